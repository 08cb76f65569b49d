"""A robot's rigid-body dynamics from its URDF's inertials, symbolically.

``RigidBodyDynamics(robot, q)`` takes one value per moving joint, as ``urdf.Kinematics``
does: an expression (usually a state) for a joint that moves, a number for one the spec
holds still (it is then rigid). Its degrees of freedom are the joints given expressions,
in tree order. It gives

* ``inverse(qd, qdd)``: the joint forces τ = M(q) q̈ + C(q, q̇) q̇ + g(q), by the
  recursive Newton–Euler algorithm (Featherstone, *Rigid Body Dynamics Algorithms*, ch. 5);
* ``bias(qd)``: C(q, q̇) q̇ + g(q), the same with q̈ = 0;
* ``gravity()``: g(q), with q̇ = q̈ = 0;
* ``mass_matrix()``: M(q), column j the forces for q̈ = e_j with no velocity or gravity.

Everything is in each link's own frame, in spatial (6-D) vectors written as pairs of
3-vectors: a motion (ω, v) is the link's angular velocity and the velocity of the point
at its origin; a force (n, f) is the moment about its origin and the force. Gravity
enters as an upward acceleration of the root (``gravity`` is the world's, default
(0, 0, −9.81) m/s² as Pinocchio's). With ``let_`` every link's velocity, acceleration and
force are named intermediates, so a kernel holds each once.

Joint forces are torques [N m] for revolute and continuous joints, forces [N] for
prismatic ones. A link without ``<inertial>`` is massless.

**A floating base.** Given ``base_rotation`` (the root link's orientation in the world, a
3×3 matrix of expressions whose columns are the base's axes), the root moves freely: six
more degrees of freedom come first, the base's twist in its own frame ordered as
Pinocchio's free flyer orders its velocity — linear ``(vx, vy, vz)`` of the base origin,
then angular ``(wx, wy, wz)``, both in the base frame. Their generalized forces are the
force and then the moment on the base, in the base frame. In these coordinates M depends on
the joints only; the orientation enters through gravity, seen from the base.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import symengine as se

from .linalg import cross, matvec, matvec_transposed
from .spec import SpecError
from .urdf import (
    Joint,
    Kinematics,
    Urdf,
    _identifier,
    _matmul,
    _matvec,
    _number,
    _snap,
    axis_rotation,
    require_joint_values,
    rpy_matrix,
)

Vector3 = list[se.Expr]
Spatial = tuple[Vector3, Vector3]


def _add(a: Sequence[se.Expr], b: Sequence[se.Expr]) -> Vector3:
    return [x + y for x, y in zip(a, b, strict=True)]


def _scale(k: se.Expr, a: Sequence[se.Expr]) -> Vector3:
    return [k * x for x in a]


ZERO: Vector3 = [se.Integer(0)] * 3


# The floating base's degrees of freedom, in Pinocchio's free-flyer order (base frame).
BASE_DOFS = ("base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz")


class RigidBodyDynamics:
    """M(q), C(q, q̇) q̇ + g(q) and inverse dynamics of a URDF's tree, its root fixed or
    floating (``base_rotation``)."""

    def __init__(self, robot: Urdf, q: Mapping[str, se.Expr | float],
                 let_: Callable[[str, se.Expr], se.Symbol] | None = None,
                 gravity: Sequence[float] = (0.0, 0.0, -9.81),
                 base_rotation: Sequence[Sequence[se.Expr]] | None = None):
        require_joint_values(robot, q)
        self.robot = robot
        self._q = {name: se.sympify(v) for name, v in q.items()}
        if base_rotation is not None and (len(base_rotation) != 3 or any(len(row) != 3 for row in base_rotation)):
            raise SpecError(f"URDF {robot.source.name}: base_rotation must be 3x3, got {base_rotation!r}")
        self._base_rotation = None if base_rotation is None else [[se.sympify(v) for v in row]
                                                                    for row in base_rotation]
        self.joint_dofs = [j.name for j in robot.moving_joints if self._q[j.name].free_symbols]
        self.dofs = (list(BASE_DOFS) if base_rotation is not None else []) + self.joint_dofs
        self._let = let_
        self._gravity = [se.sympify(g) for g in gravity]
        # Each joint's child pose in its parent's frame: (R, p).
        self._placement = {j.name: self._joint_placement(j) for j in robot.joints}
        self._calls = 0

    def _joint_placement(self, joint: Joint) -> tuple[list[list[se.Expr]], Vector3]:
        r = rpy_matrix(joint.rpy)
        p = [_number(v) for v in joint.xyz]
        if joint.type in ("revolute", "continuous"):
            r = _matmul(r, axis_rotation(joint.axis, self._q[joint.name]))
        elif joint.type == "prismatic":
            p = _add(p, matvec(r, [_snap(a) * self._q[joint.name] for a in joint.axis]))
        return r, p

    def _name(self, tag: str, link: str, values: Vector3) -> Vector3:
        if self._let is None:
            return values
        return [self._let(f"rnea{self._calls}_{_identifier(link)}_{tag}{i}", v) for i, v in enumerate(values)]

    def _subspace(self, joint: Joint) -> Spatial:
        """The joint's motion per unit rate, in the child's frame."""
        axis = [_snap(a) for a in joint.axis]
        return (axis, ZERO) if joint.type in ("revolute", "continuous") else (ZERO, axis)

    def _inertia_times(self, link: str, motion: Spatial) -> Spatial:
        """I·(ω, v) at the link's origin: f = m (v + ω × c), n = I_c ω + c × f."""
        inertial = self.robot.inertials.get(link)
        if inertial is None or inertial.mass == 0 and not any(any(row) for row in inertial.inertia):
            return ZERO, ZERO
        w, v = motion
        c = [_number(x) for x in inertial.com]
        f = _scale(_number(inertial.mass), _add(v, cross(w, c)))
        n = _add(matvec([[_number(x) for x in row] for row in inertial.inertia], w), cross(c, f))
        return n, f

    def inverse(self, qd: Sequence[se.Expr], qdd: Sequence[se.Expr], gravity: bool = True) -> list[se.Expr]:
        """τ for rates ``qd`` and accelerations ``qdd`` (one each per ``dofs`` entry)."""
        if len(qd) != len(self.dofs) or len(qdd) != len(self.dofs):
            raise SpecError(f"URDF {self.robot.source.name}: give one rate and one acceleration per degree of "
                            f"freedom ({self.dofs})")
        self._calls += 1
        qd, qdd = [se.sympify(v) for v in qd], [se.sympify(v) for v in qdd]
        rate = dict(zip(self.dofs, qd, strict=True))
        accel = dict(zip(self.dofs, qdd, strict=True))
        root = self.robot.root
        lift = [-g for g in self._gravity] if gravity else ZERO
        force: dict[str, Spatial] = {}
        if self._base_rotation is None:
            velocity: dict[str, Spatial] = {root: (ZERO, ZERO)}
            acceleration: dict[str, Spatial] = {root: (ZERO, lift)}
        else:
            # The base's own twist and its rate (a free joint's motion subspace is the
            # identity and its velocity-product term v × v vanishes); gravity as an upward
            # acceleration of the base, seen from the base: Rᵀ (−g).
            velocity = {root: (qd[3:6], qd[0:3])}
            acceleration = {root: (qdd[3:6], _add(qdd[0:3], matvec_transposed(self._base_rotation, lift)))}
            force[root] = self._link_force(root, velocity[root], acceleration[root])
        for joint in self.robot.joints:  # parents first
            r, p = self._placement[joint.name]
            (w, v), (dw, dv) = velocity[joint.parent], acceleration[joint.parent]
            # Parent motion in the child's frame: ω' = Rᵀ ω, v' = Rᵀ (v + ω × p).
            w_c, v_c = matvec_transposed(r, w), matvec_transposed(r, _add(v, cross(w, p)))
            dw_c, dv_c = matvec_transposed(r, dw), matvec_transposed(r, _add(dv, cross(dw, p)))
            if joint.name in rate:
                s_w, s_v = self._subspace(joint)
                jw, jv = _scale(rate[joint.name], s_w), _scale(rate[joint.name], s_v)
                w_c, v_c = _add(w_c, jw), _add(v_c, jv)
                # a = X a_parent + S q̈ + v × (S q̇)
                dw_c = _add(_add(dw_c, _scale(accel[joint.name], s_w)), cross(w_c, jw))
                dv_c = _add(_add(dv_c, _scale(accel[joint.name], s_v)), _add(cross(w_c, jv), cross(v_c, jw)))
            link = joint.child
            velocity[link] = (self._name("w", link, w_c), self._name("v", link, v_c))
            acceleration[link] = (self._name("dw", link, dw_c), self._name("dv", link, dv_c))
            force[link] = self._link_force(link, velocity[link], acceleration[link])
        tau: dict[str, se.Expr] = {}
        for joint in reversed(self.robot.joints):  # children first
            link = joint.child
            n, f = (self._name("n", link, force[link][0]), self._name("f", link, force[link][1]))
            if joint.name in rate:
                s_w, s_v = self._subspace(joint)
                tau[joint.name] = se.Add(*[a * b for a, b in zip(s_w, n, strict=True)],
                                         *[a * b for a, b in zip(s_v, f, strict=True)])
            if joint.parent in force:
                r, p = self._placement[joint.name]
                f_p = matvec(r, f)
                n_p = _add(matvec(r, n), cross(p, f_p))
                pn, pf = force[joint.parent]
                force[joint.parent] = (_add(pn, n_p), _add(pf, f_p))
        if self._base_rotation is not None:
            n, f = force[root]
            tau.update(zip(BASE_DOFS, [*f, *n], strict=True))
        return [tau[name] for name in self.dofs]

    def _link_force(self, link: str, motion: Spatial, rate: Spatial) -> Spatial:
        """The force a link's own inertia takes: f = I a + v ×* (I v)."""
        (w, v), (dw, dv) = motion, rate
        ia_n, ia_f = self._inertia_times(link, (dw, dv))
        iv_n, iv_f = self._inertia_times(link, (w, v))
        return _add(ia_n, _add(cross(w, iv_n), cross(v, iv_f))), _add(ia_f, cross(w, iv_f))

    def bias(self, qd: Sequence[se.Expr]) -> list[se.Expr]:
        """C(q, q̇) q̇ + g(q)."""
        return self.inverse(qd, [0] * len(self.dofs))

    def gravity(self) -> list[se.Expr]:
        """g(q): the joint forces that hold the robot still."""
        return self.inverse([0] * len(self.dofs), [0] * len(self.dofs))

    def mass_matrix(self) -> list[list[se.Expr]]:
        """M(q), rows and columns in ``dofs`` order (symmetric; built column by column)."""
        n = len(self.dofs)
        columns = [self.inverse([0] * n, [int(i == j) for i in range(n)], gravity=False) for j in range(n)]
        return [[columns[j][i] for j in range(n)] for i in range(n)]


