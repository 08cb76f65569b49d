"""Tachyon 3 in MuJoCo (cbfgen.physics): the model's kinematic tree against the generated
kinematics, the state read back from MuJoCo, the reference's rigid re-anchoring, a short
physical run within the stated tracking bounds, and the hardware-stairs climb with and
without the body CBF: with it, neither a wheel nor the body more than 1 mm into the solid
stairs, by MuJoCo's own distance queries on the physical poses (checked here, beside
what the run reports from its own exact geometry).

Tracking bounds (physical minus kinematic state), stated in docs/physics.md:
* body height within 5 mm: the knees' servos sag by about 3.3 mm under the whole weight
  on one tripod (61 kg x g / 3 legs / 60 000 N/m), plus about 1 mm of MuJoCo's soft
  wheel-floor contact;
* each toe within 15 mm: about twice the hips' static deflection under a tripod's
  horizontal load (80 N m on 4000 N m/rad at 0.4 m of leg, 8 mm)."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
    import mujoco
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")
    mujoco = pytest.importorskip("mujoco", reason="pip install -r python/requirements.txt")

from cbfgen import tachyon3 as t3  # noqa: E402
from cbfgen.physics import (  # noqa: E402
    MAX_CATCH_UP,
    PENETRATION_TOLERANCE,
    PhysicalRobot,
    PoseEstimate,
    anchored,
    run,
)

BODY_HEIGHT_BOUND = 0.005
TOE_BOUND = 0.015


def random_states(count: int, seed: int) -> list[np.ndarray]:
    """States around the standard posture with every joint well inside its limits."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        x = t3.standard_posture()
        x[0:4] = rng.uniform([-2, -2, 0, -np.pi], [2, 2, 0.5, np.pi])
        x[6:9] += rng.uniform([-0.1, 0.0, -0.3], [0.1, 0.2, 0.3])
        x[12::4] += rng.uniform(-0.15, 0.15, 6)
        x[13::4] += rng.uniform(0.0, 0.15, 6)
        joints = t3.leg_joints(x)
        ranges = np.asarray(t3.HIP_RANGES)
        knee_lo, knee_hi = t3.KNEE_RANGE
        if (
            np.all(joints[:, 0] > knee_lo + 0.01)
            and np.all(joints[:, 0] < knee_hi - 0.01)
            and np.all(joints[:, 1] > ranges[:, 0] + 0.01)
            and np.all(joints[:, 1] < ranges[:, 1] - 0.01)
        ):
            out.append(x)
    return out


def test_mujoco_kinematic_tree_matches_the_generated_kinematics():
    """Posed by its joints alone (hip angle and knee length from the joint-limit kernels),
    MuJoCo's own forward kinematics puts the body and every wheel centre where the
    generated world kinematics do."""
    robot = PhysicalRobot(t3.Course("step"))
    for x in random_states(40, seed=1):
        robot.pose(x)
        center, rotation, toes = t3.world_kinematics(x)
        np.testing.assert_allclose(robot.data.xpos[robot.body], center, atol=1e-9)
        np.testing.assert_allclose(robot.data.xmat[robot.body].reshape(3, 3), rotation, atol=1e-9)
        for leg, wheel in enumerate(robot.wheels):
            np.testing.assert_allclose(robot.data.xpos[wheel], toes[leg], atol=1e-9)


def test_the_joint_rates_are_the_derivatives_of_the_joints():
    """leg_joints' rates against central differences of its positions along xdot."""
    x = random_states(1, seed=2)[0]
    rng = np.random.default_rng(3)
    x[9:12] = rng.uniform(-0.3, 0.3, 3)
    x[14::4], x[15::4] = rng.uniform(-0.3, 0.3, 6), rng.uniform(-0.3, 0.3, 6)
    xdot = t3.SYSTEM.xdot(x, np.zeros(t3.NU))
    step = 1e-6
    numeric = (t3.leg_joints(x + step * xdot) - t3.leg_joints(x - step * xdot)) / (2 * step)
    np.testing.assert_allclose(t3.leg_joints(x)[:, 2:], numeric[:, :2], atol=1e-7)


