"""The Python API's behaviour: a Python control loop reproduces the Rust one, filter
outputs satisfy the ECBF rows they report, and bad input raises instead of panicking."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")


def python_loop(scenario: str, seconds: float, **filter_kwargs):
    course = cbfgen.Course(scenario)
    safety = cbfgen.EcbfFilter(**filter_kwargs)
    x = course.initial_state()
    xs = []
    for k in range(round(seconds / cbfgen.DT)):
        xs.append(x)
        out = safety.update(x, course.plan(k * cbfgen.DT, x), course.environment)
        x = x + cbfgen.DT * cbfgen.xdot(x, out.u)
    return np.array(xs), safety


def test_a_python_loop_reproduces_the_rust_simulation():
    # Same gait, filter and Euler step on either side of the boundary: the trajectories
    # must agree to the last bit, which checks Course, EcbfFilter and xdot together.
    seconds = 3.0
    rust = cbfgen.simulate("step", body_cbf=True, max_time=seconds)
    xs, _ = python_loop("step", seconds)
    assert rust["x"].shape == xs.shape == (round(seconds / cbfgen.DT), cbfgen.NX)
    np.testing.assert_array_equal(rust["x"], xs)


def test_simulation_arrays_are_consistent():
    run = cbfgen.simulate("step", max_time=0.5)
    n = len(run["t"])
    assert n == 500 and np.allclose(np.diff(run["t"]), cbfgen.DT)
    assert run["x"].shape == (n, cbfgen.NX) and run["min_h"].shape == (n, len(cbfgen.FAMILIES))
    np.testing.assert_allclose(run["body_z_world"], run["x"][:, 2] + run["x"][:, cbfgen.STATE_NAMES.index("bz")])
    assert set(run["summary"]["min_h"]) == set(cbfgen.FAMILIES)
    assert np.all((run["source"] >= 0) & (run["source"] < len(cbfgen.INPUT_SOURCES)))


def test_filtered_input_satisfies_every_active_ecbf_row():
    # Stop the drive next to the step, where body, toe and joint rows are active, and
    # check the QP's constraints from the rows the filter reports, in Python.
    _, safety = python_loop("step", 6.0)
    out = safety.output
    assert out.source == "qp" and out.polished
    u, lie, lg, slack = out.u, safety.lie, safety.lg_lf, safety.slack
    active = np.array(safety.active)
    assert active.sum() == out.active_rows > 0
    p1, p2 = 20.0, 20.0  # the model's default ECBF poles
    bound = -(lie[:, 2] + (p1 + p2) * lie[:, 1] + p1 * p2 * lie[:, 0])
    lhs = lg @ u + slack
    assert np.all(lhs[active] >= bound[active] - 1e-6 * (1 + np.abs(bound[active])))
    limits = np.array(cbfgen.INPUT_LIMITS)
    assert np.all(np.abs(u) <= limits + 1e-12)


def test_rows_match_the_filter_catalog():
    # The family functions and the filter evaluate the same kernels at the same state.
    x = cbfgen.standard_posture()
    env = cbfgen.Environment()
    env.floor_z = np.full(6, 0.0)
    safety = cbfgen.EcbfFilter()
    safety.update(x, np.zeros(cbfgen.NU), env)
    slots = safety.slots
    lie = safety.lie
    for leg in range(6):
        rows, _ = cbfgen.joint_limits(leg, x)
        mine = [i for i, (f, at, _) in enumerate(slots) if f == "joint_limits" and at == leg]
        np.testing.assert_array_equal(lie[mine], rows)
        (height,), _ = cbfgen.foot_height(leg, x, 0.0)
        (i,) = [i for i, (f, at, _) in enumerate(slots) if f == "foot_height" and at == leg]
        np.testing.assert_array_equal(lie[i], height)


def test_dense_g_and_xdot_agree():
    rng = np.random.default_rng(7)
    x = cbfgen.standard_posture() + rng.uniform(-0.05, 0.05, cbfgen.NX)
    u = rng.uniform(-1, 1, cbfgen.NU)
    np.testing.assert_allclose(cbfgen.xdot(x, u), cbfgen.dynamics_f(x) + cbfgen.dynamics_g(x) @ u, rtol=1e-14)


BOX = ([0, 0, 0], np.eye(3), [0.5, 0.5, 0.5])


@pytest.mark.parametrize("call, error, message", [
    (lambda: cbfgen.joint_limits(0, np.full(cbfgen.NX, np.nan)), cbfgen.CbfError, "finite"),
    (lambda: cbfgen.joint_limits(0, np.zeros(5)), ValueError, "expected 36 values"),
    (lambda: cbfgen.joint_limits(6, cbfgen.standard_posture()), ValueError, "no leg 6"),
    (lambda: cbfgen.joint_limits("XX", cbfgen.standard_posture()), ValueError, "no leg 'XX'"),
    (lambda: cbfgen.ssat(*BOX, [2, 0, 0], np.eye(3), [0.5, 0.0, 0.5]), cbfgen.CbfError, "half extent"),
    (lambda: cbfgen.ssat(*BOX, [2, 0, 0], 2 * np.eye(3), [0.5, 0.5, 0.5]), cbfgen.CbfError, "rotation"),
    (lambda: cbfgen.ssat(*BOX, *BOX, variant="nope"), ValueError, "SSAT variant"),
    (lambda: cbfgen.ssat(*BOX, *BOX, alpha=-1.0), cbfgen.CbfError, "alpha"),
    (lambda: cbfgen.foothold(0, cbfgen.standard_posture(), [0, 0], 1.0), cbfgen.CbfError, "normal"),
    (lambda: cbfgen.EcbfFilter(activation={"nope": 1.0}), ValueError, "unknown family"),
    (lambda: cbfgen.EcbfFilter(eps_abs=0.0), cbfgen.CbfError, "eps_abs = 0 is outside"),
    (lambda: cbfgen.Course("moon"), ValueError, "unknown scenario"),
    (lambda: cbfgen.simulate("step", max_time=-1.0), cbfgen.CbfError, "max_time"),
])
def test_bad_input_raises_a_python_exception(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_filter_errors_leave_it_usable():
    safety = cbfgen.EcbfFilter(edges=2)
    small = cbfgen.Environment(edges=2)
    x, u = cbfgen.standard_posture(), np.zeros(cbfgen.NU)
    with pytest.raises(cbfgen.CbfError, match="capacities"):
        safety.update(x, u, cbfgen.Environment())
    with pytest.raises(cbfgen.CbfError, match="finite"):
        safety.update(x, np.full(cbfgen.NU, np.inf), small)
    for _ in range(2):
        small.push_edge(*BOX)
    with pytest.raises(cbfgen.CbfError, match="too many edge cuboids"):
        small.push_edge(*BOX)
    assert safety.update(x, u, small).source in cbfgen.INPUT_SOURCES
    assert issubclass(cbfgen.CbfError, ValueError)


def test_environment_round_trips():
    env = cbfgen.Environment(edges=3, foothold_edges=(4, 4, 4, 4, 4, 4))
    assert env.capacity == (3, [4, 4, 4, 4, 4, 4])
    normals = np.array([[1.0, 0.0], [0.0, 1.0]])
    env.set_foothold("LR", normals, [0.5, 0.25])
    got_normals, got_offsets = env.foothold(3)
    np.testing.assert_array_equal(got_normals, normals)
    np.testing.assert_array_equal(got_offsets, [0.5, 0.25])
    with pytest.raises(ValueError, match="2 normals .* but 1 offsets"):
        env.set_foothold(0, normals, [0.5])
    env.swing = [True, False, True, False, True, False]
    assert env.swing == [True, False, True, False, True, False]
    env.set_stability(0, lower=(1.0, 0.4), upper=None)
    with pytest.raises(cbfgen.CbfError):
        env.floor_z = [0.0, 0.0, np.nan, 0.0, 0.0, 0.0]


def test_type_stubs_list_exactly_the_module_names():
    import ast
    from pathlib import Path

    stub = Path(__file__).resolve().parents[1] / "cbfgen" / "_native.pyi"
    tree = ast.parse(stub.read_text())
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            declared.add(node.target.id)
    helpers = {"ArrayLike", "Vector", "Matrix", "Leg", "Rows", "SsatVariant", "Family"}
    declared -= helpers
    assert declared == set(cbfgen.__all__)
    for name in cbfgen.__all__:  # and every public function or class carries a docstring
        obj = getattr(cbfgen, name)
        if callable(obj):
            assert obj.__doc__, name


def test_updates_on_threads_match_sequential_ones():
    # update() releases the GIL: filters on other threads then run concurrently, and one
    # filter shared by threads is serialised by its lock. Either way every result must
    # be the one a single thread computes.
    import threading

    course = cbfgen.Course("step")
    rng = np.random.default_rng(5)
    x0 = course.initial_state()
    states = [x0 + rng.normal(0.0, 0.01, cbfgen.NX) for _ in range(100)]
    inputs = [course.plan(0.0, x) for x in states]
    env = course.environment

    def run(safety):
        return np.array([safety.update(x, u, env).u for x, u in zip(states, inputs, strict=False)])

    expected = run(cbfgen.EcbfFilter())
    results = {}
    shared = cbfgen.EcbfFilter()
    threads = [threading.Thread(target=lambda i=i: results.__setitem__(i, run(cbfgen.EcbfFilter())))
               for i in range(3)]

    def shared_run(i):
        results[i] = [shared.update(x, u, env).source for x, u in zip(states, inputs, strict=True)]

    threads += [threading.Thread(target=shared_run, args=(i,)) for i in (3, 4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i in range(3):
        np.testing.assert_array_equal(results[i], expected)
    assert all(len(results[i]) == len(states) for i in (3, 4))