def contact_point(robot: Urdf, q: Mapping[str, se.Expr | float], joint_rates: Mapping[str, se.Expr],
                  base_rotation: Sequence[Sequence[se.Expr]], base_twist: Sequence[se.Expr], link: str,
                  offset: Sequence[float] = (0.0, 0.0, 0.0)) -> tuple[Vector3, list[Vector3], Vector3]:
    """A point fixed on ``link`` of a floating-base robot, in :class:`RigidBodyDynamics`'
    floating coordinates: ``(r, J, J̇v)`` with ``r`` the point in the base frame (its world
    position is the base position plus R r), ``J`` the 3 × (6 + joints) Jacobian of its
    world velocity (rows x, y, z; columns the base twist, then ``joint_rates``' joints in
    order) and ``J̇v`` its world acceleration when every generalized acceleration is zero.

    ``q`` maps each moving joint to a symbol or a number (a held joint); ``joint_rates``
    maps each joint that moves to its rate. With ṙ = J_r q̇ (J_r = ∂r/∂q):
    ṗ = R (v_b + ω_b × r + J_r q̇), so J = R [I, −[r]×, J_r], and with every acceleration
    zero, p̈ = R (ω_b × (v_b + ω_b × r + J_r q̇) + ω_b × J_r q̇ + (∂(J_r q̇)/∂q) q̇)."""
    joints = list(joint_rates)
    for name in joints:
        if not isinstance(se.sympify(q.get(name, 0)), se.Symbol):
            raise SpecError(f"URDF {robot.source.name}: joint {name!r} needs a symbol to differentiate by, "
                            f"got {q.get(name)!r}")
    if len(base_twist) != 6:
        raise SpecError(f"URDF {robot.source.name}: the base twist has 6 entries (v, w), got {len(base_twist)}")
    rotation, position = Kinematics(robot, q).pose(link)
    r = [position[i] + e for i, e in enumerate(_matvec(rotation, [_number(v) for v in offset]))]
    symbols = [se.sympify(q[name]) for name in joints]
    rates = [se.sympify(joint_rates[name]) for name in joints]
    j_r = [[se.diff(r[i], s) for s in symbols] for i in range(3)]
    r_dot = [se.Add(*[j_r[i][k] * rates[k] for k in range(len(joints))]) for i in range(3)]
    v_b, w_b = [se.sympify(v) for v in base_twist[:3]], [se.sympify(v) for v in base_twist[3:]]
    skew = [[0, r[2], -r[1]], [-r[2], 0, r[0]], [r[1], -r[0], 0]]  # −[r]×
    local = [[*([int(i == j) for j in range(3)]), *skew[i], *j_r[i]] for i in range(3)]
    jacobian = [[se.Add(*[se.sympify(base_rotation[i][k]) * local[k][c] for k in range(3)])
                 for c in range(len(local[0]))] for i in range(3)]
    r_ddot = [se.Add(*[se.diff(r_dot[i], s) * rate for s, rate in zip(symbols, rates, strict=True)])
              for i in range(3)]
    velocity = _add(_add(v_b, cross(w_b, r)), r_dot)
    jdot_v = _matvec(base_rotation, _add(_add(cross(w_b, velocity), cross(w_b, r_dot)), r_ddot))
    return r, jacobian, jdot_v