def test_the_state_read_from_mujoco_is_the_state_it_was_posed_in():
    robot = PhysicalRobot(t3.Course("step"))
    for x in random_states(20, seed=4):
        x[4:6] = 0.0  # at rest relative to the origin, so every velocity reads 0
        robot.pose(x)
        measured, off_model = robot.measure(x)
        positions = [6, 7, 8, *range(12, 36, 4), *range(13, 36, 4)]
        np.testing.assert_allclose(measured[positions], x[positions], atol=1e-9)
        np.testing.assert_allclose(measured[[9, 10, 11, *range(14, 36, 4), *range(15, 36, 4)]], 0.0, atol=1e-9)
        assert abs(off_model["lateral"]) < 1e-9 and abs(off_model["roll"]) < 1e-9


def test_a_rolled_robot_reads_as_its_joints_on_the_upright_robot():
    """The model holds no roll: a robot rolled about its body's x axis, with a roll rate
    and moving joints, reads as the state of the same joints on the upright robot
    (MuJoCo's joint positions and rates, through leg_joints), and reports the roll."""
    robot = PhysicalRobot(t3.Course("step"))
    rng = np.random.default_rng(21)
    d = robot.data
    for x in random_states(20, seed=22):
        x[4:6] = 0.0
        robot.pose(x)
        roll = rng.uniform(0.05, 0.3) * rng.choice([-1.0, 1.0])
        c, s = np.cos(roll), np.sin(roll)
        rolled = d.xmat[robot.body].reshape(3, 3) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        mujoco.mju_mat2Quat(d.qpos[3:7], rolled.ravel())
        d.qvel[3] = rng.uniform(-1.0, 1.0)  # the roll rate, about the body's own x axis
        d.qvel[robot.knee_v] = rng.uniform(-0.2, 0.2, 6)
        d.qvel[robot.hip_v] = rng.uniform(-0.5, 0.5, 6)
        mujoco.mj_forward(robot.model, d)
        # Where the wheels are is not where the model's toes are: a side is lifted.
        assert np.abs(d.xpos[robot.wheels][:, 2] - t3.world_kinematics(x)[2][:, 2]).max() > 0.01
        measured, off_model = robot.measure(x)
        assert off_model["roll"] == pytest.approx(roll, abs=1e-12)
        positions = [6, 7, 8, *range(12, 36, 4), *range(13, 36, 4)]
        np.testing.assert_allclose(measured[positions], x[positions], atol=1e-9)
        joints = t3.leg_joints(measured)
        np.testing.assert_allclose(joints[:, 0], d.qpos[robot.knee_q], atol=1e-9)
        np.testing.assert_allclose(joints[:, 1], d.qpos[robot.hip_q], atol=1e-9)
        np.testing.assert_allclose(joints[:, 2], d.qvel[robot.knee_v], atol=1e-9)
        np.testing.assert_allclose(joints[:, 3], d.qvel[robot.hip_v], atol=1e-9)
        np.testing.assert_allclose(measured[9:12], 0.0, atol=1e-9)


