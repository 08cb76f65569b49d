"""The Python API's behaviour: every built-in system through the generic classes, a
Python control loop reproducing the Rust one, filter outputs satisfying the ECBF rows
they report (recomputed independently), and bad input raising instead of panicking."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

t3 = cbfgen.tachyon3


def python_loop(scenario: str, seconds: float, **filter_kwargs):
    course = t3.Course(scenario)
    safety = t3.ecbf_filter(**filter_kwargs)
    x = course.initial_state()
    xs = []
    for k in range(round(seconds / t3.DT)):
        xs.append(x)
        out = safety.update(x, course.plan(k * t3.DT, x), course.environment)
        x = x + t3.DT * t3.SYSTEM.xdot(x, out.u)
    return np.array(xs), safety


def ecbf_bounds(safety) -> np.ndarray:
    """-(L_f^r h + sum_i k_i L_f^i h) per row, with the gains expanded here from each
    family's poles (the coefficients of prod (s + p_i)), independently of the Rust."""
    lie, settings = safety.lie, safety.family_settings
    out = np.empty(len(lie))
    for i, (family, *_rest) in enumerate(safety.layout):
        poles = settings[family][0]
        coefficients = np.poly(-np.asarray(poles))[::-1]  # k_0 .. k_{r-1}, then 1
        out[i] = -np.dot(coefficients, lie[i, : len(poles) + 1])
    return out


def test_every_built_in_system_is_reachable_by_name():
    # Every built-in system (each spec the generator finds under systems/) is a system of
    # the module: one line in python/src/registry.rs, no binding code.
    from symbolic.generate import builtin_specs

    builtin = {p.stem for p in builtin_specs()}
    assert builtin <= set(cbfgen.systems())  # then any loaded with cbfgen.load
    for name in sorted(builtin):
        s = cbfgen.System(name)
        assert (s.nx, s.nu) == (len(s.state_names), len(s.input_names))
        assert np.all(s.input_min <= s.input_max)
        for f in s.families:
            assert len(f["poles"]) == f["relative_degree"] >= 1
            assert f["instances"] in {"fixed", "optional", "capacity"}
            # The built-in systems use the plain ECBF (no alpha); Tachyon 3's foothold pull
            # is their one CLF.
            clf = (name, f["name"]) == ("tachyon3", "foothold_pull")
            assert (f["kind"], f["class_k"]) == ("lyapunov" if clf else "barrier", "s"), f


def test_a_python_loop_reproduces_the_rust_simulation():
    # Same gait, filter and Euler step on either side of the boundary: the trajectories
    # must agree to the last bit, which checks Course, the generic filter and xdot together.
    seconds = 3.0
    rust = t3.simulate("step", body_cbf=True, max_time=seconds)
    xs, _ = python_loop("step", seconds)
    assert rust["x"].shape == xs.shape == (round(seconds / t3.DT), t3.NX)
    np.testing.assert_array_equal(rust["x"], xs)


def test_a_campaign_episode_reruns_alone_with_the_same_outcome():
    # Short courses keep this quick; the Rust suite runs the 200-episode campaign.
    ranges = {"steps": [1, 1], "rise": [0.05, 0.1]}
    run = t3.campaign(episodes=3, seed=5, first_id=10, ranges=ranges, threads=1)
    assert list(run["id"]) == [10, 11, 12] and run["min_h"].shape == (3, len(t3.FAMILIES))
    assert run["errors"] == [] and run["outcome"] == ["finished"] * 3
    assert "| episodes | 3 |" in run["report"]
    assert np.all((run["rise"] >= 0.05) & (run["rise"] <= 0.1)) and np.all(run["steps"] == 1)
    alone = t3.simulate(episode=11, seed=5, ranges=ranges, body_cbf=True)["summary"]
    assert alone["completed"]
    assert alone["min_body_clearance"] == run["min_body_clearance"][1]
    assert alone["min_toe_clearance"] == run["min_toe_clearance"][1]
    with pytest.raises(cbfgen.CbfError, match="rise"):
        t3.campaign(episodes=1, ranges={"rise": [0.3, 0.1]})
    with pytest.raises(cbfgen.CbfError, match="course range"):
        t3.campaign(episodes=1, ranges={"height": [0.1, 0.2]})


def test_the_held_input_plant_and_the_certificate_run_from_python():
    # Each input held over its period (RK4 at 1 ms / 10), the certificate on: the summary
    # counts the updates it certified (None with it off); a campaign says where it measured.
    held = t3.simulate("step", max_time=0.3, fine=10, certify=True)["summary"]
    assert 0 < held["certified_cycles"] <= 300
    assert t3.simulate("step", max_time=0.3)["summary"]["certified_cycles"] is None
    run = t3.campaign(episodes=1, seed=5, ranges={"steps": [1, 1], "rise": [0.05, 0.1]}, threads=1, fine=5)
    assert run["errors"] == [] and "at every fine step, RK4 at 1 ms / 5" in run["report"]
    with pytest.raises(cbfgen.CbfError, match="fine steps per period"):
        t3.simulate("step", max_time=0.1, fine=0)
    with pytest.raises(cbfgen.CbfError, match="fine steps per period"):
        t3.campaign(episodes=1, fine=1001)


