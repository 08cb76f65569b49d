"""A spec's own dependencies: modules it imports from its folder and data files it names
with System.depends_on are part of the generated file's inputs hash and header; editing
one changes the hash, moving the folder as a whole does not."""

from __future__ import annotations

import hashlib
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from symbolic.codegen.generate import render
from symbolic.generate import REPO_ROOT
from symbolic.inputs_hash import inputs_hash
from symbolic.spec import SpecError, load

# A spec whose numbers come from a data file, whose model comes from a sibling module
# and whose barrier comes from a package folder beside it.
SPEC = '''
import tomllib
from pathlib import Path

from my_robot_model import declare
from shapes.walls import wall_barrier

from symbolic.spec import System


def build() -> System:
    numbers = tomllib.loads((Path(__file__).parent / "data" / "robot.toml").read_text())
    s = System("dep_robot", doc="A spec with helpers beside it.")
    p, v = declare(s, numbers["jerk_max"])
    s.family("wall", wall_barrier(p), params={"p_max": ()}, poles=numbers["poles"], doc="p below p_max.")
    s.depends_on("data/robot.toml")
    return s
'''
MODEL = '''
def declare(s, u_max):
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-u_max, u_max)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    return p, v
'''
WALLS = '''
def wall_barrier(p):
    return lambda prm: prm.p_max - p
'''
DATA = 'jerk_max = 3.0\npoles = [2.0, 3.0]\n'


def _folder(root: Path) -> Path:
    """The spec and its helpers in ``root/robot``; returns the spec file."""
    folder = root / "robot"
    (folder / "shapes").mkdir(parents=True)
    (folder / "data").mkdir()
    (folder / "spec.py").write_text(SPEC)
    (folder / "my_robot_model.py").write_text(MODEL)
    (folder / "shapes" / "__init__.py").write_text("")
    (folder / "shapes" / "walls.py").write_text(WALLS)
    (folder / "data" / "robot.toml").write_text(DATA)
    (folder / "unused.py").write_text("raise RuntimeError('never imported')\n")
    return folder / "spec.py"


def _header(text: str) -> tuple[str, list[str]]:
    """(inputs hash, depends lines) of a generated file."""
    lines = text.splitlines()
    digest = re.fullmatch(r"// inputs-sha256: ([0-9a-f]{64})", lines[1]).group(1)
    return digest, [line.removeprefix("// depends: ") for line in lines if line.startswith("// depends: ")]


def _expected(spec: Path, rels: list[str], runtime: str = "cbfgen") -> str:
    """The hash by its documented byte layout, computed here from the files themselves."""
    h = hashlib.sha256()
    h.update(b"cbfgen-spec\0" + inputs_hash(REPO_ROOT).encode() + b"\0" + spec.read_bytes() + b"\0"
             + runtime.encode() + b"\0")
    for rel in sorted(rels):
        h.update(rel.encode() + b"\0" + (spec.parent / rel).read_bytes() + b"\0")
    return h.hexdigest()


DEPS = ["data/robot.toml", "my_robot_model.py", "shapes/__init__.py", "shapes/walls.py"]


def test_imported_modules_and_named_files_are_the_dependencies(tmp_path):
    spec = _folder(tmp_path)
    system = load(spec)
    assert system.dependencies == sorted((spec.parent / rel).resolve() for rel in DEPS)
    # The folder's modules are not left imported, and the folder is off sys.path again.
    assert "my_robot_model" not in sys.modules and "shapes" not in sys.modules
    assert str(spec.parent.resolve()) not in sys.path
    assert not list(spec.parent.rglob("__pycache__"))
    digest, depends = _header(render(spec)[1])
    assert depends == DEPS
    assert digest == _expected(spec, DEPS)


def test_editing_a_module_or_a_data_file_changes_the_hash_and_moving_the_folder_does_not(tmp_path):
    spec = _folder(tmp_path / "a")
    first, _ = _header(render(spec)[1])
    moved = tmp_path / "elsewhere" / "deeper"
    moved.mkdir(parents=True)
    shutil.move(spec.parent, moved)
    spec = moved / "robot" / "spec.py"
    assert _header(render(spec)[1])[0] == first
    # In another process too (nothing of the first import is reused).
    code = f"from symbolic.codegen.generate import render; print(render({str(spec)!r})[1])"
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, check=True)
    assert _header(done.stdout)[0] == first

    model = spec.parent / "my_robot_model.py"
    model.write_text(MODEL + "# a comment only\n")
    edited_model, _ = _header(render(spec)[1])
    assert edited_model not in (first, _expected(spec, [r for r in DEPS if r != "my_robot_model.py"]))
    assert edited_model == _expected(spec, DEPS)

    data = spec.parent / "data" / "robot.toml"
    data.write_text(DATA.replace("3.0", "3.5"))
    edited_data, _ = _header(render(spec)[1])
    assert edited_data not in (first, edited_model)
    assert edited_data == _expected(spec, DEPS)
    # The edit reached the system: the input limit is the data file's new number.
    assert load(spec).input_limits[0].upper == 3.5

    (spec.parent / "shapes" / "walls.py").write_text(WALLS + "\n")
    assert _header(render(spec)[1])[0] not in (first, edited_model, edited_data)


def test_two_specs_in_one_folder_both_see_a_shared_module(tmp_path):
    spec = _folder(tmp_path)
    twin = spec.with_name("twin.py")
    twin.write_text(SPEC.replace('"dep_robot"', '"dep_twin"'))
    assert load(spec).dependencies == load(twin).dependencies


def test_a_spec_without_helpers_has_no_dependencies(tmp_path):
    spec = tmp_path / "plain.py"
    spec.write_text((REPO_ROOT / "symbolic" / "tests" / "specs" / "triple_integrator.py").read_text())
    assert load(spec).dependencies == []
    assert _header(render(spec)[1]) == (_expected(spec, []), [])


def test_depends_on_a_missing_file_names_the_system(tmp_path):
    spec = _folder(tmp_path)
    spec.write_text(SPEC.replace('s.depends_on("data/robot.toml")', 's.depends_on("data/missing.toml")'))
    with pytest.raises(SpecError, match=r"system 'dep_robot': depends_on\('data/missing.toml'\): .*is not a file"):
        load(spec)
    spec.write_text(SPEC.replace('s.depends_on("data/robot.toml")', 's.depends_on("data")'))
    with pytest.raises(SpecError, match=r"system 'dep_robot': depends_on\('data'\).*is not a file"):
        load(spec)
    spec.write_text(SPEC.replace('s.depends_on("data/robot.toml")', 's.depends_on(42)'))
    with pytest.raises(SpecError, match=r"system 'dep_robot': depends_on takes file paths"):
        load(spec)


def test_an_absolute_depends_on_path_is_recorded_relative_to_the_spec(tmp_path):
    spec = _folder(tmp_path / "crate")
    shared = tmp_path / "crate" / "config" / "limits.toml"
    shared.parent.mkdir()
    shared.write_text("x = 1\n")
    spec.write_text(SPEC.replace('s.depends_on("data/robot.toml")',
                                 f's.depends_on("data/robot.toml", {str(shared)!r})'))
    digest, depends = _header(render(spec)[1])
    assert depends == ["../config/limits.toml", *DEPS]
    assert digest == _expected(spec, ["../config/limits.toml", *DEPS])


def test_the_command_line_prints_the_dependencies_before_the_generated_file(tmp_path):
    spec = _folder(tmp_path)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(spec), "--out", str(out)],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[-1] == f"generated {out / 'dep_robot.rs'}"
    assert lines[:-1] == [f"depends {(spec.parent / rel).resolve()}" for rel in DEPS]