def test_anchoring_moves_the_reference_rigidly_onto_the_robot_and_keeps_its_joints():
    rng = np.random.default_rng(5)
    for x in random_states(30, seed=6):
        # The robot: the reference moved as one rigid body (a turn about a point, a
        # shift), its velocities changed by a rigid rate too.
        turn, shift = rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.1, 2)
        pivot = rng.uniform(-0.5, 0.5, 2)
        c, s = np.cos(turn), np.sin(turn)
        rotate = np.array([[c, s], [-s, c]])
        robot = x.copy()
        # (position x, z, velocity x, z) of the body and each toe.
        points = [(6, 7, 9, 10), *[(12 + 4 * leg, 13 + 4 * leg, 14 + 4 * leg, 15 + 4 * leg) for leg in range(6)]]
        for px, pz, vx_, vz_ in points:
            robot[[px, pz]] = rotate @ (x[[px, pz]] - pivot) + pivot + shift
            robot[[vx_, vz_]] = rotate @ x[[vx_, vz_]]
        robot[8] += turn
        vx, vz = rng.uniform(-0.3, 0.3, 2)
        robot[[9, *range(14, 36, 4)]] += vx
        robot[[10, *range(15, 36, 4)]] += vz
        moved = anchored(x, robot)
        positions = [6, 7, 8, *range(12, 36, 4), *range(13, 36, 4)]
        np.testing.assert_allclose(moved[positions], robot[positions], atol=1e-9)
        np.testing.assert_allclose(moved[[10, *range(15, 36, 4)]], robot[[10, *range(15, 36, 4)]], atol=1e-9)
        # Along the course the reference keeps up to MAX_CATCH_UP of its own speed.
        kept = np.clip(vx, -MAX_CATCH_UP, MAX_CATCH_UP)
        np.testing.assert_allclose(moved[[9, *range(14, 36, 4)]], robot[[9, *range(14, 36, 4)]] - kept, atol=1e-9)
        np.testing.assert_allclose(t3.leg_joints(moved)[:, :2], t3.leg_joints(x)[:, :2], atol=1e-9)


def test_a_pose_estimate_moves_the_whole_robot_rigidly_and_keeps_its_joints():
    estimate = PoseEstimate()
    rng = np.random.default_rng(8)
    for x in random_states(20, seed=9):
        error = estimate.error(travelled=rng.uniform(0.0, 3.0), rng=rng)
        believed = estimate.estimate(x, error)
        # World kinematics of the believed state: the body centre moved by the shift, the
        # body turned by the pitch error, every wheel turned about the body centre.
        # The error is in the origin's frame, which is yawed by x[3] in the world.
        center, rotation, toes = t3.world_kinematics(x)
        center_b, rotation_b, toes_b = t3.world_kinematics(believed)
        cy, sy = np.cos(x[3]), np.sin(x[3])
        yaw = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        np.testing.assert_allclose(center_b - center, yaw @ [error[0], 0.0, error[1]], atol=1e-12)
        c, s = np.cos(error[2]), np.sin(error[2])
        turn = yaw @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ yaw.T
        np.testing.assert_allclose(rotation_b, turn @ rotation, atol=1e-12)
        np.testing.assert_allclose(toes_b, (turn @ (toes - center).T).T + center_b, atol=1e-12)
        np.testing.assert_allclose(t3.leg_joints(believed)[:, :2], t3.leg_joints(x)[:, :2], atol=1e-9)
    with pytest.raises(ValueError, match="non-negative noise"):
        PoseEstimate(noise=(-1.0, 0.0, 0.0))


def test_the_physical_robot_refuses_a_course_that_does_not_exist():
    with pytest.raises(ValueError, match="does not run 'nowhere'"):
        run("nowhere")


def test_a_short_physical_run_tracks_the_kinematic_state_within_its_bounds():
    """Three seconds of the step course: the legs take the weight and lift the body; no
    body contact, and the physical state within the stated bounds of the kinematic one."""
    record = run("step", body_cbf=True, max_time=3.0)
    a, summary = record.arrays(), record.summary()
    assert summary["error"] is None and summary["cycles"] == 3000
    # Fig. 9's counts: applied within evaluated within computed, and the 42 per-leg rows
    # (4 joint limits, a foot height and 2 stability rows on each of 6 legs) always there.
    computed, culled, applied = a["computed_rows"], a["culled_rows"], a["active_rows"]
    assert np.all(applied <= computed - culled) and np.all(culled >= 0)
    assert computed.min() >= 42
    assert summary["body_contact_cycles"] == 0
    assert summary["max_body_height_error_mm"] <= 1e3 * BODY_HEIGHT_BOUND
    assert summary["max_toe_error_mm"] <= 1e3 * TOE_BOUND
    # It moved: the gait raised the body by more than 5 cm over the run.
    assert a["x"][-1, 7] - a["x"][0, 7] > 0.05


