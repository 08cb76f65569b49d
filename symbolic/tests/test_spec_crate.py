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


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo")
def test_an_outside_crate_builds_its_specs_and_filters_safely(tmp_path):
    crate = tmp_path / "spec_crate"
    shutil.copytree(FIXTURE, crate)
    for template in crate.glob("*.in"):
        template.with_suffix("").write_text(template.read_text().replace("@REPO@", str(REPO_ROOT)))
        template.unlink()
    env = {**os.environ, "CARGO_TARGET_DIR": str(REPO_ROOT / "target" / "spec-crates"),
           "CBFGEN_PYTHON": sys.executable}
    venv_bin = REPO_ROOT / ".venv" / "bin"
    if venv_bin.is_dir():
        env["PATH"] = f"{venv_bin}{os.pathsep}{env.get('PATH', '')}"  # cmake, for OSQP's C sources
    done = subprocess.run(["cargo", "test", "--release", "--quiet"], cwd=crate, env=env,
                          capture_output=True, text=True)
    assert done.returncode == 0, (done.stdout + done.stderr)[-6000:]
    # Both generated modules went to OUT_DIR only: nothing was written beside the crate.
    assert sorted(p.name for p in crate.iterdir()) == ["Cargo.lock", "Cargo.toml", "build.rs", "src", "tests"]
