"""ANYmal C in MuJoCo, built by cbfgen.physics.urdf_model from the URDF's inertials and
collision primitives, against Pinocchio's free flyer of the same URDF at random states:
the total mass, the whole mass matrix (MuJoCo's free joint takes the world linear
velocity, Pinocchio's the trunk-frame one: M_mujoco = T^T M_pinocchio T with
T = diag(R^T, I)) and the foot sphere centres."""

from __future__ import annotations

import os

import numpy as np
import pytest

from symbolic import urdf

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen  # noqa: F401  (the package this module is part of)
else:
    pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")
mujoco = pytest.importorskip("mujoco", reason="installed from python/requirements.txt")
pin = pytest.importorskip("pinocchio", reason="installed from symbolic/requirements-test.txt")

from cbfgen.physics.urdf_model import mjcf_from_urdf, quaternion, rpy_matrix  # noqa: E402

LEGS = ["LF", "RF", "LH", "RH"]
JOINTS = [f"{leg}_{j}" for leg in LEGS for j in ("HAA", "HFE", "KFE")]


@pytest.fixture(scope="module")
def robot():
    path = urdf.description("anymal_c_simple_description/urdf/anymal.urdf")
    description = urdf.load(path)
    spheres = {leg: next(s for s in urdf.collision_shapes(description, f"{leg}_FOOT") if isinstance(s, urdf.Sphere))
               for leg in LEGS}
    model = mujoco.MjModel.from_xml_string(
        mjcf_from_urdf(path, sites={f"{leg}_foot": (f"{leg}_FOOT", list(spheres[leg].center)) for leg in LEGS}))
    truth = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    frames = []
    for leg in LEGS:
        foot = truth.getFrameId(f"{leg}_FOOT", pin.FrameType.BODY)
        link = truth.frames[foot]
        placement = link.placement * pin.SE3(np.eye(3), np.array(spheres[leg].center))
        frames.append(truth.addFrame(pin.Frame(f"{leg}_FOOT_CENTRE", link.parentJoint, foot, placement,
                                               pin.FrameType.OP_FRAME)))
    return description, model, truth, frames


def test_the_model_has_the_urdfs_joints_motors_and_mass(robot):
    description, model, truth, _ = robot
    assert (model.nq, model.nv, model.nu) == (7 + 12, 6 + 12, 12)
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)}
    assert names == {"root", *JOINTS}
    assert model.body_subtreemass[1] == pytest.approx(sum(i.mass for i in truth.inertias), rel=1e-12)
    efforts = {j: upper for j, (_, upper) in zip(JOINTS, description.limits(JOINTS, "effort"), strict=True)}
    for j in JOINTS:
        actuator = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, j)
        np.testing.assert_array_equal(model.actuator_ctrlrange[actuator], [-efforts[j], efforts[j]])


def test_mass_matrix_and_feet_match_pinocchio(robot):
    description, model, truth, frames = robot
    data, truth_data = mujoco.MjData(model), truth.createData()
    qadr = [model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j)] for j in JOINTS]
    vadr = list(range(6)) + [model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j)] for j in JOINTS]
    iq = [truth.joints[truth.getJointId(j)].idx_q for j in JOINTS]
    iv = list(range(6)) + [truth.joints[truth.getJointId(j)].idx_v for j in JOINTS]
    sites = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"{leg}_foot") for leg in LEGS]
    rng = np.random.default_rng(3711)
    worst = {"M": 0.0, "feet": 0.0}
    for _ in range(1000):
        quaternion = pin.Quaternion(*rng.normal(size=4)).normalized()
        joints = np.array([rng.uniform(lo, hi) for lo, hi in description.limits(JOINTS, "position")])
        position = rng.uniform(-1, 1, 3)
        data.qpos[:3], data.qpos[3:7], data.qpos[qadr] = position, [quaternion.w, *quaternion.coeffs()[:3]], joints
        mujoco.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass)
        q = pin.neutral(truth)
        q[:3], q[3:7], q[iq] = position, quaternion.coeffs(), joints
        upper = pin.crba(truth, truth_data, q)
        want = (np.triu(upper) + np.triu(upper, 1).T)[np.ix_(iv, iv)]
        t = np.eye(18)
        t[:3, :3] = quaternion.toRotationMatrix().T  # MuJoCo's world linear velocity -> trunk frame
        want = t.T @ want @ t
        worst["M"] = max(worst["M"], float(np.max(np.abs(mass[np.ix_(vadr, vadr)] - want))) / np.max(np.abs(want)))
        pin.framesForwardKinematics(truth, truth_data, q)
        for site, frame in zip(sites, frames, strict=True):
            worst["feet"] = max(worst["feet"], float(np.max(np.abs(data.site_xpos[site]
                                                                   - truth_data.oMf[frame].translation))))
    assert max(worst.values()) <= 1e-12, worst


