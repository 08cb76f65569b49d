"""cbfgen.load: a spec outside the library, built as a plugin, cached, and used through
the same classes as a built-in system.

The builds share the spec-crate tests' Cargo target directory (the core compiles once);
the plugin cache is this module's (the `environment` fixture, conftest.py)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import cbfgen
import numpy as np
import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
DOUBLE = REPO_ROOT / "systems" / "double_integrator" / "spec" / "double_integrator.py"
CRUISE = REPO_ROOT / "symbolic" / "tests" / "specs" / "adaptive_cruise.py"

pytestmark = pytest.mark.skipif(shutil.which("cargo") is None, reason="cbfgen.load builds with cargo")


def _spec_copy(tmp_path: Path, spec: Path) -> Path:
    """The spec in a folder of its own, as a user keeps it."""
    folder = tmp_path / "my_robot"
    folder.mkdir(exist_ok=True)
    return Path(shutil.copy(spec, folder / spec.name))


def _closed_loop(system: cbfgen.System) -> np.ndarray:
    """Test_api's moving-boundary loop: every returned input."""
    params = system.params()
    params.set("sine_barrier", {"amplitude": 0.2, "omega": 2.0, "offset": -0.5})
    safety = system.filter()
    x, inputs = np.array([0.0, 0.0]), []
    for k in range(2000):
        out = safety.update(x, [-5.0], params, k * 1e-3)
        assert out.source == "qp" and out.verdict == "met"
        inputs.append(out.u[0])
        x = x + 1e-3 * system.xdot(x, out.u)
    return np.array(inputs)


def test_a_loaded_spec_filters_bit_for_bit_as_the_same_spec_linked_in(environment, tmp_path):
    # The built-in double integrator is its spec built into a crate (systems/double_integrator),
    # linked into this module; the same file loaded as a plugin must give the same inputs to
    # the last bit, through the same generic classes.
    loaded = cbfgen.load(_spec_copy(tmp_path, DOUBLE), progress=False)
    linked = cbfgen.System("double_integrator")
    assert (loaded.nx, loaded.nu, loaded.state_names, loaded.families) == (
        linked.nx, linked.nu, linked.state_names, linked.families)
    np.testing.assert_array_equal(_closed_loop(loaded), _closed_loop(linked))
    # Its objects are its own: parameters of the linked system are refused, by name.
    with pytest.raises(cbfgen.CbfError, match="parameters of system double_integrator"):
        loaded.filter().update([0.0, 0.0], [0.0], linked.params())


def test_a_loaded_filter_states_the_worst_case_the_linked_one_does_and_no_update_passes_it(environment, tmp_path):
    # The worst case crosses the plugin ABI (filter_worst_case, filter_calibrate): the loaded
    # spec states what the linked-in one does, field for field, under the same settings;
    # every update's counted work is within it, and with a calibration it is the counts
    # times the rates.
    loaded = cbfgen.load(_spec_copy(tmp_path, DOUBLE), progress=False)
    linked = cbfgen.System("double_integrator")
    for settings in ({}, {"dense_max_work": 5000}, {"backend": "dense"}):
        stated = [system.filter(**settings).worst_case() for system in (loaded, linked)]
        assert stated[0] == stated[1], settings
        worst = stated[0]
        assert worst["row_ops"] == 15  # the sine barrier's kernel, counted in Rust
        if "dense_max_work" in settings:
            assert 5000 < worst["dense_trips"] < 10**6
        params = loaded.params()
        params.set("sine_barrier", {"amplitude": 0.2, "omega": 2.0, "offset": -0.5})
        safety, x = loaded.filter(**settings), np.array([0.0, 0.0])
        for k in range(300):
            out = safety.update(x, [-5.0], params, k * 1e-3)
            assert all(out.work[key] <= worst[key] for key in ("qp_solves", "dense_trips", "osqp_iterations"))
            x = x + 1e-3 * loaded.xdot(x, out.u)
    safety = loaded.filter()
    rates = safety.calibrate([0.0, 0.0], params)
    assert set(rates) == {"ns_per_dense_trip", "ns_per_osqp_iteration", "ns_per_row_op", "ns_per_interval_op"}
    assert rates.pop("ns_per_interval_op") == 0.0  # no certificate: no enclosure timed
    assert all(np.isfinite(v) and v > 0 for v in rates.values()), rates
    rates["ns_per_interval_op"] = 0.0
    timed = safety.worst_case(rates)
    by_hand = (timed["dense_trips"] * rates["ns_per_dense_trip"] + timed["osqp_iterations"]
               * rates["ns_per_osqp_iteration"] + timed["row_ops"] * rates["ns_per_row_op"]) * 1e-3
    assert timed["cpu_time_us"] == pytest.approx(by_hand, rel=1e-12)
    assert timed["interval_ops"] == 0
    # With the certificate (linked in: the plugin ABI does not carry it) the enclosures
    # state their interval operations; timed only at a rate measured with the certificate.
    certified = linked.filter(sample_period=1e-3)
    worst = certified.worst_case(rates)
    assert worst["enclosures"] > 0 and worst["qp_solves"] > 1 and worst["interval_ops"] > 0
    assert worst["cpu_time_us"] is None  # the rates above timed no enclosure
    params = linked.params()
    params.set("sine_barrier", {"amplitude": 0.2, "omega": 2.0, "offset": -0.5})
    rates = certified.calibrate([0.0, 0.0], params)
    assert rates["ns_per_interval_op"] > 0
    timed = certified.worst_case(rates)
    by_hand = (timed["dense_trips"] * rates["ns_per_dense_trip"] + timed["osqp_iterations"]
               * rates["ns_per_osqp_iteration"] + timed["row_ops"] * rates["ns_per_row_op"]
               + timed["interval_ops"] * rates["ns_per_interval_op"]) * 1e-3
    assert timed["cpu_time_us"] == pytest.approx(by_hand, rel=1e-12)
    with pytest.raises(ValueError, match="ns_per_row_op"):
        certified.worst_case({"ns_per_dense_trip": 1.0, "ns_per_osqp_iteration": 1.0})
    with pytest.raises(ValueError, match="not a finite rate"):
        certified.worst_case({**rates, "ns_per_row_op": float("nan")})