class WheelDistances:
    """Per cycle, MuJoCo's own signed distance (``mj_geomDistance``) from each wheel to
    each terrain box, on the physical poses: an independent measure of what the run
    reports from its exact sphere–box geometry."""

    def __init__(self) -> None:
        self.nearest: list[float] = []

    def __call__(self, _k: int, robot: PhysicalRobot) -> None:
        fromto = np.zeros(6)
        self.nearest.append(
            min(
                mujoco.mj_geomDistance(robot.model, robot.data, toe, g, 1.0, fromto)
                for toe in robot.toe_geoms
                for g in robot.terrain_geoms
            )
        )


@pytest.fixture(scope="module")
def stairs_climbs():
    out = {}
    for body_cbf in (True, False):
        wheels = WheelDistances()
        out[body_cbf] = (run("stairs", body_cbf=body_cbf, on_cycle=wheels), wheels)
    return out


def test_with_the_filter_the_physical_robot_climbs_the_hardware_stairs_without_body_contact(stairs_climbs):
    record, wheels = stairs_climbs[True]
    summary = record.summary()
    assert summary["finished"], summary
    assert summary["body_contact_cycles"] == 0, summary
    assert summary["min_body_distance_mm"] > 0.0, summary
    assert summary["body_penetration_cycles"] == 0, summary
    assert summary["max_body_height_error_mm"] <= 1e3 * BODY_HEIGHT_BOUND, summary
    assert summary["max_toe_error_mm"] <= 1e3 * TOE_BOUND, summary
    # What the run reports of its wheels against the solid stairs (its own exact
    # sphere-box geometry on MuJoCo's wheel centres) is what MuJoCo's distances say.
    np.testing.assert_allclose(record.arrays()["wheel_distance"][:, 0], wheels.nearest, atol=1e-6)
    # The filter's own cost is read from its thread's CPU clock every cycle, beside the wall
    # time. A reading of zero is possible (a VM's thread clock that stood still over a short
    # update, or stepped back across cores and was clamped), but not as the rule.
    cpu = record.arrays()["cpu_us"]
    assert cpu.shape == record.arrays()["update_us"].shape and np.all(np.isfinite(cpu)) and np.all(cpu >= 0.0)
    assert np.mean(cpu > 0.0) > 0.99, f"{np.sum(cpu == 0.0)} of {cpu.size} cycles read no CPU time"
    assert summary["median_filter_cpu_us"] < 1000.0, summary


def test_no_wheel_goes_more_than_1_mm_into_the_solid_stairs_nor_touches_a_riser(stairs_climbs):
    record, wheels = stairs_climbs[True]
    deepest = min(wheels.nearest)
    assert deepest > -PENETRATION_TOLERANCE, f"a wheel {-1e3 * deepest:.2f} mm into the stairs"
    summary = record.summary()
    assert summary["wheel_penetration_cycles"] == 0, summary
    assert summary["wheel_riser_contact_cycles"] == 0 and summary["toe_riser_contact_cycles"] == 0, summary
    assert summary["min_wheel_riser_distance_mm"] > 0.0, summary


def test_without_the_body_cbf_mujoco_reports_body_edge_contact(stairs_climbs):
    summary = stairs_climbs[False][0].summary()
    assert summary["body_contact_cycles"] > 100, summary
    assert summary["min_body_distance_mm"] < 0.0, summary


@pytest.fixture(scope="module")
def perceived_climb():
    """The paper's hardware run: the hardware stairs perceived by the LiDAR, from the
    default pose estimate (drift and noise, :class:`PoseEstimate`)."""
    wheels = WheelDistances()
    return run("stairs", body_cbf=True, on_cycle=wheels, perception=PoseEstimate()), wheels


