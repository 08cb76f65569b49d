"""The symbolic rigid-body dynamics (symbolic/dynamics.py) against Pinocchio reading the
same URDF: M(q) (crba), C(q, q̇) q̇ + g(q) (nonLinearEffects), g(q)
(computeGeneralizedGravity) and inverse dynamics (rnea) at 10^4 random states within the
joint limits, to 1e-12 relative; the Panda with its fingers locked (Pinocchio's reduced
model), ANYmal C on a fixed base."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin  # `pin` on PyPI: symbolic/requirements-test.txt
import pytest
import symengine as se

from symbolic import urdf
from symbolic.dynamics import BASE_DOFS, RigidBodyDynamics, contact_point
from symbolic.spec import SpecError

STATES = 10_000
FLOATING_STATES = STATES
CASES = [
    ("panda_description/urdf/panda.urdf", {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}),
    ("anymal_c_simple_description/urdf/anymal.urdf", {}),
]


def _pinocchio(path: Path, locked: dict[str, float]):
    model = pin.buildModelFromUrdf(str(path))
    if locked:
        reference = pin.neutral(model)
        for name, value in locked.items():
            reference[model.joints[model.getJointId(name)].idx_q] = value
        model = pin.buildReducedModel(model, [model.getJointId(n) for n in locked], reference)
    return model, model.createData()


def _worst_of_dynamics(worst: dict[str, float], out: np.ndarray, model, data, state, iv: list[int]) -> None:
    """Fold into ``worst`` the relative differences of our flat (M, b, g, τ) ``out`` from
    Pinocchio's at ``state`` = (q, v, a) in its coordinates, read at velocity indices ``iv``."""
    n = len(iv)
    qp, vp, ap = state
    got = {"M": out[:n * n].reshape(n, n), "b": out[n * n:n * n + n], "g": out[n * n + n:n * n + 2 * n],
           "tau": out[n * n + 2 * n:]}
    upper = pin.crba(model, data, qp)
    full = np.triu(upper) + np.triu(upper, 1).T
    want = {"M": full[np.ix_(iv, iv)], "b": pin.nonLinearEffects(model, data, qp, vp)[iv],
            "g": pin.computeGeneralizedGravity(model, data, qp)[iv], "tau": pin.rnea(model, data, qp, vp, ap)[iv]}
    _fold(worst, got, want)


def _fold(worst: dict[str, float], got: dict[str, np.ndarray], want: dict[str, np.ndarray]) -> None:
    """Each key's largest difference so far, relative to the larger of 1 and the truth's size."""
    for key in worst:
        scale = max(1.0, float(np.max(np.abs(want[key]))))
        worst[key] = max(worst[key], float(np.max(np.abs(got[key] - want[key]))) / scale)


@pytest.mark.parametrize("relative, locked", CASES)
def test_mass_matrix_bias_gravity_and_inverse_dynamics_match_pinocchio(relative, locked):
    path = urdf.description(relative)
    robot = urdf.load(path)
    moving = [j.name for j in robot.moving_joints if j.name not in locked]
    n = len(moving)
    q, qd, qdd = ([se.Symbol(f"{tag}{i}") for i in range(n)] for tag in ("q", "qd", "qdd"))
    dynamics = RigidBodyDynamics(robot, {**dict(zip(moving, q, strict=True)), **locked})
    assert dynamics.dofs == moving
    mass = dynamics.mass_matrix()
    values = [e for row in mass for e in row] + dynamics.bias(qd) + dynamics.gravity() + dynamics.inverse(qd, qdd)
    ours = se.Lambdify(q + qd + qdd, values, cse=True)

    model, data = _pinocchio(path, locked)
    iq = [model.joints[model.getJointId(name)].idx_q for name in moving]
    iv = [model.joints[model.getJointId(name)].idx_v for name in moving]
    assert model.nq == model.nv == n, "every joint here has one coordinate"
    limits = robot.limits(moving, "position")
    rng = np.random.default_rng(352)
    worst = {"M": 0.0, "b": 0.0, "g": 0.0, "tau": 0.0}
    for _ in range(STATES):
        x = np.array([rng.uniform(lo, hi) for lo, hi in limits])
        v, a = rng.uniform(-2.0, 2.0, n), rng.uniform(-10.0, 10.0, n)
        out = np.asarray(ours(np.concatenate([x, v, a]))).ravel()
        qp, vp, ap = np.zeros(n), np.zeros(n), np.zeros(n)
        qp[iq], vp[iv], ap[iv] = x, v, a
        _worst_of_dynamics(worst, out, model, data, (qp, vp, ap), iv)
    assert max(worst.values()) <= 1e-12, f"{relative}: largest relative differences {worst}"


