"""ANYmal C on a floating base (systems/anymal/spec/anymal.py), the compiled kernels and
filter against Pinocchio: its feet at 10^4 random states, and closed loops whose every
cycle is checked by Pinocchio's kinematics and exact SAT, independent of the filter's own
smooth model (foot squares and the ground; joint limits; the SRDF's self-collision pairs).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from symbolic import urdf

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")
pin = pytest.importorskip("pinocchio", reason="installed from symbolic/requirements-test.txt")

DESCRIPTION = "anymal_c_simple_description/urdf/anymal.urdf"
LEGS = ["LF", "RF", "LH", "RH"]
JOINTS = [f"{leg}_{j}" for leg in LEGS for j in ("HAA", "HFE", "KFE")]
NQ = 18
DT = 1e-3


class Truth:
    """Pinocchio's free-flyer model of the same URDF, fed the system's state: the trunk's
    pose as a position and the quaternion of Rz(yaw) Ry(pitch) Rx(roll), the joints by name."""

    def __init__(self):
        path = urdf.description(DESCRIPTION)
        self.robot = urdf.load(path)
        self.model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
        self.data = self.model.createData()
        self.joint_q = [self.model.joints[self.model.getJointId(j)].idx_q for j in JOINTS]
        self.joint_v = [self.model.joints[self.model.getJointId(j)].idx_v for j in JOINTS]
        self.foot_frames = [self.model.getFrameId(f"{leg}_FOOT", pin.FrameType.BODY) for leg in LEGS]
        spheres = [[s for s in urdf.collision_shapes(self.robot, f"{leg}_FOOT") if isinstance(s, urdf.Sphere)][0]
                   for leg in LEGS]
        self.foot_offsets = [np.array(s.center) for s in spheres]
        self.foot_radius = spheres[0].radius
        srdf = urdf.load_srdf(urdf.description("anymal_c_simple_description/srdf/anymal.srdf"), self.robot)
        self.links = [link for link in self.robot.links if self.robot.collision(link)]
        self.boxes = {link: urdf.link_box(self.robot, link) for link in self.links}
        self.pairs = urdf.self_collision_pairs(self.robot, srdf, self.links)
        self.link_frames = {link: self.model.getFrameId(link, pin.FrameType.BODY) for link in self.links}

    @staticmethod
    def rotation(roll, pitch, yaw):
        return pin.rpy.rpyToMatrix(roll, pitch, yaw)  # Rz(yaw) Ry(pitch) Rx(roll)

    def configure(self, x):
        rot = self.rotation(*x[3:6])
        q = np.zeros(self.model.nq)
        q[:3] = x[:3]
        q[3:7] = pin.Quaternion(rot).coeffs()
        q[self.joint_q] = x[6:NQ]
        # Pinocchio's free-flyer velocity is the trunk's, in its own frame: R^T p' and the
        # body angular velocity of the roll-pitch-yaw rates.
        rates = x[NQ + 3:NQ + 6]
        roll, pitch, yaw = x[3:6]
        rz, ryz = self.rotation(0, 0, yaw), self.rotation(0, pitch, yaw)
        omega = ryz @ [rates[0], 0, 0] + rz @ [0, rates[1], 0] + [0, 0, rates[2]]
        v = np.zeros(self.model.nv)
        v[:3] = rot.T @ x[NQ:NQ + 3]
        v[3:6] = rot.T @ omega
        v[self.joint_v] = x[NQ + 6:]
        pin.forwardKinematics(self.model, self.data, q, v)
        pin.updateFramePlacements(self.model, self.data)

    def feet(self):
        """Foot sphere centres and their velocities, world."""
        positions, velocities = [], []
        for frame, offset in zip(self.foot_frames, self.foot_offsets, strict=True):
            placement = self.data.oMf[frame]
            arm = placement.rotation @ offset
            twist = pin.getFrameVelocity(self.model, self.data, frame, pin.LOCAL_WORLD_ALIGNED)
            positions.append(placement.translation + arm)
            velocities.append(twist.linear + np.cross(twist.angular, arm))
        return np.array(positions), np.array(velocities)

    def smallest_self_separation(self):
        """The smallest exact SAT separation [m] over the SRDF's pairs, with their pair."""
        def placed(link):
            o = self.data.oMf[self.link_frames[link]]
            b = self.boxes[link]
            return (o.translation + o.rotation @ b.center, o.rotation @ np.array(b.rotation), b.half)
        return min((urdf.box_separation(placed(a), placed(b)), (a, b)) for a, b in self.pairs)


@pytest.fixture(scope="module")
def truth():
    return Truth()


def test_anymal_is_built_in_with_four_families_and_an_srdf_worth_of_pairs(truth):
    anymal = cbfgen.System("anymal")
    assert (anymal.nx, anymal.nu) == (36, 18)
    degrees = {f["name"]: f["relative_degree"] for f in anymal.families}
    assert degrees == {"joint_limits": 2, "velocity_limits": 1, "foot_region": 2, "self_collision": 2}
    members = {f["name"]: f["members"] for f in anymal.families}
    assert members["foot_region"] == [leg.lower() for leg in LEGS]
    assert len(members["self_collision"]) == len(truth.pairs) == 30