def test_on_perceived_stairs_from_a_drifting_estimate_the_body_never_touches_and_no_wheel_enters(perceived_climb):
    record, wheels = perceived_climb
    summary = record.summary()
    assert summary["finished"] and summary["perceived"], summary
    # Perception ran at 1 Hz through the climb, and the estimate really was off.
    assert summary["perception_updates"] >= int(summary["finish_time_s"]) - 1, summary
    assert summary["max_estimate_error_mm"] > 30.0, summary
    deepest = min(wheels.nearest)
    assert deepest > -PENETRATION_TOLERANCE, f"a wheel {-1e3 * deepest:.2f} mm into the stairs"
    assert summary["wheel_penetration_cycles"] == 0, summary
    assert summary["wheel_riser_contact_cycles"] == 0 and summary["toe_riser_contact_cycles"] == 0, summary
    # The body, by MuJoCo's contacts and distances to the true solid stairs.
    assert summary["body_contact_cycles"] == 0, summary
    assert summary["min_body_distance_mm"] > 0.0 and summary["body_penetration_cycles"] == 0, summary
    # The model holds no roll; read from the joints, the robot does not build one up. The
    # sideways drift (which the model cannot hold either) is chaotic in the contacts'
    # last bits: 6.7 mm on one VM, 14.5 mm on an EPYC VM without AVX-512, from the same code.
    assert summary["max_roll_deg"] < 1.0 and summary["max_lateral_mm"] < 20.0, summary


def test_the_physical_robot_turns_ninety_degrees_on_three_legs_about_a_drive_axle():
    """The turn course in MuJoCo: three steps, a 90° left turn on the landing, three steps.
    The driven wheels cannot steer and the middle ones are passive omni wheels, so the
    turn only works as the paper's: on three legs, about the drive axle left down. An
    earlier turn on all six wheels scrubbed them and tipped the robot over."""
    wheels, body_rotation = WheelDistances(), {}

    def on_cycle(k: int, robot: PhysicalRobot) -> None:
        wheels(k, robot)
        body_rotation["last"] = robot.data.xmat[robot.body].reshape(3, 3).copy()

    record = run("turn", body_cbf=True, on_cycle=on_cycle)
    summary = record.summary()
    assert summary["finished"], summary
    assert summary["body_contact_cycles"] == 0 and summary["min_body_distance_mm"] > 0.0, summary
    assert min(wheels.nearest) > -PENETRATION_TOLERANCE, summary
    assert summary["wheel_riser_contact_cycles"] == 0 and summary["toe_riser_contact_cycles"] == 0, summary
    a = record.arrays()
    # MuJoCo's body ends facing +y, on top of flight 2 (its top level starts at y = 1.9).
    rotation = body_rotation["last"]
    assert abs(np.degrees(np.arctan2(rotation[1, 0], rotation[0, 0])) - 90.0) < 1.0
    assert np.asarray(record.x)[-1, 1] > 1.9
    # While the reference turns, exactly two driven wheels touch the ground (one axle:
    # the other is lifted with its tripod), and they roll rather than scrub: their
    # contact points slip at under 1 cm/s with the yaw rate up to 0.5 rad/s (an axle
    # 0.8 m wide skidding about the body centre would slip at 0.2 m/s).
    turning = np.abs(np.asarray(record.x_ref)[:, 5]) > 0.1
    assert turning.sum() > 1000
    drive_slip = a["slip"][turning][:, list(t3.DRIVE_LEGS)]
    assert np.all(np.sum(~np.isnan(drive_slip), axis=1) == 2)
    assert np.nanmax(drive_slip) < 0.01
    # The body follows the turning reference's heading: before each cycle's correction
    # (the loop takes the heading from the body), it is never more than 1° off.
    heading = np.array([o["heading"] for o in record.off_model])
    assert np.degrees(np.abs(heading).max()) < 1.0