def test_perceived_terrain_runs_from_python_and_hides_the_truth():
    # Every named course is offered; a perceived run differs from the true-terrain one
    # (the filter saw other edges) and counts its 1 Hz updates.
    assert t3.SCENARIOS == ["step", "stairs", "unequal_rises", "landing", "box", "platform", "turn"]
    truth = t3.simulate("box", max_time=4.0)
    seen = t3.simulate("box", max_time=4.0, perception=True)
    assert truth["summary"]["perception_updates"] == 0
    assert seen["summary"]["perception_updates"] == 4  # before the start, and at 1, 2, 3 s
    assert not np.array_equal(truth["x"], seen["x"])
    # Perception maps one flight along x: the course that turns is refused with it.
    with pytest.raises(cbfgen.CbfError, match="flights of a course run on perceived terrain"):
        t3.Course("turn", perception=True)
    with pytest.raises(cbfgen.CbfError, match="flights of a course run on perceived terrain"):
        t3.simulate("turn", max_time=1.0, perception=True)
    # Its solids are every flight's, in the world: the floor, flight 1's two steps and
    # landing, and flight 2's three steps up +y from the landing's side, down to the floor.
    boxes = t3.Course("turn").terrain_boxes()
    assert len(boxes) == 7 and len(t3.Course("turn").edge_boxes()) == 7
    center, rotation, half = boxes[-1]
    extent = np.abs(rotation) @ half  # the turned box's half extents along the world axes
    np.testing.assert_allclose(center + extent, [4.1, 4.9, 0.99], atol=1e-12)
    np.testing.assert_allclose(center - extent, [1.7, 1.9, 0.0], atol=1e-12)
    assert seen["summary"]["min_body_clearance"] > 0.0 and seen["summary"]["min_toe_clearance"] > -1e-3


def test_a_measured_roll_grows_the_body_rows_edges_and_survives_perception_updates():
    # The body turned about its x axis: the farthest corner moves roll_clearance (numpy).
    half = np.asarray(t3.BODY_HALF_EXTENTS)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    for roll in (-0.3, 0.0, 0.05, 0.2):
        c, s = np.cos(roll), np.sin(roll)
        turned = corners @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T
        assert t3.roll_clearance(roll) == pytest.approx(np.linalg.norm(turned - corners, axis=1).max(), abs=1e-12)
    # Two courses perceiving alike, one told of a roll: its body rows' edges are the
    # other's grown by roll_clearance, before and after a perception update replaces them.
    level, rolled = t3.Course("stairs", perception=True), t3.Course("stairs", perception=True)
    x = level.initial_state()
    rolled.set_body_roll(0.1)
    for k in range(1600):
        for course in (level, rolled):
            course.perceive(k * t3.DT, x)
        if k in (0, 1599):
            halves = [np.asarray([half for _c, _r, half in c.environment_edges()]) for c in (level, rolled)]
            assert halves[0].size > 0
            np.testing.assert_allclose(halves[1] - halves[0], t3.roll_clearance(0.1), atol=1e-12)
    assert level.perception_updates == rolled.perception_updates == 2
    with pytest.raises(cbfgen.CbfError, match="body roll"):
        rolled.set_body_roll(float("nan"))


def test_the_origin_jumps_to_the_wheels_at_each_support_exchange_from_python():
    # The paper's origin rule from a loop written here: at each touchdown the origin
    # moves to the six wheels' centroid (numpy), and every world pose stays where it was.
    jumping, rolling = t3.Course("stairs", origin="jump_at_exchange"), t3.Course("stairs")
    safety = t3.ecbf_filter()
    x = jumping.initial_state()
    jumps = []
    for k in range(round(9.0 / t3.DT)):
        t = k * t3.DT
        moved, jump = jumping.exchange_origin(t, x)
        assert rolling.exchange_origin(t, x)[1] is None
        if jump is None:
            np.testing.assert_array_equal(moved, x)
        else:
            jumps.append(jump)
            assert jump == pytest.approx(np.mean(x[t3.STATE_NAMES.index("lf_x") :: 4]), abs=1e-12)
            assert np.mean(moved[t3.STATE_NAMES.index("lf_x") :: 4]) == pytest.approx(0.0, abs=1e-12)
            for before, after in zip(t3.world_kinematics(x), t3.world_kinematics(moved), strict=True):
                np.testing.assert_allclose(after, before, atol=1e-12)
        x = moved
        out = safety.update(x, jumping.plan(t, x), jumping.environment)
        x = x + t3.DT * t3.SYSTEM.xdot(x, out.u)
    assert len(jumps) >= 2 and max(abs(j) for j in jumps) > 0.01, jumps
    with pytest.raises(ValueError, match="unknown origin"):
        t3.Course("stairs", origin="teleporting")


