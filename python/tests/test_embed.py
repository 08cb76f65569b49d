"""cbfgen from C and C++: systems installed by ``cbfgen.embed`` (a built-in one and a user's
spec), the C header compiled strictly, a C closed loop against the Rust filter bit for bit,
bad C calls answered with codes and messages, the C++ wrapper's error path, and the
example controller built as an outside CMake project with ``find_package``.

The installs share the spec-crate tests' Cargo target directory (the core compiles once).
Needs gcc, g++, CMake and Eigen 3: ``scripts/cbf setup`` installs the last two."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import cbfgen
import numpy as np
import pytest
from cbfgen import embed

REPO_ROOT = Path(__file__).resolve().parents[2]
CAPI = REPO_ROOT / "capi"
YOUR_ROBOT = REPO_ROOT / "examples" / "your_robot" / "spec" / "your_robot.py"
STRICT_C = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
STRICT_CXX = ["-std=c++17", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]


def _cmake() -> str:
    cmake = shutil.which("cmake") or str(Path(sys.executable).parent / "cmake")
    assert Path(cmake).is_file() or shutil.which(cmake), "CMake is missing: run scripts/cbf setup"
    return cmake


@pytest.fixture(scope="module")
def prefix(environment, tmp_path_factory):
    """double_integrator (built in) and your_robot (a spec) installed into a fresh prefix."""
    folder = tmp_path_factory.mktemp("prefix")
    assert embed.install(["double_integrator", str(YOUR_ROBOT)], folder, progress=False) == [
        "double_integrator", "your_robot"]
    return folder


def _run(args: list, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600, **kwargs)


def _c_program(prefix: Path, source: Path, out: Path) -> Path:
    """``source`` compiled as strict C99 and linked with the double integrator's static
    library and the system libraries it needs (as the installed CMake package lists them)."""
    cmake_file = (prefix / "lib" / "cmake" / "cbfgen" / "cbfgen_system_double_integrator.cmake").read_text()
    native = re.search(r'"cbfgen::c;([^"]*)"', cmake_file).group(1).split(";")
    built = _run(["gcc", *STRICT_C, f"-I{prefix / 'include'}", source,
                  prefix / "lib" / "libcbfgen_double_integrator.a", *[f"-l{n}" for n in native], "-o", out])
    assert built.returncode == 0, built.stderr
    return out


def test_the_install_has_headers_libraries_and_the_cmake_package(prefix):
    for path in ["include/cbfgen/abi.h", "include/cbfgen/cbfgen.h", "include/cbfgen/cbfgen.hpp",
                 "include/cbfgen/systems/double_integrator.h", "include/cbfgen/systems/your_robot.h",
                 "lib/libcbfgen_double_integrator.a", "lib/libcbfgen_your_robot.so",
                 "lib/cmake/cbfgen/cbfgenConfig.cmake", "lib/cmake/cbfgen/cbfgen_system_your_robot.cmake"]:
        assert (prefix / path).is_file(), path
    # The shared library exports the system's entry table and nothing else of cbfgen's.
    symbols = _run(["nm", "-D", "--defined-only", prefix / "lib" / "libcbfgen_your_robot.so"]).stdout
    assert re.findall(r"\bcbfgen\w*", symbols) == ["cbfgen_your_robot_plugin_v1"]
    # Its SONAME is its installed name, so programs linked against it find it by that name.
    assert "Library soname: [libcbfgen_your_robot.so]" in _run(
        ["readelf", "-d", prefix / "lib" / "libcbfgen_your_robot.so"]).stdout


def test_the_headers_compile_as_strict_c99_and_cxx17(prefix, tmp_path):
    unit = tmp_path / "unit.c"
    unit.write_text("#include <cbfgen/cbfgen.h>\n#include <cbfgen/systems/double_integrator.h>\n"
                    "#include <cbfgen/systems/your_robot.h>\n"
                    "int main(void) { return CBFGEN_ABI_VERSION > 0 ? 0 : 1; }\n")
    c = _run(["gcc", *STRICT_C, "-fsyntax-only", f"-I{prefix / 'include'}", unit])
    assert c.returncode == 0, c.stderr
    cxx_unit = tmp_path / "unit.cpp"
    cxx_unit.write_text("#include <cbfgen/cbfgen.hpp>\n#include <cbfgen/systems/your_robot.h>\nint main() {}\n")
    cxx = _run(["g++", *STRICT_CXX, "-fsyntax-only", f"-I{prefix / 'include'}", "-I/usr/include/eigen3", cxx_unit])
    assert cxx.returncode == 0, cxx.stderr
    # The header's ABI version is the core's, and the loader's.
    assert f"#define CBFGEN_ABI_VERSION {cbfgen.plugins.ABI_VERSION}\n" in (
        prefix / "include" / "cbfgen" / "abi.h").read_text()


def test_two_systems_static_libraries_link_into_one_program(prefix, tmp_path):
    """As docs/embedding.md says: static libraries of one install share the core and Rust's
    runtime (the linker keeps one copy of what they share), and each system keeps its own
    entry table: your_robot's describes your_robot, not the system linked first (before
    the tables were made per system, both entry points served the first system)."""
    unit = tmp_path / "two.c"
    unit.write_text("#include <cbfgen/systems/double_integrator.h>\n#include <cbfgen/systems/your_robot.h>\n"
                    "int main(void) {\n  cbfgen_error err = {0, 0, {0}};\n"
                    "  return cbfgen_check(cbfgen_double_integrator_plugin_v1(), &err) == 0 &&\n"
                    "         cbfgen_check(cbfgen_your_robot_plugin_v1(), &err) == 0 &&\n"
                    "         cbfgen_your_robot_plugin_v1()->describe()->nx == 4 ? 0 : 1;\n}\n")
    cmake_file = (prefix / "lib" / "cmake" / "cbfgen" / "cbfgen_system_your_robot.cmake").read_text()
    native = re.search(r'"cbfgen::c;([^"]*)"', cmake_file).group(1).split(";")
    built = _run(["gcc", *STRICT_C, f"-I{prefix / 'include'}", unit, prefix / "lib" / "libcbfgen_double_integrator.a",
                  prefix / "lib" / "libcbfgen_your_robot.a", *[f"-l{n}" for n in native], "-o", tmp_path / "two"])
    assert built.returncode == 0, built.stderr
    ran = _run([tmp_path / "two"])
    assert ran.returncode == 0, ran.stdout + ran.stderr


def test_a_c_closed_loop_gives_the_rust_filter_s_inputs_bit_for_bit(prefix, tmp_path):
    program = _c_program(prefix, CAPI / "tests" / "c" / "closed_loop.c", tmp_path / "closed_loop")
    ran = _run([program])
    assert ran.returncode == 0, ran.stderr
    steps = [[float.fromhex(v) for v in line.split()[:4]] for line in ran.stdout.splitlines()]
    assert len(steps) == 2000
    # The same loop on the Rust filter (the built-in system, linked into this module).
    system = cbfgen.System("double_integrator")
    params = system.params()
    params.set("sine_barrier", {"amplitude": 0.2, "omega": 2.0, "offset": -0.5})
    safety = system.filter(params)
    x = np.array([0.0, 0.0])
    braked = 0
    for k, (t, q, qd, u) in enumerate(steps):
        assert (t, q, qd) == (k * 1e-3, x[0], x[1]), f"step {k}: the C loop's state left the Rust loop's"
        out = safety.update(x, [-5.0], params, t=k * 1e-3)
        assert out.u[0] == u, f"step {k}: C gave {u!r}, Rust {out.u[0]!r}"
        braked += u > -5.0
        x = x + 1e-3 * system.xdot(x, out.u)
    assert braked > 100, "the loop never reached the boundary: it tests nothing of the filter"


def test_bad_c_calls_return_codes_and_messages_and_the_filter_recovers(prefix, tmp_path):
    program = _c_program(prefix, CAPI / "tests" / "c" / "bad_calls.c", tmp_path / "bad_calls")
    ran = _run([program])
    assert ran.returncode == 0, ran.stdout + ran.stderr
    lines = dict(line.split(" ", 1) for line in ran.stdout.splitlines())
    assert lines["update_null_filter"] == "100 double_integrator: filter handle is a null pointer"
    assert lines["update_wrong_state_length"] == "9 state: expected length 2, got 3"
    assert lines["report_wrong_rows"] == "9 report's active rows: expected length 1, got 2"
    assert lines["set_no_family"] == "14 no family 7: there are 1"
    assert lines["check_abi"].startswith(f"102 the system's library has cbfgen ABI {cbfgen.plugins.ABI_VERSION + 1}")
    assert "never set" in lines["update_unset_params"]
    assert float.fromhex(lines["recovered"].split()[1]) >= 23.0 - 1e-9


def _cmake_project(source: Path, prefix: Path, tmp_path: Path, *, configure_only: bool = False):
    """``source`` copied out of the repository and configured (and built) against ``prefix``
    as any outside project is."""
    project = Path(shutil.copytree(source, tmp_path / source.name))
    build = tmp_path / f"{source.name}-build"
    cmake = _cmake()
    configured = _run([cmake, "-S", project, "-B", build, f"-DCMAKE_PREFIX_PATH={prefix}",
                       "-DCMAKE_BUILD_TYPE=Release", f"-DCMAKE_CXX_FLAGS={' '.join(STRICT_CXX[1:])}"])
    if configure_only:
        return configured
    assert configured.returncode == 0, configured.stdout + configured.stderr
    built = _run([cmake, "--build", build])
    assert built.returncode == 0, built.stdout + built.stderr
    return build


def test_the_example_controller_builds_with_find_package_and_keeps_both_systems_clear(prefix, tmp_path):
    build = _cmake_project(CAPI / "examples" / "controller", prefix, tmp_path)
    ran = _run([build / "safety_filter_controller"])
    assert ran.returncode == 0, ran.stdout + ran.stderr
    for name, updates in (("double_integrator", 2000), ("your_robot", 6000)):
        line = next(line for line in ran.stdout.splitlines() if line.startswith(name))
        assert f"{updates} updates, 0 failed, 0 relaxed" in line
        clearance = float(re.search(r"min clearance (\S+) m", line).group(1))
        assert clearance >= -1e-4, line  # the 1 kHz sample-and-hold dip the example allows
    # The unicycle was driven straight at its obstacle: it came close and stayed out.
    robot = next(line for line in ran.stdout.splitlines() if line.startswith("your_robot"))
    assert float(re.search(r"min clearance (\S+) m", robot).group(1)) < 0.05


def test_the_cpp_wrapper_s_error_path(prefix, tmp_path):
    build = _cmake_project(CAPI / "tests" / "cpp", prefix, tmp_path)
    ran = _run([build / "wrapper_errors"])
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert not re.findall(r"^FAILED", ran.stdout, re.M) and len(re.findall(r"^ok ", ran.stdout, re.M)) == 16


def test_the_cpp_bench_builds_and_times_an_update(prefix, tmp_path):
    """A smoke run of scripts/bench_cpp.py's C++ side (the full run is `scripts/cbf bench-cpp`)."""
    build = _cmake_project(CAPI / "bench", prefix, tmp_path)
    ran = _run([build / "update_bench", "3", "2000"])
    assert ran.returncode == 0, ran.stdout + ran.stderr
    timed = re.fullmatch(r"update_ns wall=(\S+) cpu=(\S+) samples=3 updates=2000\n", ran.stdout)
    assert timed and 0 < float(timed.group(1)) < 1e6 and 0 < float(timed.group(2)) < 1e6, ran.stdout