def test_a_second_load_hits_the_cache_and_a_changed_spec_rebuilds(environment, tmp_path):
    spec = _spec_copy(tmp_path, CRUISE)
    first = cbfgen.load(spec, progress=False)
    libraries = sorted((environment / "plugins").glob("adaptive_cruise-*/*.so"))
    assert len(libraries) == 1
    built = libraries[0].stat().st_mtime_ns
    again = cbfgen.load(spec, progress=False)
    assert again.families == first.families and libraries[0].stat().st_mtime_ns == built  # not rebuilt
    # A CLF and an extended class-K term come through the plugin as declared.
    kinds = {f["name"]: (f["kind"], f["class_k"]) for f in first.families}
    assert kinds["speed_goal"][0] == "lyapunov" and "tanh" in kinds["standstill_gap"][1]
    # The spec changes (the CLF's rate): a new build, with the new default.
    spec.write_text(spec.read_text().replace("rate=2.0", "rate=3.0"))
    changed = cbfgen.load(spec, progress=False)
    assert len(list((environment / "plugins").glob("adaptive_cruise-*/*.so"))) == 2
    assert {f["name"]: f["poles"] for f in changed.families}["speed_goal"] == [3.0]


def test_a_warm_load_runs_no_spec_and_a_changed_dependency_runs_it_again(environment, tmp_path, monkeypatch):
    # The spec takes its CLF rate from a module beside it (a recorded dependency).
    spec = _spec_copy(tmp_path, CRUISE)
    (spec.parent / "cruise_rates.py").write_text("SPEED_GOAL_RATE = 2.0\n")
    text = spec.read_text().replace("from symbolic.spec import", "import cruise_rates\nfrom symbolic.spec import", 1)
    spec.write_text(text.replace("rate=2.0", "rate=cruise_rates.SPEED_GOAL_RATE"))
    first = cbfgen.load(spec, progress=False)
    runs = []
    real_generate = cbfgen.plugins._generate

    def counted(source, path):
        runs.append(path)
        return real_generate(source, path)

    monkeypatch.setattr(cbfgen.plugins, "_generate", counted)
    again = cbfgen.load(spec, progress=False)
    assert runs == [] and again.families == first.families  # the index found it: the spec did not run
    # The dependency changes, the spec file does not: the spec runs again and builds anew.
    (spec.parent / "cruise_rates.py").write_text("SPEED_GOAL_RATE = 3.0\n")
    changed = cbfgen.load(spec, progress=False)
    assert runs == [spec.resolve()]
    assert {f["name"]: f["poles"] for f in changed.families}["speed_goal"] == [3.0]
    # Back to the first rate: the first build is found again, by running the spec once more.
    (spec.parent / "cruise_rates.py").write_text("SPEED_GOAL_RATE = 2.0\n")
    assert {f["name"]: f["poles"] for f in cbfgen.load(spec, progress=False).families}["speed_goal"] == [2.0]
    assert len(runs) == 2