def test_rotations_reach_mujoco_as_they_are():
    # URDF roll-pitch-yaw against Pinocchio's, and the quaternion written for MuJoCo read back
    # by MuJoCo, for random angles and for half turns (where w vanishes).
    rng = np.random.default_rng(3712)
    angles = [rng.uniform(-np.pi, np.pi, 3) for _ in range(2000)]
    angles += [np.array(a) for a in ([np.pi, 0, 0], [0, np.pi, 0], [0, 0, np.pi], [np.pi, np.pi / 2, 0])]
    for rpy in angles:
        r = rpy_matrix(rpy)
        np.testing.assert_allclose(r, pin.rpy.rpyToMatrix(*rpy), atol=1e-14)
        back = np.zeros(9)
        mujoco.mju_quat2Mat(back, quaternion(r))
        np.testing.assert_allclose(back.reshape(3, 3), r, atol=1e-12)


# ---------------------------------------------------------------- closed loops in MuJoCo
# The whole-body controller (cbfgen.anymal) at 400 Hz on MuJoCo's model at 2 kHz, measured
# in MuJoCo's world: trunk height, contacts of anything but the foot spheres, feet against
# their squares.


@pytest.fixture(scope="module")
def physics():
    from cbfgen.physics import anymal as physics

    return physics


def test_standing_10_s_holds_every_priority_and_the_trunk(physics):
    summary = physics.run("stand", seconds=10.0).summary()
    assert summary["every_cycle_solved"] and summary["largest_priority_0_residual"] <= 1e-5, summary
    assert summary["body_contacts"] == 0, summary
    low, high = summary["trunk_height_range_m"]
    start = physics.anymal.standing()[2]
    assert start - 0.02 <= low and high <= start + 0.02, summary


def test_trotting_10_s_at_0_3_m_per_s_does_not_fall(physics):
    summary = physics.run("trot", seconds=10.0, velocity=0.3).summary()
    # A knee reaches its 80 N m at some touchdowns: the equations of motion then give way
    # by at most 1.2e-4 m/s² (measured; reported as priority 0's residual), not the limit.
    assert summary["every_cycle_solved"] and summary["largest_priority_0_residual"] <= 1e-3, summary
    assert summary["body_contacts"] == 0, summary
    low, high = summary["trunk_height_range_m"]
    start = physics.anymal.standing()[2]
    assert start - 0.05 <= low and high <= start + 0.05, summary
    # 0.3 m/s for the 9.7 s after the first still swing.
    assert abs(summary["travelled_m"] - 0.3 * 9.7) <= 0.3, summary


def test_the_foothold_cbf_keeps_the_swing_foot_in_its_square_in_mujoco(physics):
    on = physics.run("footholds", cbf=True, seconds=3.0).summary()
    off = physics.run("footholds", cbf=False, seconds=3.0).summary()
    assert on["every_cycle_solved"] and on["body_contacts"] == 0, on
    assert on["largest_priority_0_residual"] <= 1e-5 and on["largest_cbf_slack"] == 0.0, on
    assert on["farthest_outside_square_m"] <= 0.002, on
    assert off["farthest_outside_square_m"] >= 0.03, off
