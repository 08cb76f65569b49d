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

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

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


@dataclass(frozen=True)
class TreeBody:
    """One body of a :class:`Tree`, in numbers (``cbfgen::rigid_body::Body``)."""

    parent: int
    rotation: tuple[float, ...]  # its frame in the parent's at zero coordinate, row by row
    origin: tuple[float, float, float]
    joint: str  # "fixed", "revolute" or "prismatic"
    axis: tuple[float, float, float]
    coordinate: int  # index into the joint coordinates (moving joints)
    velocity: int  # index into the generalized velocities (moving joints)
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, ...]  # about the centre of mass, row by row


@dataclass(frozen=True)
class Tree:
    """The tree :class:`RigidBodyDynamics` walks, as numbers the run time walks the same
    way (``cbfgen::rigid_body``): every rigidly attached link merged into the moving body
    it hangs from, and where each coordinate, velocity and the base's rotation are in the
    state."""

    bodies: tuple[TreeBody, ...]
    floating: bool
    gravity: tuple[float, float, float]
    coordinate_states: tuple[int, ...]  # state index of each joint coordinate
    velocity_states: tuple[int, ...]  # state index of each generalized velocity
    rotation_states: tuple[int, ...] | None  # the base rotation's 9 state indices, row by row


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

    def tree(self, states: Sequence[se.Symbol], velocity: Sequence[se.Expr]) -> Tree:
        """This model as numbers (:class:`Tree`) for ``velocity`` (one per ``dofs`` entry),
        each joint coordinate, velocity and base rotation entry located in ``states``.
        Raises SpecError when one is not a state itself."""
        where = f"URDF {self.robot.source.name}, rigid-body tree"
        index = {sym: i for i, sym in enumerate(states)}

        def state_of(what: str, expr: se.Expr) -> int:
            if expr not in index:
                raise SpecError(f"{where}: {what} is {expr}, not a state: the run-time tree reads the joint "
                                "coordinates, the velocities and the base rotation straight from the state")
            return index[expr]

        if len(velocity) != len(self.dofs):
            raise SpecError(f"{where}: give one velocity per degree of freedom ({self.dofs})")
        floating = self._base_rotation is not None
        base = len(BASE_DOFS) if floating else 0
        coordinate = {name: k for k, name in enumerate(self.joint_dofs)}
        # Each link's carrier (the moving body it is rigidly attached to, or the root) and
        # its pose in the carrier's frame; each carrier's parts: (mass, com, inertia) in it.
        carrier = {self.robot.root: (0, _IDENTITY, (0.0, 0.0, 0.0))}
        parts: list[list[tuple[float, Vec, Mat]]] = [[]]
        bodies: list[dict] = [dict(parent=0, rotation=_IDENTITY, origin=(0.0, 0.0, 0.0), joint="fixed",
                                   axis=(0.0, 0.0, 0.0), coordinate=0, velocity=0)]

        def add_inertial(link: str, body: int, rotation: Mat, origin: Vec) -> None:
            inertial = self.robot.inertials.get(link)
            if inertial is not None:
                com = _plus(origin, _times(rotation, [float(_number(c)) for c in inertial.com]))
                inertia = _rotate(rotation, [[float(_number(v)) for v in row] for row in inertial.inertia])
                parts[body].append((float(_number(inertial.mass)), com, inertia))

        add_inertial(self.robot.root, 0, _IDENTITY, (0.0, 0.0, 0.0))
        for joint in self.robot.joints:  # parents first
            body, rotation, origin = carrier[joint.parent]
            r = [[float(v) for v in row] for row in rpy_matrix(joint.rpy)]
            placed_rotation, placed_origin = _compose(rotation, origin, r, [float(_number(v)) for v in joint.xyz])
            value = self._q.get(joint.name)
            moving = joint.name in coordinate
            if not moving and value is not None and joint.type in ("revolute", "continuous", "prismatic"):
                # Held still: its value folds into the placement.
                turn = axis_rotation(joint.axis, value) if joint.type != "prismatic" else None
                if turn is not None:
                    placed_rotation = _matmul3(placed_rotation, [[float(v) for v in row] for row in turn])
                else:
                    slide = [float(_snap(a)) * float(value) for a in joint.axis]
                    placed_origin = _plus(placed_origin, _times(placed_rotation, slide))
            if not moving:
                carrier[joint.child] = (body, placed_rotation, placed_origin)
                add_inertial(joint.child, body, placed_rotation, placed_origin)
                continue
            k = coordinate[joint.name]
            bodies.append(dict(parent=body, rotation=placed_rotation, origin=placed_origin,
                               joint="prismatic" if joint.type == "prismatic" else "revolute",
                               axis=tuple(float(_snap(a)) for a in joint.axis), coordinate=k, velocity=base + k))
            parts.append([])
            carrier[joint.child] = (len(bodies) - 1, _IDENTITY, (0.0, 0.0, 0.0))
            add_inertial(joint.child, len(bodies) - 1, _IDENTITY, (0.0, 0.0, 0.0))
        out = []
        for b, body_parts in zip(bodies, parts, strict=True):
            mass, com, inertia = _combine(body_parts)
            out.append(TreeBody(b["parent"], tuple(v for row in b["rotation"] for v in row), tuple(b["origin"]),
                                b["joint"], b["axis"], b["coordinate"], b["velocity"], mass, com,
                                tuple(v for row in inertia for v in row)))
        rotation_states = None
        if floating:
            rotation_states = tuple(state_of(f"base rotation entry {i}{j}", self._base_rotation[i][j])
                                    for i in range(3) for j in range(3))
        return Tree(tuple(out), floating, tuple(float(g) for g in self._gravity),
                    tuple(state_of(f"joint {n}'s coordinate", self._q[n]) for n in self.joint_dofs),
                    tuple(state_of(f"velocity {n}", se.sympify(v)) for n, v in zip(self.dofs, velocity, strict=True)),
                    rotation_states)

    def mass_matrix(self) -> list[list[se.Expr]]:
        """M(q), rows and columns in ``dofs`` order (symmetric; built column by column)."""
        n = len(self.dofs)
        columns = [self.inverse([0] * n, [int(i == j) for i in range(n)], gravity=False) for j in range(n)]
        return [[columns[j][i] for j in range(n)] for i in range(n)]