def test_a_velocity_and_yaw_rate_command_turns_the_robot_on_three_legs_from_python():
    # The paper's velocity command from a loop written here, 3 m before the step: the
    # robot rolls and turns left, the yaw rate zero whenever all six wheels are down,
    # and each turning swing's origin stands on the centre of the drive axle left down
    # (numpy, from the toes' world positions).
    course = t3.Course("step")
    with pytest.raises(ValueError, match="yaw rate"):
        course.command(0.1, 1.01 * course.max_yaw_rate)
    with pytest.raises(ValueError):
        course.command(float("nan"), 0.0)
    course.command(0.1, 0.15)
    safety = t3.ecbf_filter()
    x = course.initial_state(start_gap=3.0)
    yaw, rate = t3.STATE_NAMES.index("yaw"), t3.STATE_NAMES.index("yaw_rate")
    start, lifted_turning, on_axle = x[yaw], 0, 0
    for k in range(round(8.0 / t3.DT)):
        t = k * t3.DT
        x, jump = course.exchange_origin(t, x)
        u_ref = course.plan(t, x)
        if course.swinging is None:
            assert abs(x[rate]) < 0.01
        elif abs(x[rate]) > 0.01:
            lifted_turning += 1
            _, _, toes = t3.world_kinematics(x)
            axle = toes[t3.STANCE_AXLE[course.swinging]].mean(axis=0)
            on_axle += bool(np.hypot(*(axle[:2] - x[:2])) < 0.01)
        x = x + t3.DT * t3.SYSTEM.xdot(x, safety.update(x, u_ref, course.environment).u)
    assert lifted_turning > 500 and on_axle == lifted_turning
    assert x[yaw] - start > 0.3
    # The same course in a loop that never moves the origin is told to.
    course = t3.Course("step")
    course.command(0.1, 0.15)
    x = course.initial_state(start_gap=3.0)
    with pytest.raises(cbfgen.CbfError, match="exchange_origin"):
        for k in range(round(3.0 / t3.DT)):
            course.plan(k * t3.DT, x)


def test_simulation_arrays_are_consistent():
    run = t3.simulate("step", max_time=0.5)
    n = len(run["t"])
    assert n == 500 and np.allclose(np.diff(run["t"]), t3.DT)
    assert run["x"].shape == (n, t3.NX) and run["min_h"].shape == (n, len(t3.FAMILIES))
    np.testing.assert_allclose(run["body_z_world"], run["x"][:, 2] + run["x"][:, t3.STATE_NAMES.index("bz")])
    assert set(run["summary"]["min_h"]) == set(t3.FAMILIES)
    assert np.all((run["source"] >= 0) & (run["source"] < len(cbfgen.INPUT_SOURCES)))
    # Timings: wall and thread CPU time per cycle; the summary's counts of cycles over the
    # 1 ms period are direct counts over those series, and its percentiles nearest ranks.
    summary = run["summary"]
    assert run["cpu_us"].shape == run["update_us"].shape == (n,)
    assert np.all(np.isfinite(run["cpu_us"])) and np.all(run["cpu_us"] >= 0.0)
    assert summary["over_period_wall"] == np.count_nonzero(run["update_us"] > 1000.0)
    assert summary["over_period_cpu"] == np.count_nonzero(run["cpu_us"] > 1000.0)
    ranked = np.sort(run["cpu_us"])
    assert [summary[f"{k}_cpu_us"] for k in ("median", "p99", "max")] == [
        ranked[int(np.ceil(p * n)) - 1] for p in (0.5, 0.99, 1.0)
    ]


def test_filtered_input_satisfies_every_active_ecbf_row():
    # Stop the drive next to the step, where body, toe and joint rows are active, and
    # check the QP's constraints from the rows the filter reports, in Python.
    _, safety = python_loop("step", 6.0)
    out = safety.output
    assert out.source == "qp" and out.backend == "dense"  # the exact, KKT-verified solve
    assert out.verdict == "met" and out.relaxed_rows == 0 and out.relaxed == [] and out.worst is None
    assert out.convergence == "met"  # no Lyapunov family: nothing to give way
    assert all(f["relaxed_rows"] == 0 for f in out.relaxation.values())
    assert set(out.relaxation) == set(t3.FAMILIES)
    u, lg = out.u, safety.lg_lf
    active = np.array(safety.active)
    assert active.sum() == out.active_rows > 0
    bound = ecbf_bounds(safety)
    # Every active row holds exactly at u (to the solver's rounding), no slack needed.
    assert np.all((lg @ u)[active] >= bound[active] - 1e-8 * (1 + np.abs(bound[active])))
    np.testing.assert_array_equal(safety.slack[~active], 0.0)
    assert np.all((t3.SYSTEM.input_min - 1e-12 <= u) & (u <= t3.SYSTEM.input_max + 1e-12))