def test_mass_matrix_is_symmetric_positive_definite_and_inverse_dynamics_is_linear_in_acceleration():
    # Independent of Pinocchio: M = Mᵀ ≻ 0, and τ(q, q̇, q̈) = M q̈ + b exactly as built.
    robot = urdf.load(urdf.description(CASES[0][0]))
    moving = [j.name for j in robot.moving_joints if j.name not in CASES[0][1]]
    n = len(moving)
    q, qd, qdd = ([se.Symbol(f"{tag}{i}") for i in range(n)] for tag in ("q", "qd", "qdd"))
    dynamics = RigidBodyDynamics(robot, {**dict(zip(moving, q, strict=True)), **CASES[0][1]})
    mass, bias, tau = dynamics.mass_matrix(), dynamics.bias(qd), dynamics.inverse(qd, qdd)
    f = se.Lambdify(q + qd + qdd, [e for row in mass for e in row] + bias + tau, cse=True)
    rng = np.random.default_rng(353)
    for _ in range(200):
        x = np.concatenate([rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n), rng.uniform(-10, 10, n)])
        out = np.asarray(f(x)).ravel()
        m, b, t = out[:n * n].reshape(n, n), out[n * n:n * n + n], out[n * n + n:]
        assert np.allclose(m, m.T, rtol=0, atol=1e-14)
        assert np.linalg.eigvalsh(m).min() > 0
        assert np.allclose(t, m @ x[2 * n:] + b, rtol=1e-12, atol=1e-12)