def test_a_missing_system_fails_find_package_naming_the_install_command(prefix, tmp_path):
    project = tmp_path / "wants_panda"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(wants_panda CXX)\n"
        "find_package(cbfgen 0.1 REQUIRED COMPONENTS panda)\n")
    configured = _cmake_project(project, prefix, tmp_path / "x", configure_only=True)
    assert configured.returncode != 0
    said = " ".join(configured.stderr.split())  # CMake wraps its messages
    assert f"no system panda is installed in {prefix}: python -m cbfgen.embed install --prefix {prefix} panda" in said


def test_embed_refuses_what_is_neither_a_system_nor_a_spec(prefix, tmp_path):
    with pytest.raises(cbfgen.LoadError, match=r"'pandas' is neither a built-in system \(anymal, .*\) nor a spec"):
        embed.install(["pandas"], tmp_path, progress=False)


def test_without_a_clone_a_built_in_system_names_the_fix(environment, tmp_path, monkeypatch):
    monkeypatch.delenv("CBFGEN_SOURCE", raising=False)
    monkeypatch.chdir(tmp_path)  # an installed wheel, no clone around: the embedded sources
    with pytest.raises(cbfgen.LoadError, match=r"the built-in system panda is built from its crate in a clone of "
                                               r"cbfgen, .* \(a spec file needs no clone\)"):
        embed.install(["panda"], tmp_path / "prefix", progress=False)


def test_embed_knows_every_built_in_system_and_the_core_s_version():
    names = _run([sys.executable, "-c", "import cbfgen; print(' '.join(cbfgen.systems()))"]).stdout.split()
    assert sorted(embed.BUILT_IN) == sorted(names)
    workspace = tomllib.loads((REPO_ROOT / "Cargo.toml").read_text())["workspace"]["package"]
    assert embed.VERSION == workspace["version"]