def test_double_integrator_closed_loop_through_the_generic_classes():
    # The multi-layer example's system, driven only through System/Params/EcbfFilter:
    # a nominal input pushing down through the moving boundary q = A sin(w t) + c. Its
    # rows are recomputed here from the formula by hand; the row holds exactly at every
    # returned input, and the position never goes below the boundary (beyond the Euler
    # step's own error).
    system = cbfgen.System("double_integrator")
    amplitude, omega, offset = 0.2, 2.0, -0.5
    params = system.params()
    params.set("sine_barrier", {"amplitude": amplitude, "omega": omega, "offset": offset})
    safety = system.filter()
    x, dt, lowest = np.array([0.0, 0.0]), 1e-3, np.inf
    for k in range(4000):
        t = k * dt
        out = safety.update(x, [-5.0], params, t)
        assert out.source == "qp"
        s, c = np.sin(omega * t), np.cos(omega * t)
        by_hand = [x[0] - amplitude * s - offset, x[1] - amplitude * omega * c, amplitude * omega**2 * s]
        np.testing.assert_allclose(safety.lie[0], by_hand, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(safety.lg_lf, [[1.0]])
        assert out.verdict == "met"
        if safety.active[0]:
            assert out.u[0] >= ecbf_bounds(safety)[0] - 1e-8
        lowest = min(lowest, by_hand[0])
        x = x + dt * system.xdot(x, out.u)
    assert -1e-3 < lowest < 0.05  # it went to the boundary and stayed on the safe side


def test_the_certificate_between_samples_keeps_the_held_input_above_the_boundary():
    # The boundary 0.1 sin(20 t), pressed onto at -100 m/s^2, each input held 1 ms and the
    # exact solution checked at 100 instants per period (computed here): without
    # `sample_period` the position dips below the boundary between samples; with it every
    # update is certified, the margins are reported per row, and it never does.
    system = cbfgen.System("double_integrator")
    params = system.params()
    params.set("sine_barrier", {"amplitude": 0.1, "omega": 20.0, "offset": 0.0})

    def least_h(**settings):
        safety = system.filter(input_min=[-1000.0], input_max=[1000.0], **settings)
        x, dt, lowest, states = np.array([0.2, 0.0]), 1e-3, np.inf, set()
        for k in range(1500):
            t = k * dt
            out = safety.update(x, [-100.0], params, t)
            assert out.source == "qp" and out.verdict == "met"
            states.add((out.between_samples, out.uncertified_why))
            tau = dt * np.arange(1, 101) / 100
            q = x[0] + x[1] * tau + 0.5 * out.u[0] * tau**2
            lowest = min(lowest, float(np.min(q - 0.1 * np.sin(20.0 * (t + tau)))))
            x = np.array([x[0] + x[1] * dt + 0.5 * out.u[0] * dt**2, x[1] + out.u[0] * dt])
        return lowest, states, safety.margins

    lowest, states, margins = least_h()
    assert lowest < -1e-4 and states == {("off", None)} and np.all(margins == 0.0)
    lowest, states, margins = least_h(certify_rounds=8, sample_period=1e-3)
    assert lowest >= 0.0 and states == {("certified", None)}
    assert margins.shape == (1,) and margins[0] >= 0.0
    with pytest.raises(ValueError, match="needs sample_period"):
        system.filter(input_delay=True)
    with pytest.raises(cbfgen.CbfError, match="sampled-data period"):
        system.filter(sample_period=0.0)


def test_rows_agree_with_the_kernel_table_and_the_filter():
    # System.rows (the generated barrier set), the filter's rows and the uniform kernel
    # table (the same kernels reached through a second, flat door) at one state.
    x = t3.standard_posture()
    env = t3.Environment()
    env.floor_z = np.full(6, -0.01)
    rows = t3.SYSTEM.rows(x, env)
    safety = t3.ecbf_filter()
    safety.update(x, np.zeros(t3.NU), env)
    np.testing.assert_array_equal(rows.lie, safety.lie)
    np.testing.assert_array_equal(rows.lg_lf, safety.lg_lf)
    assert rows.layout == safety.layout and rows.applicable == safety.applicable
    for leg in ("lf", "mf", "rf", "lr", "mr", "rr"):
        flat = cbfgen.call_kernel("tachyon3", f"joint_limits_{leg}", x)
        mine = [i for i, (f, m, _, _) in enumerate(rows.layout) if f == "joint_limits" and m == leg]
        np.testing.assert_array_equal(rows.lie[mine], flat[:12].reshape(4, 3))
        flat = cbfgen.call_kernel("tachyon3", f"foot_height_{leg}", np.append(x, -0.01))
        (i,) = [i for i, (f, m, _, _) in enumerate(rows.layout) if f == "foot_height" and m == leg]
        np.testing.assert_array_equal(rows.lie[i], flat[:3])


@pytest.mark.parametrize("name", ["double_integrator", "tachyon3"])
def test_xdot_is_drift_plus_input_matrix_times_u(name):
    system = cbfgen.System(name)
    rng = np.random.default_rng(7)
    x = (t3.standard_posture() if name == "tachyon3" else np.zeros(system.nx)) + rng.uniform(-0.05, 0.05, system.nx)
    u = rng.uniform(-1, 1, system.nu)
    np.testing.assert_allclose(system.xdot(x, u), system.drift(x) + system.input_matrix(x) @ u, rtol=1e-14)
    np.testing.assert_array_equal(system.drift(x), cbfgen.call_kernel(name, "drift", x))


def test_params_take_dicts_or_flat_vectors_with_matrices_row_by_row():
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # not symmetric
    center, half = [0.8, 0.1, 0.06], [0.02, 1.0, 0.02]
    by_dict, flat, typed = t3.SYSTEM.params(t3.capacity(2, [1] * 6)), t3.SYSTEM.params(t3.capacity(2, [1] * 6)), \
        t3.Environment(2, [1] * 6)
    by_dict.push("body_edge", {"center": center, "rotation": rotation, "half": half})
    flat.push("body_edge", np.concatenate([center, rotation.ravel(order="C"), half]))
    typed.push_edge(center, rotation, half)
    for p in (by_dict, flat, typed):
        got = p.get("body_edge")
        np.testing.assert_array_equal(got["rotation"], rotation)
        np.testing.assert_array_equal(got["center"], center)
        assert p.get("body_edge", instance=1) is None and p.count("body_edge") == 1
    by_dict.push("foothold", {"normal": [0.6, 0.8], "offset": 0.25}, member="lr")
    assert by_dict.count("foothold", member=3) == 1 and by_dict.count("foothold", member="lf") == 0
    by_dict.set_enabled("foothold", False)
    assert not any(by_dict.is_enabled("foothold", member=m) for m in range(6))
    by_dict.set("stability", {"a": 1.0, "b": 0.4}, member="mf", instance=1)
    assert by_dict.get("stability", member="mf", instance=1) == {"a": 1.0, "b": 0.4}
    by_dict.remove("stability", member="mf", instance=1)
    assert by_dict.get("stability", member="mf", instance=1) is None
    copy = by_dict.copy()
    copy.clear("body_edge")
    assert copy.count("body_edge") == 0 and by_dict.count("body_edge") == 1


BOX = ([0, 0, 0], np.eye(3), [0.5, 0.5, 0.5])
DI = cbfgen.System("double_integrator")


def test_a_fixed_instance_nobody_set_is_refused_by_name_until_it_is_set():
    # The double integrator's boundary has no default in its spec: the filter, the rows
    # and get() refuse it, naming family, instance and parameter; set, it runs.
    params, safety = DI.params(), DI.filter()
    x, u_ref = np.array([0.5, 0.0]), np.array([-3.0])
    never = "sine_barrier instance 0: parameter amplitude was never set"
    for call in (lambda: safety.update(x, u_ref, params), lambda: DI.rows(x, params),
                 lambda: params.get("sine_barrier")):
        with pytest.raises(cbfgen.CbfError, match=never):
            call()
    params.set("sine_barrier", {"amplitude": 0.0, "omega": 1.0, "offset": 0.0})
    # At rest 0.5 m above a flat boundary, poles (10, 10): u >= -k0 h = -50 lets -3 through.
    out = safety.update(x, u_ref, params)
    assert out.verdict == "met" and out.u[0] == pytest.approx(-3.0)
    # Tachyon 3's floors start where its spec puts them, the ground plane z = 0.
    assert [t3.Environment().get("foot_height", member=leg)["floor_z"] for leg in range(6)] == [0.0] * 6


@pytest.mark.parametrize("call, error, message", [
    (lambda: t3.SYSTEM.drift(np.full(t3.NX, np.nan)), cbfgen.CbfError, "finite"),
    (lambda: t3.SYSTEM.drift(np.zeros(5)), ValueError, r"expected 36 values|shape \(36,\)"),
    (lambda: cbfgen.System("moon_rover"), cbfgen.CbfError, "no system named"),
    (lambda: DI.params().set("nope", [0, 0, 0]), cbfgen.CbfError, "no family named"),
    (lambda: DI.params().set("sine_barrier", [0, 0]), ValueError, "shape"),
    (lambda: DI.params().set("sine_barrier", {"amplitude": 0.0, "omega": 1.0}), ValueError, "missing"),
    (lambda: DI.params().push("sine_barrier", [0, 0, 0]), cbfgen.CbfError, "push is not available"),
    (lambda: DI.params().set("sine_barrier", [0, 0, np.nan]), cbfgen.CbfError, "finite"),
    (lambda: DI.params().set("sine_barrier", [0, 0, 1e300]), cbfgen.CbfError, "outside"),
    (lambda: DI.params().set("sine_barrier", [0, 0, 0], instance=1), cbfgen.CbfError, "no instance 1"),
    (lambda: t3.Environment().set("foot_height", [0.0]), ValueError, "pass member="),
    (lambda: t3.Environment().set("foot_height", [0.0], member="xx"), ValueError, "no member 'xx'"),
    (lambda: t3.SYSTEM.params({"joint_limits": 3}), cbfgen.CbfError, "not available"),
    (lambda: t3.SYSTEM.params({"body_edge": t3.MAX_EDGES + 1}), cbfgen.CbfError, "above the maximum"),
    (lambda: t3.Environment().set_foothold(0, [[0, 0]], [1.0]), cbfgen.CbfError, "normal"),
    (lambda: cbfgen.ssat(*BOX, [2, 0, 0], np.eye(3), [0.5, 0.0, 0.5]), cbfgen.CbfError, "half extent"),
    (lambda: cbfgen.ssat(*BOX, [2, 0, 0], 2 * np.eye(3), [0.5, 0.5, 0.5]), cbfgen.CbfError, "rotation"),
    (lambda: cbfgen.ssat(*BOX, *BOX, variant="nope"), ValueError, "SSAT variant"),
    (lambda: cbfgen.ssat(*BOX, *BOX, alpha=-1.0), cbfgen.CbfError, "alpha"),
    (lambda: t3.ecbf_filter(activation={"nope": 1.0}), cbfgen.CbfError, "no family named"),
    (lambda: t3.ecbf_filter(eps_abs=0.0), cbfgen.CbfError, "eps_abs = 0 is outside"),
    (lambda: t3.ecbf_filter(poles={"body_edge": [1.0]}), cbfgen.CbfError, "poles"),
    (lambda: t3.ecbf_filter(speed=3), ValueError, "unknown setting"),
    (lambda: t3.ecbf_filter(backend="bogus"), ValueError,
     r"unknown backend 'bogus': expected one of \[\"dense\", \"osqp\", \"dense_then_osqp\"\]"),
    (lambda: t3.ecbf_filter(dense_max_steps=0), cbfgen.CbfError, "dense_max_steps"),
    (lambda: t3.ecbf_filter(dense_max_steps=cbfgen.MAX_ITERATIONS + 1), cbfgen.CbfError, "dense_max_steps"),
    (lambda: t3.Course("moon"), ValueError, "unknown scenario"),
    (lambda: t3.simulate("step", max_time=-1.0), cbfgen.CbfError, "max_time"),
])
def test_bad_input_raises_a_python_exception(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_a_setting_given_as_none_keeps_the_spec_default():
    # As an omitted keyword: what scripts pass when a setting is optional.
    assert t3.ecbf_filter(activation=None, poles=None).family_settings == t3.ecbf_filter().family_settings
    assert t3.ecbf_filter(poles={"body_edge": [5.0, 6.0]}).family_settings["body_edge"][0] == [5.0, 6.0]


def test_cpu_time_is_measured_only_when_asked_for():
    course = t3.Course("step")
    x = course.initial_state()
    out = t3.ecbf_filter().update(x, course.plan(0.0, x), course.environment)
    assert out.cpu_time_us is None


def test_cpu_time_is_reported_beside_wall_time():
    course = t3.Course("step")
    safety = t3.ecbf_filter(measure_cpu_time=True)
    x = course.initial_state()
    cpu, wall = [], []
    for k in range(30):
        out = safety.update(x, course.plan(k * t3.DT, x), course.environment)
        cpu.append(out.cpu_time_us)
        wall.append(out.eval_time_us + out.solve_time_us)
        x = x + t3.DT * t3.SYSTEM.xdot(x, out.u)
    cpu = np.array(cpu)
    # A 269-row update is tens of microseconds of work; a second would be a broken clock.
    assert np.all(np.isfinite(cpu)) and np.all(cpu >= 0.0) and np.all(cpu < 1e6)
    assert safety.output.cpu_time_us == out.cpu_time_us
    if os.name == "posix":  # a per-thread CPU clock exists: the work shows on it
        assert np.median(cpu) > 0.0
        # The thread cannot work longer than the wall time around its work (give or take
        # the clocks' granularity).
        assert np.median(cpu) <= 1.5 * np.median(wall) + 5.0


@pytest.mark.parametrize("backend", ["dense", "osqp", "dense_then_osqp"])
def test_each_solver_backend_is_accepted_and_reaches_the_filter(backend):
    assert backend in cbfgen.SOLVERS
    safety = t3.ecbf_filter(backend=backend, dense_max_steps=7)
    settings = safety.solver_settings
    assert (settings["backend"], settings["dense_max_steps"]) == (backend, 7)
    course = t3.Course("step")
    x = course.initial_state()
    out = safety.update(x, course.plan(0.0, x), course.environment)
    assert out.u.shape == (t3.NU,) and np.all(np.isfinite(out.u))
    # The backend that answered is the one asked for (the default's dense solve verifies
    # at rest); OSQP's ADMM iterations show only where OSQP ran.
    assert out.backend == ("osqp" if backend == "osqp" else "dense")
    assert (out.iterations > 0) == (backend == "osqp")
    assert not out.dense_fallback and (backend != "osqp" or out.dense_steps == 0)
    # The other solver settings read back as the keywords set them; None keeps the default.
    tuned = t3.ecbf_filter(eps_abs=1e-4, max_iter=300, polish=False, time_limit_us=800.0).solver_settings
    assert (tuned["eps_abs"], tuned["max_iter"], tuned["polish"]) == (1e-4, 300, False)
    assert tuned["time_limit_us"] == pytest.approx(800.0)
    assert t3.ecbf_filter(backend=None, dense_max_steps=None).solver_settings == t3.ecbf_filter().solver_settings


def test_filter_errors_leave_it_usable():
    safety = t3.ecbf_filter(edges=2)
    small = t3.Environment(edges=2)
    x, u = t3.standard_posture(), np.zeros(t3.NU)
    with pytest.raises(cbfgen.CbfError, match="capacities"):
        safety.update(x, u, t3.Environment())
    with pytest.raises(cbfgen.CbfError, match="parameters of system double_integrator"):
        safety.update(x, u, DI.params())
    with pytest.raises(cbfgen.CbfError, match="finite"):
        safety.update(x, np.full(t3.NU, np.inf), small)
    for _ in range(2):
        small.push_edge(*BOX)
    with pytest.raises(cbfgen.CbfError, match="too many edge cuboids"):
        small.push_edge(*BOX)
    assert safety.update(x, u, small).source in cbfgen.INPUT_SOURCES
    assert issubclass(cbfgen.CbfError, ValueError)


def test_environment_round_trips():
    env = t3.Environment(edges=3, foothold_edges=(4, 4, 4, 4, 4, 4))
    assert env.sizes == (3, [4, 4, 4, 4, 4, 4])
    assert env.capacity["body_edge"] == 3 and env.capacity["foothold"] == [4] * 6
    normals = np.array([[1.0, 0.0], [0.0, 1.0]])
    env.set_foothold("LR", normals, [0.5, 0.25])
    got_normals, got_offsets = env.foothold(3)
    np.testing.assert_array_equal(got_normals, normals)
    np.testing.assert_array_equal(got_offsets, [0.5, 0.25])
    assert env.get("foothold", member="lr", instance=1) == {"normal": pytest.approx([0.0, 1.0]), "offset": 0.25}
    with pytest.raises(ValueError, match="2 normals .* but 1 offsets"):
        env.set_foothold(0, normals, [0.5])
    env.swing = [True, False, True, False, True, False]
    assert env.swing == [True, False, True, False, True, False]
    assert [env.is_enabled("foothold", member=m) for m in range(6)] == env.swing
    env.set_stability(0, lower=(1.0, 0.4), upper=None)
    assert env.get("stability", member="lf") == {"a": 1.0, "b": 0.4}


def test_a_foothold_polygon_and_its_pull():
    env = t3.Environment(edges=3, foothold_edges=(4, 4, 4, 4, 4, 4))
    env.swing = [True] * 6
    # A tread 35 cm deep from x = 1, inset 12 cm for the wheel: toe centres in x [1.12, 1.23].
    env.set_foothold_polygon("RF", [[1.0, -0.6], [1.35, -0.6], [1.35, 0.6], [1.0, 0.6]], inset=0.12)
    normals, offsets = env.foothold("rf")
    assert normals @ [1.2, 0.0] + offsets == pytest.approx([0.48, 0.03, 0.48, 0.08])
    # Outside: pulled to 1 cm inside the near edge, straight ahead; the rows go off.
    target, outside = env.guide_toe("RF", [1.02, 0.3])
    assert target == pytest.approx([1.13, 0.3]) and outside == pytest.approx(0.10)
    assert env.foothold_pull("RF") == (pytest.approx([1.13, 0.3]), pytest.approx([1.0, 0.0]))
    assert not env.is_enabled("foothold", member="rf") and env.swing[2]
    # Inside: the rows keep it.
    assert env.guide_toe("RF", [1.2, 0.3]) is None and env.foothold_pull("RF") is None
    assert env.is_enabled("foothold", member="rf")
    with pytest.raises(ValueError, match="not convex"):
        env.set_foothold_polygon(0, [[0, 0], [2, 0], [1, 0.3], [1, 2]])
    with pytest.raises(ValueError, match="leaves no polygon"):
        env.set_foothold_polygon(0, [[0, 0], [1, 0], [0, 1]], inset=0.5)
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
    helpers = {"ArrayLike", "Vector", "Matrix", "Leg", "Member", "Values", "FamilyInfo", "SsatVariant",
               "RowPlace", "Backend", "SolverSettings", "RelaxedRow", "FamilyRelaxation", "UpdateWork", "WorstCase",
               "Calibration"}
    declared -= helpers
    native = {n for n in dir(cbfgen._native) if not n.startswith("_")}
    assert declared == native
    for module in (cbfgen, t3, cbfgen.anymal):  # every public function or class carries a docstring
        for name in set(module.__all__) - {"tachyon3", "anymal"}:
            obj = getattr(module, name)
            if callable(obj):
                assert obj.__doc__, f"{module.__name__}.{name}"


def test_updates_on_threads_match_sequential_ones():
    # update() releases the GIL: filters on other threads then run concurrently, and one
    # filter shared by threads is serialised by its lock. Either way every result must
    # be the one a single thread computes.
    import threading

    course = t3.Course("step")
    rng = np.random.default_rng(5)
    x0 = course.initial_state()
    states = [x0 + rng.normal(0.0, 0.01, t3.NX) for _ in range(100)]
    inputs = [course.plan(0.0, x) for x in states]
    env = course.environment

    def run(safety):
        return np.array([safety.update(x, u, env).u for x, u in zip(states, inputs, strict=False)])

    expected = run(t3.ecbf_filter())
    results = {}
    shared = t3.ecbf_filter()
    threads = [threading.Thread(target=lambda i=i: results.__setitem__(i, run(t3.ecbf_filter())))
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


def test_a_row_the_input_limits_cannot_meet_is_reported_relaxed_with_why():
    # The double integrator falling at 2 m/s onto a still boundary 0.1 m below, with
    # |u| <= 1: its ECBF row (poles 10, 10) asks u >= -(20 * -2 + 100 * 0.1) = 30, by hand.
    # The filter brakes at the bound, and says the row is missed by 29 because input "u"
    # is at its maximum; at rest above the boundary every row is met again.
    system = cbfgen.System("double_integrator")
    params = system.params()
    params.set("sine_barrier", {"amplitude": 0.0, "omega": 1.0, "offset": 0.0})
    safety = system.filter(input_min=[-1.0], input_max=[1.0])
    out = safety.update([0.1, -2.0], [0.0], params)
    assert out.source == "qp" and out.verdict == "relaxed" and out.relaxed_rows == 1
    assert out.u[0] == pytest.approx(1.0, abs=1e-12)
    (row,) = out.relaxed
    assert row["place"] == ("sine_barrier", None, 0, "above_sine")
    assert row["slack"] == pytest.approx(29.0, rel=1e-12)
    assert row["relative"] == pytest.approx(29.0 / (30.0 + 1.0), rel=1e-12)  # slack / (|b| + |a u|)
    assert (row["cause"], row["input"], row["limit"]) == ("input_limit", "u", "max")
    assert out.worst == row
    assert out.relaxation == {"sine_barrier": {"relaxed_rows": 1, "max_slack": pytest.approx(29.0),
                                               "max_relative": pytest.approx(29.0 / 31.0)}}
    np.testing.assert_allclose(safety.slack, [29.0], rtol=1e-12)
    calm = safety.update([1.0, 0.0], [0.5], params)
    assert calm.verdict == "met" and calm.relaxed == [] and calm.worst is None
    assert calm.relaxation["sine_barrier"]["relaxed_rows"] == 0


def test_priorities_are_settings_and_out_of_range_ones_raise():
    safety = t3.ecbf_filter(priority={"foothold": 5})
    poles, priority, activation = safety.family_settings["foothold"]
    assert priority == 5 and safety.family_settings["joint_limits"][1] == 0
    assert {f["name"]: f["priority"] for f in t3.SYSTEM.families} == {
        "joint_limits": 0, "foot_height": 1, "stability": 2, "body_edge": 0, "toe_edge": 0, "foothold": 3,
        "foothold_pull": 15}
    with pytest.raises(cbfgen.CbfError, match="priority tier"):
        t3.ecbf_filter(priority={"foothold": 16})


def test_culled_rows_change_no_input_and_hold_a_bound_below_h():
    # The stairs at their start: the upper steps' edge cuboids are far from the robot. A
    # filter that culls them and one that evaluates every row return the same input; a
    # culled row's h is a lower bound, above its family's activation, of the full h.
    course = t3.Course("stairs")
    culling, full = t3.ecbf_filter(), t3.ecbf_filter(cull_far_rows=False)
    x = course.initial_state()
    for k in range(20):
        u_ref = course.plan(k * t3.DT, x)
        a = culling.update(x, u_ref, course.environment)
        b = full.update(x, u_ref, course.environment)
        assert np.array_equal(a.u, b.u)
        culled = np.array(culling.culled)
        assert not np.any(full.culled)
        assert not np.any(culled & np.array(culling.active))
        h_bound, h_full = culling.lie[:, 0], full.lie[:, 0]
        assert np.all(h_bound[culled] <= h_full[culled])
        x = x + t3.DT * t3.SYSTEM.xdot(x, a.u)
    assert culled.sum() > 0, "nothing was far enough to cull"
