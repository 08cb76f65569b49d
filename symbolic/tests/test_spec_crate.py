"""The public build path end to end: a crate outside the repository (copied to a
temporary directory) generates the test specs with cbfgen-build in its build.rs and runs
closed loops on them with the generic filter (symbolic/tests/spec_crate/tests/)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
FIXTURE = Path(__file__).resolve().parent / "spec_crate"


def _crate(tmp_path: Path, build_rs: str | None = None, lib_rs: str | None = None,
           keep_tests: bool = False) -> Path:
    """The fixture crate in ``tmp_path``, optionally with another build.rs / lib.rs."""
    crate = tmp_path / "spec_crate"
    shutil.copytree(FIXTURE, crate)
    for template in crate.glob("*.in"):
        template.with_suffix("").write_text(template.read_text().replace("@REPO@", str(REPO_ROOT)))
        template.unlink()
    if build_rs is not None:
        (crate / "build.rs").write_text(build_rs.replace("@REPO@", str(REPO_ROOT)))
    if lib_rs is not None:
        (crate / "src" / "lib.rs").write_text(lib_rs)
    if not keep_tests:
        shutil.rmtree(crate / "tests")
    return crate


def _cargo(crate: Path, python: str, *args: str, allow_stale: bool = False) -> subprocess.CompletedProcess:
    """Cargo in ``crate`` with ``python`` as the generator's interpreter; the target dir is
    shared across runs (a cold build of cbfgen takes about a minute, a warm one seconds)."""
    env = {**os.environ, "CARGO_TARGET_DIR": str(REPO_ROOT / "target" / "spec-crates"), "CBFGEN_PYTHON": python}
    env.pop("CBFGEN_ALLOW_STALE", None)
    if allow_stale:
        env["CBFGEN_ALLOW_STALE"] = "1"
    venv_bin = REPO_ROOT / ".venv" / "bin"
    if venv_bin.is_dir():
        env["PATH"] = f"{venv_bin}{os.pathsep}{env.get('PATH', '')}"  # cmake, for OSQP's C sources
    return subprocess.run(["cargo", *args], cwd=crate, env=env, capture_output=True, text=True)


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo")
def test_without_python_the_build_fails_with_one_line_naming_the_fix(tmp_path):
    done = _cargo(_crate(tmp_path), str(tmp_path / "no-such-python"), "build", "--release")
    assert done.returncode != 0
    errors = [line for line in done.stderr.splitlines() if line.startswith("error")]
    assert errors and "cbfgen-build: cannot start Python" in errors[0], done.stderr[-3000:]
    assert "pip install symengine==" in errors[0] and "CBFGEN_PYTHON" in errors[0]


CHECKED_IN_BUILD = """
fn main() {
    cbfgen_build::Generator::new()
        .spec("spec/robot.py")
        .checked_in("generated")
        .build();
}
"""
CHECKED_IN_LIB = """//! A checked-in system.

/// The triple integrator, from the committed file.
pub mod triple_integrator {
    include!("../generated/triple_integrator.rs");
}
"""
# The crate's spec imports its model from a sibling module and names a data file it
# depends on: both are the generated file's inputs.
CHECKED_IN_SPEC = """from triple_integrator_model import build as build_model


def build():
    s = build_model()
    s.depends_on("limits.toml")
    return s
"""


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo")
def test_checked_in_mode_writes_beside_the_crate_and_builds_without_python_while_current(tmp_path):
    crate = _crate(tmp_path, CHECKED_IN_BUILD, CHECKED_IN_LIB)
    spec = crate / "spec"
    spec.mkdir()
    (spec / "robot.py").write_text(CHECKED_IN_SPEC)
    shutil.copy(FIXTURE.parent / "specs" / "triple_integrator.py", spec / "triple_integrator_model.py")
    limits = spec / "limits.toml"
    limits.write_text("p_max = 1.0\n")
    no_python = str(tmp_path / "no-such-python")

    first = _cargo(crate, sys.executable, "build", "--release")
    assert first.returncode == 0, first.stderr[-3000:]
    written = crate / "generated" / "triple_integrator.rs"
    text = written.read_text()
    assert text.startswith("// @generated")
    assert "// depends: limits.toml\n// depends: triple_integrator_model.py\n" in text
    assert not list(spec.rglob("__pycache__"))  # nothing written beside the spec
    # Without Python the committed file is checked, found current, and used as it is.
    second = _cargo(crate, no_python, "build", "--release")
    assert second.returncode == 0, second.stderr[-3000:]
    assert "stale" not in second.stderr and written.read_text() == text

    # A data file the spec depends on changes: without Python the build stops with one
    # line giving the command that regenerates the file...
    limits.write_text("p_max = 2.0\n")
    stale = _cargo(crate, no_python, "build", "--release")
    assert stale.returncode != 0
    errors = [line for line in stale.stderr.splitlines() if line.startswith("error")]
    assert errors and "triple_integrator.rs is stale" in errors[0], stale.stderr[-3000:]
    assert "python3 -m symbolic generate spec/robot.py --out generated --runtime-crate cbfgen" in errors[0]
    assert "CBFGEN_ALLOW_STALE=1" in errors[0]
    # ...unless the stale file is allowed, with a warning.
    allowed = _cargo(crate, no_python, "build", "--release", allow_stale=True)
    assert allowed.returncode == 0, allowed.stderr[-3000:]
    assert "CBFGEN_ALLOW_STALE=1: building with the stale" in allowed.stderr
    # With Python the file is regenerated: only its inputs hash changes.
    third = _cargo(crate, sys.executable, "build", "--release")
    assert third.returncode == 0, third.stderr[-3000:]
    regenerated = written.read_text()
    assert regenerated.splitlines()[1] != text.splitlines()[1]
    assert regenerated.splitlines()[2:] == text.splitlines()[2:]
    # The data file alone changing (nothing else, not the environment) reruns the build
    # script: the generator's `depends` lines reached Cargo.
    limits.write_text("p_max = 3.0\n")
    fourth = _cargo(crate, sys.executable, "build", "--release")
    assert fourth.returncode == 0, fourth.stderr[-3000:]
    assert written.read_text().splitlines()[1] not in (text.splitlines()[1], regenerated.splitlines()[1])
    # A sibling module's edit makes the file stale too.
    model = spec / "triple_integrator_model.py"
    model.write_text(model.read_text() + "\n# edited\n")
    assert _cargo(crate, no_python, "build", "--release").returncode != 0


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo")
def test_an_outside_crate_builds_its_specs_and_filters_safely(tmp_path):
    crate = _crate(tmp_path, keep_tests=True)
    done = _cargo(crate, sys.executable, "test", "--release", "--quiet")
    assert done.returncode == 0, (done.stdout + done.stderr)[-6000:]
    # Both generated modules went to OUT_DIR only: nothing was written beside the crate.
    assert sorted(p.name for p in crate.iterdir()) == ["Cargo.lock", "Cargo.toml", "build.rs", "src", "tests"]