def test_a_loaded_clf_is_reported_as_convergence_never_as_safety(environment, tmp_path):
    system = cbfgen.load(_spec_copy(tmp_path, CRUISE), progress=False)
    params = system.params()
    params.set("standstill_gap", {"z_min": 5.0})
    params.set("speed_goal", {"v_desired": 24.0})
    safety = system.filter()
    # 45 m behind a car 6 m/s slower, the headway asks for braking while the speed goal
    # (24 m/s) asks for more speed: the headway holds, the CLF gives way to it, reported.
    out = safety.update([20.0, 45.0, 14.0], [0.0], params)
    assert out.verdict == "met" and out.convergence == "relaxed" and out.u[0] < 0.0
    assert [(r["place"][0], r["cause"]) for r in out.relaxed] == [("speed_goal", "higher_priority")]


def test_a_loaded_specs_kernels_are_in_the_table_and_agree_with_symengine(environment, tmp_path):
    # Through the plugin's C ABI, each kernel of the loaded spec against SymEngine's numeric
    # evaluation of the same spec's expressions.
    from symbolic.codegen.definition import define
    from symbolic.spec import load as load_spec
    from symbolic.tests.symengine_reference import SymEngineReference

    spec = _spec_copy(tmp_path, CRUISE)
    system = cbfgen.load(spec, progress=False)
    kernels = define(load_spec(spec)).kernels()
    table = {name: (inputs, outputs) for module, name, inputs, outputs in cbfgen.kernel_table()
             if module == system.name}
    assert sorted(table) == sorted(k.name for k in kernels)
    rng = np.random.default_rng(7)
    for kernel in kernels:
        reference = SymEngineReference(kernel)
        inputs, outputs = table[kernel.name]
        assert inputs == [(i.name, len(i.symbols)) for i in kernel.inputs]
        for _ in range(50):
            values = {i.name: rng.uniform(1.0, 30.0, len(i.symbols)) for i in kernel.inputs}
            got = cbfgen.call_kernel(system.name, kernel.name, reference.flat_inputs(values))
            want = np.concatenate([reference(values)[name] for name, _ in outputs])
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12, err_msg=kernel.name)
    with pytest.raises(KeyError, match="no generated kernel"):
        cbfgen.call_kernel(system.name, "no_such_kernel", [])
    with pytest.raises(cbfgen.CbfError, match="too many kernel inputs"):
        cbfgen.call_kernel(system.name, kernels[0].name, [1.0] * 99)
    with pytest.raises(cbfgen.CbfError, match="kernel inputs: expected length"):
        cbfgen.call_kernel(system.name, kernels[0].name, [])


def test_missing_tools_and_sources_are_one_line_naming_the_fix(environment, tmp_path, monkeypatch):
    spec = _spec_copy(tmp_path, DOUBLE)
    monkeypatch.setenv("CBFGEN_SOURCE", str(tmp_path))
    with pytest.raises(cbfgen.LoadError, match="is not a clone of cbfgen"):
        cbfgen.load(spec, progress=False)
    monkeypatch.setenv("CBFGEN_SOURCE", str(REPO_ROOT))
    monkeypatch.setenv("CBFGEN_CACHE", str(tmp_path / "empty-cache"))
    monkeypatch.setenv("PATH", str(tmp_path))  # no cargo
    with pytest.raises(cbfgen.LoadError, match=r"cargo is not on PATH: install Rust \(https://rustup.rs\)"):
        cbfgen.load(spec, progress=False)
    with pytest.raises(cbfgen.LoadError, match="no spec file"):
        cbfgen.load(tmp_path / "nothing.py")


def test_the_sources_are_found_from_the_spec_or_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.delenv("CBFGEN_SOURCE", raising=False)
    inside = REPO_ROOT / "systems" / "double_integrator" / "spec"
    assert cbfgen.plugins.source_dir(inside) == REPO_ROOT
    monkeypatch.chdir(inside)
    assert cbfgen.plugins.source_dir(tmp_path) == REPO_ROOT


def test_with_no_clone_anywhere_the_embedded_core_builds_the_same_plugin(environment, tmp_path, monkeypatch):
    # An installed wheel, its clone gone: the sources embedded in the module are written
    # into the cache as a crate of their own and the spec builds against them.
    monkeypatch.delenv("CBFGEN_SOURCE", raising=False)
    monkeypatch.chdir(tmp_path)
    spec = _spec_copy(tmp_path, DOUBLE)
    source = cbfgen.plugins.source_dir(spec.parent)
    assert source.is_relative_to(environment / "source")
    # The embedded files are the repository's, byte for byte (the manifest made standalone).
    embedded = dict(cbfgen._native.core_sources())
    wanted = {"Cargo.toml", "Cargo.lock", "rustfmt.toml", "src/lib.rs", "cbfgen-build/Cargo.toml", "symbolic/spec.py",
              "capi/include/cbfgen/cbfgen.hpp", "capi/cmake/cbfgenConfig.cmake"}  # cbfgen.embed's, for a spec
    assert wanted <= embedded.keys()
    for path, data in embedded.items():
        assert data == (REPO_ROOT / path).read_bytes(), path
        if path != "Cargo.toml":
            assert (source / path).read_bytes() == data, path
    manifest = (source / "Cargo.toml").read_text()
    assert "[workspace]\n" in manifest and "members" not in manifest
    loaded = cbfgen.load(spec, progress=False)
    np.testing.assert_array_equal(_closed_loop(loaded), _closed_loop(cbfgen.System("double_integrator")))
    assert cbfgen.plugins.source_dir(spec.parent) == source  # written once


