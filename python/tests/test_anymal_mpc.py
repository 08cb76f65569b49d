"""ANYmal C as the kino-dynamic MPC sees it (systems/anymal/spec/anymal_mpc.py) against
Pinocchio on the same URDF: the rigid body it freezes at the standing state (mass, centre
of mass, rotational inertia: Pinocchio's ccrba at the SRDF's standing joints) as the flow
moves it under forces at the feet; the feet's world positions and velocities at random
states. The Jacobians against finite differences are in
systems/anymal/tests/integration/mpc_model.rs."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")
pin = pytest.importorskip("pinocchio", reason="installed from symbolic/requirements-test.txt")
import anymal_pinocchio  # noqa: E402  (needs pinocchio)

SYSTEM = "anymal_mpc"
NX = NU = 24
STANDING = [-0.1, 0.7, -1.0, 0.1, 0.7, -1.0, -0.1, -0.7, 1.0, 0.1, -0.7, 1.0]  # anymal.srdf's "standing"
TOLERANCE = 1e-10


class Truth:
    """Pinocchio's free flyer and the standing robot as one body, by Pinocchio."""

    def __init__(self):
        self.model, self.feet, self.robot = anymal_pinocchio.model_with_feet()
        self.data = self.model.createData()
        self.iq = [self.model.joints[self.model.getJointId(j)].idx_q for j in anymal_pinocchio.JOINTS]
        self.iv = [self.model.joints[self.model.getJointId(j)].idx_v for j in anymal_pinocchio.JOINTS]
        q = self.configuration(np.zeros(3), np.eye(3), STANDING)
        pin.ccrba(self.model, self.data, q, np.zeros(self.model.nv))
        self.mass = self.data.Ig.mass
        self.inertia = self.data.Ig.inertia.copy()  # about the centre of mass, trunk axes (trunk at identity)
        self.com = pin.centerOfMass(self.model, self.data, q).copy()  # in the trunk frame

    def configuration(self, origin, rotation, joints) -> np.ndarray:
        q = pin.neutral(self.model)
        q[:3] = origin
        q[3:7] = pin.Quaternion(rotation).coeffs()
        q[self.iq] = joints
        return q

    def feet_moving(self, x: np.ndarray, rates: np.ndarray):
        """Each foot centre's world position and velocity when the trunk turns at w and its
        point at the centre of mass moves at v (both trunk frame), the joints at ``rates``."""
        rotation = pin.rpy.rpyToMatrix(*x[:3])
        w, v = x[6:9], x[9:12]
        origin = x[3:6] - rotation @ self.com
        q = self.configuration(origin, rotation, x[12:24])
        nu = np.zeros(self.model.nv)
        nu[:3] = v - np.cross(w, self.com)  # the trunk origin's velocity, trunk frame
        nu[3:6] = w
        nu[self.iv] = rates
        pin.forwardKinematics(self.model, self.data, q, nu)
        pin.updateFramePlacements(self.model, self.data)
        world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        return [(self.data.oMf[f].translation.copy(),
                 pin.getFrameVelocity(self.model, self.data, f, world).linear.copy()) for f in self.feet]


@pytest.fixture(scope="module")
def truth():
    return Truth()


def _random_point(rng, robot):
    x = np.concatenate([rng.uniform(-0.5, 0.5, 2), rng.uniform(-3, 3, 1), rng.uniform(-2, 2, 9),
                        [rng.uniform(lo, hi) for lo, hi in robot.limits(anymal_pinocchio.JOINTS, "position")]])
    u = np.concatenate([rng.uniform(-300, 300, 12), rng.uniform(-3, 3, 12)])
    return x, u


def _relative(got, want) -> float:
    return float(np.max(np.abs(np.asarray(got) - want))) / max(1.0, float(np.max(np.abs(want))))


def test_the_standing_body_moves_under_foot_forces_as_pinocchios(truth):
    # At the standing joints and zero joint rates the robot is one rigid body: Newton's
    # and Euler's equations with Pinocchio's mass, centre of mass and inertia, the forces
    # at Pinocchio's feet.
    rng = np.random.default_rng(3801)
    worst = 0.0
    for _ in range(1000):
        x, u = _random_point(rng, truth.robot)
        x[12:24], u[12:24] = STANDING, 0.0
        xdot = cbfgen.call_kernel(SYSTEM, "flow", np.concatenate([x, u]))[:NX]
        rotation = pin.rpy.rpyToMatrix(*x[:3])
        w, v = x[6:9], x[9:12]
        feet = [rotation.T @ (p - x[3:6]) for p, _ in truth.feet_moving(x, np.zeros(12))]  # trunk-frame arms
        forces = u[:12].reshape(4, 3)
        torque = sum(np.cross(arm, f) for arm, f in zip(feet, forces, strict=True))
        w_dot = np.linalg.solve(truth.inertia, torque - np.cross(w, truth.inertia @ w))
        v_dot = forces.sum(axis=0) / truth.mass + rotation.T @ np.array([0, 0, -9.81]) - np.cross(w, v)
        worst = max(worst, _relative(xdot[6:9], w_dot), _relative(xdot[9:12], v_dot),
                    _relative(xdot[3:6], rotation @ v))
    assert worst <= 1e-9, worst


def test_the_feet_are_pinocchios(truth):
    rng = np.random.default_rng(3802)
    worst = {"p": 0.0, "v": 0.0}
    for _ in range(2000):
        x, u = _random_point(rng, truth.robot)
        got = cbfgen.call_kernel(SYSTEM, "feet", np.concatenate([x, u]))
        positions = got[:12].reshape(4, 3)
        velocities = got[12 + 12 * NX:24 + 12 * NX].reshape(4, 3)
        for leg, (p, v) in enumerate(truth.feet_moving(x, u[12:24])):
            worst["p"] = max(worst["p"], _relative(positions[leg], p))
            worst["v"] = max(worst["v"], _relative(velocities[leg], v))
    assert max(worst.values()) <= TOLERANCE, worst