Vec = tuple[float, float, float]
Mat = list[list[float]]
_IDENTITY: Mat = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def _matmul3(a: Mat, b: Mat) -> Mat:
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _times(a: Mat, v: Sequence[float]) -> Vec:
    return tuple(sum(a[i][k] * v[k] for k in range(3)) for i in range(3))


def _plus(a: Sequence[float], b: Sequence[float]) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _compose(rotation: Mat, origin: Vec, r: Mat, p: Sequence[float]) -> tuple[Mat, Vec]:
    """(rotation, origin) followed by (r, p): a frame placed in a frame."""
    return _matmul3(rotation, r), _plus(origin, _times(rotation, p))


def _rotate(r: Mat, inertia: Mat) -> Mat:
    """R I Rᵀ: an inertia seen in the frame R is given in."""
    return _matmul3(_matmul3(r, inertia), [list(row) for row in zip(*r, strict=True)])


def _combine(parts: Sequence[tuple[float, Vec, Mat]]) -> tuple[float, Vec, Mat]:
    """Rigidly joined inertials (each mass, centre and inertia about it, in one frame) as
    one: the total mass, its centre and the inertia about it (parallel axes)."""
    mass = math.fsum(m for m, _, _ in parts)
    if mass == 0.0:
        com: Vec = (0.0, 0.0, 0.0)
    else:
        com = tuple(math.fsum(m * c[i] for m, c, _ in parts) / mass for i in range(3))
    inertia = [[0.0] * 3 for _ in range(3)]
    for m, c, own in parts:
        d = [c[i] - com[i] for i in range(3)]
        dd = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
        for i in range(3):
            for j in range(3):
                inertia[i][j] += own[i][j] + m * ((dd if i == j else 0.0) - d[i] * d[j])
    return mass, com, inertia


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