MISTAKEN_SPEC = '''from symbolic.spec import System


def build() -> System:
    s = System("mistaken")
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    {family}
    return s
'''


@pytest.mark.parametrize("family, says", [
    # Found while differentiating: the generator's own check, before any compile.
    ('s.family("limit", lambda q: 1 + 0 * p, poles=[5.0, 5.0])', "family 'limit': row 'limit' depends on no state"),
    # A keyword of an older release, and what replaced it.
    ('s.family("limit", lambda q: 1 - p, slack_weight=100.0)',
     "family 'limit': slack_weight= was removed; priorities replaced slack weights: give the family priority=N"),
])
def test_a_spec_mistake_is_reported_with_its_file_and_line_before_anything_compiles(environment, tmp_path,
                                                                                      monkeypatch, family, says):
    spec = tmp_path / "mistaken.py"
    spec.write_text(MISTAKEN_SPEC.format(family=family))

    def no_build(*args):
        raise AssertionError("cbfgen.load compiled a spec the generator refuses")

    monkeypatch.setattr(cbfgen.plugins, "_build", no_build)
    with pytest.raises(cbfgen.LoadError) as refused:
        cbfgen.load(spec, progress=False)
    message = str(refused.value)
    assert message.startswith(f"cbfgen.load: {spec}:9: ") and says in message, message


def test_a_warm_load_reads_no_unchanged_data_file_and_a_changed_one_rebuilds(environment, tmp_path, monkeypatch):
    # A spec naming a large data file (as a robot's meshes would be), settled on disk.
    spec = _spec_copy(tmp_path, DOUBLE)
    spec.write_text(spec.read_text().replace("    return s\n", '    s.depends_on("robot.bin")\n    return s\n', 1))
    data = spec.parent / "robot.bin"
    data.write_bytes(bytes(range(256)) * 32768)  # 8 MiB
    an_hour_ago = data.stat().st_mtime - 3600
    os.utime(data, (an_hour_ago, an_hour_ago))
    first = cbfgen.load(spec, progress=False)
    read = []
    real_read = Path.read_bytes

    def counted(self):
        read.append(self)
        return real_read(self)

    monkeypatch.setattr(Path, "read_bytes", counted)
    cbfgen.plugins._Digests._open.clear()  # as a new process: the digests from the cache's file
    assert cbfgen.load(spec, progress=False).families == first.families
    assert data not in read, "a warm load read the unchanged data file"
    # The same size, other bytes, another time: read again, and built anew.
    data.write_bytes(bytes(reversed(range(256))) * 32768)
    os.utime(data, (an_hour_ago + 60, an_hour_ago + 60))
    libraries = len(list((environment / "plugins").glob("double_integrator-*/*.so")))
    cbfgen.load(spec, progress=False)
    assert data in read
    assert len(list((environment / "plugins").glob("double_integrator-*/*.so"))) == libraries + 1


def test_a_loaded_filter_takes_its_parameters_capacities_and_a_mismatch_names_the_fix(environment, tmp_path):
    robot = cbfgen.load(_spec_copy(tmp_path, REPO_ROOT / "symbolic" / "tests" / "specs" / "planar_robot.py"),
                        progress=False)
    def ready(capacity):
        params = robot.params({"wall": capacity})
        params.set("speed_limit", {"vmax": 2.0})
        return params

    params = ready(3)
    x, u_ref = np.zeros(robot.nx), np.zeros(robot.nu)
    for safety in (robot.filter(params), robot.filter()):  # from the parameters, or from the first update's
        safety.update(x, u_ref, params)
        assert safety.row_count == len(robot.rows(x, params))
        # Through the plugin too, the mismatch says how to avoid it.
        with pytest.raises(cbfgen.CbfError, match=r"other capacities than the filter: build the filter from the "
                                                  r"parameters, system.filter\(params\)"):
            safety.update(x, u_ref, ready(1))