def test_the_compiled_feet_and_their_velocities_match_pinocchio(truth):
    rng = np.random.default_rng(35)
    worst_position = worst_velocity = 0.0
    for _ in range(10_000):
        base = np.concatenate([rng.uniform(-2, 2, 3), rng.uniform(-math.pi, math.pi, 3) * [1, 0.45, 1]])
        joints = [rng.uniform(lo, hi) for lo, hi in truth.robot.limits(JOINTS, "position")]
        joints = np.clip(joints, -math.pi, math.pi)
        x = np.concatenate([base, joints, rng.uniform(-2, 2, NQ)])
        got = cbfgen.call_kernel("anymal", "feet", x)
        truth.configure(x)
        positions, velocities = truth.feet()
        worst_position = max(worst_position, float(np.max(np.abs(got[:12] - positions.ravel()))))
        worst_velocity = max(worst_velocity, float(np.max(np.abs(got[12:] - velocities.ravel())
                                                        / np.maximum(1.0, np.abs(velocities.ravel())))))
    assert worst_position <= 1e-12, worst_position
    assert worst_velocity <= 1e-12, worst_velocity


def _standing():
    anymal = cbfgen.System("anymal")
    standing = dict(zip(anymal.state_names[:NQ], range(NQ), strict=True))
    # The SRDF's standing state, read from the SRDF itself.
    srdf = urdf.load_srdf(urdf.description("anymal_c_simple_description/srdf/anymal.srdf"),
                          urdf.load(urdf.description(DESCRIPTION)))
    pose = srdf.virtual_states["standing"]["root_joint"]
    x = np.zeros(2 * NQ)
    x[:3] = pose[:3]
    for name, value in srdf.states["standing"].items():
        x[standing[name.lower()]] = value
    return anymal, x


def _run(anymal, params, x, nominal, seconds, filtered, truth, check):
    safety = anymal.filter(params.capacity)
    lo, hi = anymal.input_min, anymal.input_max
    verdicts = set()
    for k in range(int(seconds / DT)):
        u_ref = nominal(k * DT, x)
        if filtered:
            out = safety.update(x, u_ref, params)
            verdicts.add(out.verdict)
            u = out.u
        else:
            u = np.clip(u_ref, lo, hi)
        x = np.concatenate([x[:NQ] + x[NQ:] * DT + 0.5 * u * DT**2, x[NQ:] + u * DT])
        truth.configure(x)
        check(x)
    return verdicts


def _pd(target, stiffness=400.0, damping=40.0):
    return lambda t, x: stiffness * (target(t) - x[:NQ]) - damping * x[NQ:]


def test_feet_stay_on_their_squares_and_above_the_ground_under_a_trot_that_leaves_them(truth):
    anymal, start = _standing()
    truth.configure(start)
    homes, _ = truth.feet()
    half, ground = 0.03, 0.0
    params = anymal.params({"foot_region": [5] * 4})
    legs = next(f["members"] for f in anymal.families if f["name"] == "foot_region")
    for leg, home in zip(legs, homes, strict=True):
        for normal, offset in [([1, 0, 0], home[0] + half), ([-1, 0, 0], half - home[0]),
                               ([0, 1, 0], home[1] + half), ([0, -1, 0], half - home[1]),
                               ([0, 0, -1], -(ground + truth.foot_radius))]:
            params.push("foot_region", {"normal": normal, "offset": offset}, member=leg)

    def target(t):
        # Hips swing 0.4 rad in a trot (LF with RH), the trunk sways 5 cm sideways.
        q = start[:NQ].copy()
        q[1] += 0.05 * math.sin(2 * math.pi * t)
        for leg, phase in zip(range(4), (0.0, math.pi, math.pi, 0.0), strict=True):
            q[6 + 3 * leg + 1] += 0.4 * math.sin(3 * math.pi * t + phase)
        return q

    limits = np.array(truth.robot.limits(JOINTS, "position"))

    def strays(record):
        def check(x):
            feet, _ = truth.feet()
            record.append(max(float(np.max(np.abs(feet[:, :2] - homes[:, :2]))),
                              float(np.max(ground + truth.foot_radius - feet[:, 2]))))
            assert np.all(x[6:NQ] >= limits[:, 0] - 1e-9) and np.all(x[6:NQ] <= limits[:, 1] + 1e-9)
        return check

    filtered, unfiltered = [], []
    verdicts = _run(anymal, params, start, _pd(target), 2.0, True, truth, strays(filtered))
    _run(anymal, params, start, _pd(target), 2.0, False, truth, strays(unfiltered))
    assert verdicts == {"met"}, verdicts
    # Pinocchio's feet: inside their squares and above the ground at every cycle, within the
    # rounding of one period's integration.
    assert max(filtered) <= half + 1e-6, max(filtered)
    assert max(unfiltered) > half + 0.05, max(unfiltered)


def test_two_feet_driven_into_each_other_never_meet_by_exact_sat(truth):
    # The front-left hip swings back and the hind-left forward: their feet would cross
    # under the belly. The SRDF's pairs, placed by Pinocchio, checked by exact SAT.
    anymal, start = _standing()
    params = anymal.params()
    goal = start[:NQ].copy()
    goal[6 + 1] += 1.6   # LF_HFE
    goal[6 + 3 * 2 + 1] -= 1.6  # LH_HFE
    separations = {True: [], False: []}
    for filtered in (True, False):
        verdicts = _run(anymal, params, start, _pd(lambda t: goal, 100.0, 20.0), 1.5, filtered, truth,
                        lambda x, f=filtered: separations[f].append(truth.smallest_self_separation()))
        if filtered:
            assert verdicts == {"met"}, verdicts
    closest = min(separations[True])
    assert closest[0] >= 0.0, closest
    # The filter is what kept them apart.
    assert min(separations[False])[0] < -0.02, min(separations[False])
