"""ANYmal C in free-flyer coordinates (systems/anymal/spec/anymal_wbc.py): the compiled
rigid-body dynamics, contact points and foothold rows against Pinocchio's free flyer on
the same URDF at 10^4 random states, to 1e-10 relative: crba, nonLinearEffects, the foot
frames' LOCAL_WORLD_ALIGNED Jacobians and classical accelerations."""

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

SYSTEM = "anymal_wbc"
LEGS, JOINTS = anymal_pinocchio.LEGS, anymal_pinocchio.JOINTS
NV = 18
STATES = 10_000
TOLERANCE = 1e-10


class Truth:
    """Pinocchio's free flyer of the same URDF, fed the system's state: position, the
    quaternion of R, the joints by name; the twist and joint rates as its velocity."""

    def __init__(self):
        self.model, self.feet, self.robot = anymal_pinocchio.model_with_feet()
        self.iq = [self.model.joints[self.model.getJointId(j)].idx_q for j in JOINTS]
        self.iv = list(range(6)) + [self.model.joints[self.model.getJointId(j)].idx_v for j in JOINTS]
        self.data = self.model.createData()

    def random_state(self, rng) -> np.ndarray:
        """Trunk anywhere in +-2 m with any orientation, joints within their limits,
        twist and rates in +-2 (m/s, rad/s)."""
        rotation = pin.Quaternion(*rng.normal(size=4)).normalized().toRotationMatrix()
        joints = [rng.uniform(lo, hi) for lo, hi in self.robot.limits(JOINTS, "position")]
        return np.concatenate([rng.uniform(-2, 2, 3), rotation.ravel(), joints, rng.uniform(-2, 2, NV)])

    def configure(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, v = pin.neutral(self.model), np.zeros(self.model.nv)
        q[:3] = x[:3]
        q[3:7] = pin.Quaternion(x[3:12].reshape(3, 3)).coeffs()
        q[self.iq] = x[12:24]
        v[self.iv] = x[24:42]
        return q, v

    def dynamics(self, x):
        q, v = self.configure(x)
        upper = pin.crba(self.model, self.data, q)
        mass = np.triu(upper) + np.triu(upper, 1).T
        return mass[np.ix_(self.iv, self.iv)], pin.nonLinearEffects(self.model, self.data, q, v)[self.iv]

    def contacts(self, x):
        """Each foot sphere centre: world position, world-velocity Jacobian and J' v."""
        q, v = self.configure(x)
        n = self.model.nv
        pin.forwardKinematics(self.model, self.data, q, v, np.zeros(n))
        pin.updateFramePlacements(self.model, self.data)
        pin.computeJointJacobians(self.model, self.data, q)
        world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        return [(self.data.oMf[frame].translation,
                 pin.getFrameJacobian(self.model, self.data, frame, world)[:3][:, self.iv],
                 pin.getFrameClassicalAcceleration(self.model, self.data, frame, world).linear)
                for frame in self.feet]


@pytest.fixture(scope="module")
def truth():
    return Truth()


def _relative(got: np.ndarray, want: np.ndarray) -> float:
    return float(np.max(np.abs(got - want))) / max(1.0, float(np.max(np.abs(want))))


def _sizes(name: str) -> dict[str, int]:
    (outputs,) = [o for module, kernel, _, o in cbfgen.kernel_table() if (module, kernel) == (SYSTEM, name)]
    return dict(outputs)


def test_the_compiled_dynamics_match_pinocchio(truth):
    sizes = _sizes("dynamics")
    assert sizes["bias"] == NV
    symmetric = sizes["mass_matrix"] == NV * (NV + 1) // 2
    upper = np.triu_indices(NV)
    rng = np.random.default_rng(3701)
    worst = {"M": 0.0, "b": 0.0}
    for _ in range(STATES):
        x = truth.random_state(rng)
        got = cbfgen.call_kernel(SYSTEM, "dynamics", x)
        mass, bias = truth.dynamics(x)
        m = sizes["mass_matrix"]
        worst["M"] = max(worst["M"], _relative(got[:m], mass[upper] if symmetric else mass.ravel()))
        worst["b"] = max(worst["b"], _relative(got[m:], bias))
    assert max(worst.values()) <= TOLERANCE, worst


def test_the_compiled_contact_points_match_pinocchio(truth):
    assert _sizes("contacts") == {"positions": 12, "jacobians": 12 * NV, "drifts": 12}
    rng = np.random.default_rng(3702)
    worst = {"p": 0.0, "J": 0.0, "Jdot_v": 0.0}
    for _ in range(STATES):
        x = truth.random_state(rng)
        got = cbfgen.call_kernel(SYSTEM, "contacts", x)
        positions, jacobians, drifts = got[:12].reshape(4, 3), got[12:12 + 12 * NV].reshape(4, 3, NV), got[-12:]
        for leg, (centre, jacobian, drift) in enumerate(truth.contacts(x)):
            worst["p"] = max(worst["p"], _relative(positions[leg], centre))
            worst["J"] = max(worst["J"], _relative(jacobians[leg], jacobian))
            worst["Jdot_v"] = max(worst["Jdot_v"], _relative(drifts[3 * leg:3 * leg + 3], drift))
    assert max(worst.values()) <= TOLERANCE, worst


def test_the_foothold_rows_are_pinocchios_foot_kinematics(truth):
    # h = d + m(t) - n . c, so L_f h = m' - n . J nu, L_f^2 h = m'' - n . J' nu and
    # L_g L_f h = -n^T J: the row the whole-body controller adds is the foot's own
    # kinematics and the growth's Taylor polynomial (m, m', m'' at `at`), nothing else.
    sizes = _sizes("foot_region_lf")
    rng = np.random.default_rng(3703)
    worst = 0.0
    for _ in range(1000):
        x = truth.random_state(rng)
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        offset = rng.uniform(-1, 1)
        growth = rng.uniform(-1, 1, size=3)
        t, at = rng.uniform(0, 10), rng.uniform(0, 10)
        since = t - at
        feet = truth.contacts(x)
        for leg in range(4):
            inputs = np.concatenate([x, [t], normal, [offset], growth, [at]])
            got = cbfgen.call_kernel(SYSTEM, f"foot_region_{LEGS[leg].lower()}", inputs)
            centre, jacobian, drift = feet[leg]
            # The kernel keeps the columns the foot can move: the trunk's six and its leg's
            # three joints, in order; Pinocchio's Jacobian is zero in every other.
            columns = [*range(6), *range(6 + 3 * leg, 9 + 3 * leg)]
            others = np.delete(np.arange(NV), columns)
            assert np.all(jacobian[:, others] == 0.0)
            m = growth[0] + growth[1] * since + growth[2] * since**2 / 2
            m_dot = growth[1] + growth[2] * since
            want = np.concatenate([[offset + m - normal @ centre, m_dot - normal @ jacobian @ x[24:],
                                    growth[2] - normal @ drift], -normal @ jacobian[:, columns]])
            assert got.size == sum(sizes.values()) == want.size
            worst = max(worst, _relative(got, want))
    assert worst <= TOLERANCE, worst