def test_named_intermediates_give_the_same_values(tmp_path):
    # With let (as in a family's kernel) every link's velocity, acceleration and force is a
    # named intermediate; substituting them back gives the expressions built without.
    robot = urdf.load(urdf.description(CASES[0][0]))
    moving = [j.name for j in robot.moving_joints if j.name not in CASES[0][1]]
    q, qd = [se.Symbol(f"q{i}") for i in range(7)], [se.Symbol(f"qd{i}") for i in range(7)]
    lets: dict[se.Symbol, se.Expr] = {}

    def let(name, value):
        symbol = se.Symbol(name)
        assert symbol not in lets, name
        lets[symbol] = value
        return symbol

    named = RigidBodyDynamics(robot, {**dict(zip(moving, q, strict=True)), **CASES[0][1]}, let).bias(qd)
    plain = RigidBodyDynamics(robot, {**dict(zip(moving, q, strict=True)), **CASES[0][1]}).bias(qd)
    order = list(lets)
    values = se.Lambdify(q + qd, plain, cse=True)
    point = np.random.default_rng(354).uniform(-1, 1, 14)
    env = dict(zip(q + qd, point, strict=True))
    for symbol in order:  # in definition order: each uses only earlier ones
        env[symbol] = float(lets[symbol].subs(env))
    got = [float(e.subs(env)) for e in named]
    assert np.allclose(got, np.asarray(values(point)).ravel(), rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("inertial, message", [
    ("<inertial><mass value='-1'/><inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/></inertial>",
     "link 'b', inertial: mass -1.0 must be >= 0"),
    ("<inertial><mass value='1'/></inertial>", "link 'b', inertial: needs <mass> and <inertia>"),
    ("<inertial><mass value='1'/><inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0'/></inertial>",
     "link 'b', inertial: inertia lacks ['izz']"),
])
def test_a_broken_inertial_names_the_link(tmp_path, inertial, message):
    path = tmp_path / "broken.urdf"
    path.write_text(f"<robot name='broken'><link name='a'/><link name='b'>{inertial}</link>"
                    "<joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 0 1'/></joint>"
                    "</robot>")
    with pytest.raises(SpecError) as err:
        urdf.load(path)
    assert message in str(err.value) and "broken.urdf" in str(err.value)


def test_a_floating_base_matches_pinocchios_free_flyer():
    # ANYmal C on Pinocchio's free flyer: the base's twist in its own frame (linear, then
    # angular) before the joints, its orientation a random rotation. M, C q̇ + g, g and
    # inverse dynamics at random states, to 1e-12 relative.
    relative = CASES[1][0]
    path = urdf.description(relative)
    robot = urdf.load(path)
    joints = [j.name for j in robot.moving_joints]
    n = 6 + len(joints)
    rotation = [[se.Symbol(f"r{i}{j}") for j in range(3)] for i in range(3)]
    q = [se.Symbol(f"q{i}") for i in range(len(joints))]
    qd, qdd = ([se.Symbol(f"{tag}{i}") for i in range(n)] for tag in ("qd", "qdd"))
    dynamics = RigidBodyDynamics(robot, dict(zip(joints, q, strict=True)), base_rotation=rotation)
    assert dynamics.dofs == [*BASE_DOFS, *joints]
    mass = dynamics.mass_matrix()
    values = [e for row in mass for e in row] + dynamics.bias(qd) + dynamics.gravity() + dynamics.inverse(qd, qdd)
    flat_rotation = [r for row in rotation for r in row]
    ours = se.Lambdify(flat_rotation + q + qd + qdd, values, cse=True)

    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = model.createData()
    iq = [model.joints[model.getJointId(name)].idx_q for name in joints]
    iv = list(range(6)) + [model.joints[model.getJointId(name)].idx_v for name in joints]
    limits = robot.limits(joints, "position")
    rng = np.random.default_rng(355)
    worst = {"M": 0.0, "b": 0.0, "g": 0.0, "tau": 0.0}
    for _ in range(FLOATING_STATES):
        quaternion = pin.Quaternion(*(rng.normal(size=4))).normalized()
        x = np.array([rng.uniform(lo, hi) for lo, hi in limits])
        v, a = rng.uniform(-2.0, 2.0, n), rng.uniform(-10.0, 10.0, n)
        r = quaternion.toRotationMatrix()
        out = np.asarray(ours(np.concatenate([r.ravel(), x, v, a]))).ravel()
        qp, vp, ap = pin.neutral(model), np.zeros(n), np.zeros(n)
        qp[:3] = rng.uniform(-1.0, 1.0, 3)  # the base's position changes nothing
        qp[3:7] = quaternion.coeffs()
        qp[iq] = x
        vp[iv], ap[iv] = v, a
        _worst_of_dynamics(worst, out, model, data, (qp, vp, ap), iv)
    assert max(worst.values()) <= 1e-12, f"{relative} floating: largest relative differences {worst}"


def test_contact_points_of_a_floating_base_match_pinocchios_frames():
    # Each ANYmal foot link's origin: position, world-aligned Jacobian and J̇v (the
    # classical acceleration at zero generalized acceleration) against Pinocchio's frame
    # of the same link on a free flyer, to 1e-12 relative.
    path = urdf.description(CASES[1][0])
    robot = urdf.load(path)
    joints = [j.name for j in robot.moving_joints]
    n = 6 + len(joints)
    rotation = [[se.Symbol(f"r{i}{j}") for j in range(3)] for i in range(3)]
    q = [se.Symbol(f"q{i}") for i in range(len(joints))]
    v = [se.Symbol(f"v{i}") for i in range(n)]
    feet = [link for link in robot.links if link.endswith("_FOOT")]
    assert len(feet) == 4
    exprs = []
    for foot in feet:
        r, jacobian, jdot_v = contact_point(robot, dict(zip(joints, q, strict=True)),
                                            dict(zip(joints, v[6:], strict=True)), rotation, v[:6], foot)
        exprs += r + [e for row in jacobian for e in row] + jdot_v
    ours = se.Lambdify([x for row in rotation for x in row] + q + v, exprs, cse=True)

    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = model.createData()
    iq = [model.joints[model.getJointId(name)].idx_q for name in joints]
    iv = list(range(6)) + [model.joints[model.getJointId(name)].idx_v for name in joints]
    frames = [model.getFrameId(foot) for foot in feet]
    limits = robot.limits(joints, "position")
    rng = np.random.default_rng(356)
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    worst = {"p": 0.0, "J": 0.0, "Jdot_v": 0.0}
    for _ in range(STATES):
        quaternion = pin.Quaternion(*(rng.normal(size=4))).normalized()
        x, rates = np.array([rng.uniform(lo, hi) for lo, hi in limits]), rng.uniform(-2.0, 2.0, n)
        r = quaternion.toRotationMatrix()
        out = np.asarray(ours(np.concatenate([r.ravel(), x, rates]))).ravel().reshape(4, -1)
        qp, vp = pin.neutral(model), np.zeros(n)
        qp[:3] = rng.uniform(-1.0, 1.0, 3)
        qp[3:7], qp[iq], vp[iv] = quaternion.coeffs(), x, rates
        pin.forwardKinematics(model, data, qp, vp, np.zeros(n))
        pin.updateFramePlacements(model, data)
        pin.computeJointJacobians(model, data, qp)
        for k, frame in enumerate(frames):
            got = {"p": qp[:3] + r @ out[k, :3], "J": out[k, 3:3 + 3 * n].reshape(3, n), "Jdot_v": out[k, 3 + 3 * n:]}
            want = {"p": data.oMf[frame].translation,
                    "J": pin.getFrameJacobian(model, data, frame, world)[:3][:, iv],
                    "Jdot_v": pin.getFrameClassicalAcceleration(model, data, frame, world).linear}
            _fold(worst, got, want)
    assert max(worst.values()) <= 1e-12, f"feet: largest relative differences {worst}"


@pytest.mark.parametrize("relative, locked", CASES)
def test_the_run_time_tree_keeps_the_robots_mass_and_centre_of_mass(relative, locked):
    # The tree the generated code walks (symbolic.dynamics.Tree: rigid links merged into
    # the body they hang from, held joints folded in) against Pinocchio's total mass and
    # centre of mass of the same URDF, at the zero configuration and at a turned one. On a
    # fixed base, Pinocchio counts neither: what is rigid on the world is its universe's,
    # here the root body's.
    path = urdf.description(relative)
    robot = urdf.load(path)
    names = [j.name for j in robot.moving_joints if j.name not in locked]
    q = se.symbols([f"q{k}" for k in range(len(names))])
    v = se.symbols([f"v{k}" for k in range(len(names))])
    dynamics = RigidBodyDynamics(robot, {**dict(zip(names, q, strict=True)), **locked})
    tree = dynamics.tree([*q, *v], [v[dynamics.joint_dofs.index(n)] for n in dynamics.dofs])
    assert len(tree.bodies) == len(names) + 1 and tree.coordinate_states == tuple(
        names.index(n) for n in dynamics.joint_dofs)
    model, data = _pinocchio(path, locked)
    assert sum(b.mass for b in tree.bodies[1:]) == pytest.approx(pin.computeTotalMass(model), rel=1e-14)
    rng = np.random.default_rng(3)
    for values in (np.zeros(len(names)), rng.uniform(-1.0, 1.0, len(names))):
        # The tree's bodies placed by hand: each joint's rotation about its axis.
        poses = []
        for b in tree.bodies:
            r, p = np.array(b.rotation).reshape(3, 3), np.array(b.origin)
            if b.joint == "revolute":
                r = r @ _rotation(np.array(b.axis), values[b.coordinate])
            elif b.joint == "prismatic":
                p = p + r @ (np.array(b.axis) * values[b.coordinate])
            if poses:
                parent_r, parent_p = poses[b.parent]
                r, p = parent_r @ r, parent_p + parent_r @ p
            poses.append((r, p))
        moments = sum(b.mass * (p + r @ np.array(b.com)) for b, (r, p) in zip(tree.bodies[1:], poses[1:], strict=True))
        pin_q = pin.neutral(model)
        for name, value in zip(names, values, strict=True):
            pin_q[model.joints[model.getJointId(name)].idx_q] = value
        np.testing.assert_allclose(moments / pin.computeTotalMass(model), pin.centerOfMass(model, data, pin_q),
                                   rtol=0, atol=1e-12)


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_a_run_time_dynamics_output_refuses_what_is_not_a_state():
    from symbolic.spec import System

    robot = urdf.load(urdf.description(CASES[0][0]))
    s = System("arm", doc="An arm.")
    names = [j.name for j in robot.moving_joints if j.name not in CASES[0][1]]
    x = s.states([f"q{k}" for k in range(len(names))] + [f"v{k}" for k in range(len(names))],
                 docs=["angle [rad]"] * len(names) + ["rate [rad/s]"] * len(names))
    q, v = x[:len(names)], x[len(names):]
    dynamics = RigidBodyDynamics(robot, {**dict(zip(names, q, strict=True)), **CASES[0][1]})
    with pytest.raises(SpecError, match="velocity panda_joint1 is 2\\*x_v0, not a state"):
        s.rigid_body_output("dynamics", dynamics, [2 * v[0], *v[1:]], doc="M and bias.")
    with pytest.raises(SpecError, match="order must list each of the 7 degrees of freedom once"):
        s.rigid_body_output("dynamics", dynamics, v, doc="M and bias.", order=[0, 0, 1, 2, 3, 4, 5])
    s.rigid_body_output("dynamics", dynamics, v, doc="M and bias.")
    assert [name for name, _, _ in s.outputs[0].values] == ["mass_matrix", "bias"] and s.outputs[0].tree is not None
