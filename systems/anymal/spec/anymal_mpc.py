"""ANYmal C as seed 004's kino-dynamic MPC sees it (eqs. 18-20): one rigid body with the
legs' joints as kinematic integrators, contact forces and joint velocities as inputs.

**Description.** The same URDF and SRDF as ``anymal.py``, through ``anymal_robot.py``
(the robot, its legs, feet, limits and standing state are stated once, there).

**Model.** States: the trunk's orientation as roll, pitch, yaw (R = Rz Ry Rx, as
``anymal.py``), the centre of mass p in the world [m], the trunk's angular velocity w and
the centre of mass's velocity v, both in the trunk's frame, then the 12 joint angles.
Inputs: the four feet's contact forces f_i in the trunk's frame [N], then the 12 joint
velocities [rad/s]. The body is the whole robot frozen at its SRDF standing state: its
mass m, its centre of mass c (a fixed point of the trunk's frame) and its rotational
inertia I about c are the standing robot's (the seed's "constant inertia taken
upright"). So

    euler' = E(euler)^-1 w,  p' = R v,
    w' = I^-1 (sum_i r_i(q) x f_i - w x I w),  v' = (1/m) sum_i f_i + R^T g - w x v,
    q' = u_q,

with r_i(q) the foot sphere's centre relative to c in the trunk's frame. The legs move
the feet (and so the moment arms) but, in this model, not the centre of mass or the
inertia: the seed's simplification.

**Outputs** (what the MPC linearises; ``inputs=True`` ones take (x, u)): ``flow``: x' and
its Jacobians in x and u; ``feet``: each foot centre's world position and velocity with
their Jacobians; ``orientation``: R and its derivatives in roll, pitch, yaw (to rotate a
trunk-frame force into the world for the friction cone).

**Family.** ``foot_region``: a foot's centre inside half-spaces n . c <= d (world, given
at run time); relative degree 1 in the joint velocities: seed 004's eq. 25, h' + gamma h
>= 0, at one state.
"""

from __future__ import annotations

import symengine as se

from symbolic import urdf
from symbolic.linalg import cross, matvec, matvec_transposed
from symbolic.spec import System

import anymal_robot

GRAVITY = 9.81
FORCE_LIMIT = 2000.0  # |f| per axis [N]: an input box wide enough never to bind (4x the weight)
CBF_RATE = [20.0]  # gamma of eq. 25 in the one-state family [1/s]


def _standing_body() -> tuple[float, list[float], list[list[float]]]:
    """The standing robot as one rigid body: mass [kg], centre of mass in the trunk frame
    [m], rotational inertia about it in the trunk frame [kg m^2], from the URDF's
    inertials at the SRDF's standing joints."""
    standing = dict(zip(anymal_robot.JOINT_NAMES, anymal_robot.STANDING_JOINTS, strict=True))
    fk = urdf.Kinematics(anymal_robot.ROBOT, standing)
    parts = []
    for link, inertial in anymal_robot.ROBOT.inertials.items():
        rotation, position = fk.pose(link)
        r = [[float(v) for v in row] for row in rotation]
        centre = [float(position[i]) + sum(r[i][k] * inertial.com[k] for k in range(3)) for i in range(3)]
        inertia = [[sum(r[i][a] * inertial.inertia[a][b] * r[j][b] for a in range(3) for b in range(3))
                    for j in range(3)] for i in range(3)]
        parts.append((inertial.mass, centre, inertia))
    mass = sum(m for m, _, _ in parts)
    com = [sum(m * c[i] for m, c, _ in parts) / mass for i in range(3)]
    total = [[0.0] * 3 for _ in range(3)]
    for m, c, inertia in parts:
        d = [c[i] - com[i] for i in range(3)]
        dd = sum(v * v for v in d)
        for i in range(3):
            for j in range(3):
                total[i][j] += inertia[i][j] + m * ((dd if i == j else 0.0) - d[i] * d[j])
    return mass, com, total


MASS, COM_OFFSET, INERTIA = _standing_body()
STANDING_COM_HEIGHT = anymal_robot.STANDING[2] + COM_OFFSET[2]


def _arm(leg: int, q, let=None) -> list[se.Expr]:
    """Foot ``leg``'s sphere centre relative to the centre of mass, trunk frame."""
    fk = urdf.Kinematics(anymal_robot.ROBOT, dict(zip(anymal_robot.JOINT_NAMES, q, strict=True)), let)
    return [c - o for c, o in zip(anymal_robot.foot_center(leg, fk), COM_OFFSET, strict=True)]


def _jacobian(exprs, symbols):
    return [[se.diff(e, s) for s in symbols] for e in exprs]


def build() -> System:
    s = System("anymal_mpc", doc="ANYmal C for seed 004's kino-dynamic MPC (systems/anymal/spec/anymal_mpc.py): "
                                 "the standing robot as one rigid body, contact forces and joint velocities as "
                                 "inputs, feet inside convex foothold regions.")
    joints = [j.lower() for j in anymal_robot.JOINT_NAMES]
    euler_names, com_names = ["roll", "pitch", "yaw"], ["com_x", "com_y", "com_z"]
    names = [*euler_names, *com_names, "wx", "wy", "wz", "vx", "vy", "vz", *joints]
    docs = (["trunk roll [rad]", "trunk pitch [rad]", "trunk yaw [rad]"]
            + [f"centre of mass {a}, world [m]" for a in "xyz"]
            + [f"trunk angular velocity {a}, trunk frame [rad/s]" for a in "xyz"]
            + [f"centre-of-mass velocity {a}, trunk frame [m/s]" for a in "xyz"]
            + [f"joint {j} angle [rad]" for j in anymal_robot.JOINT_NAMES])
    x = s.states(names, docs=docs)
    euler, p, w, v, q = x[0:3], x[3:6], x[6:9], x[9:12], x[12:24]
    legs = [leg.lower() for leg in anymal_robot.LEGS]
    u = s.inputs([f"{leg}_f{a}" for leg in legs for a in "xyz"] + [f"{j}_rate" for j in joints],
                 limits=[(-FORCE_LIMIT, FORCE_LIMIT)] * 12 + [(-m, m) for m in anymal_robot.QD_MAX],
                 docs=[f"{leg} foot contact force {a}, trunk frame [N]" for leg in anymal_robot.LEGS for a in "xyz"]
                 + [f"joint {j} velocity [rad/s]" for j in anymal_robot.JOINT_NAMES])
    rates = u[12:24]

    rotation = urdf.euler_zyx(*euler)
    roll, pitch = euler[0], euler[1]
    # Euler-angle rates from the trunk-frame angular velocity (Rz Ry Rx).
    cr, sr, cp, tp = se.cos(roll), se.sin(roll), se.cos(pitch), se.tan(pitch)
    euler_rate = [w[0] + sr * tp * w[1] + cr * tp * w[2], cr * w[1] - sr * w[2], (sr * w[1] + cr * w[2]) / cp]
    arms = [_arm(leg, q) for leg in range(4)]

    inertia = [[se.RealDouble(v) for v in row] for row in INERTIA]
    inverse = se.DenseMatrix(inertia).inv().tolist()
    gyroscopic = cross(w, matvec(inertia, w))
    gravity_trunk = matvec_transposed(rotation, [0, 0, -GRAVITY])
    drift = (euler_rate + matvec(rotation, v) + matvec(inverse, [-g for g in gyroscopic])
             + [gravity_trunk[i] - cross(w, v)[i] for i in range(3)] + [0] * 12)
    # g(x): moment arms into the angular rows, 1/m into the linear ones, identity for q.
    g = [[se.Integer(0)] * 24 for _ in range(24)]
    for leg in range(4):
        arm = arms[leg]
        skew = [[0, -arm[2], arm[1]], [arm[2], 0, -arm[0]], [-arm[1], arm[0], 0]]
        for i in range(3):
            for k in range(3):
                g[6 + i][3 * leg + k] = sum((inverse[i][a] * skew[a][k] for a in range(3)), se.Integer(0))
            g[9 + i][3 * leg + i] = se.RealDouble(1.0 / MASS)
    for j in range(12):
        g[12 + j][12 + j] = se.Integer(1)
    s.dynamics(f=drift, g=g)

    flow = [drift[i] + sum((g[i][j] * u[j] for j in range(24)), se.Integer(0)) for i in range(24)]
    flow_a, flow_b = _jacobian(flow, x), _jacobian(flow, u)
    s.output("flow", [
        ("xdot", flow, "x' = f(x) + g(x) u"),
        ("a", flow_a, "d x' / d x, one row per state"),
        ("b", flow_b, "d x' / d u (= g(x)), one row per state"),
    ], doc="The kino-dynamic model's flow and its Jacobians, for the MPC's linearisation.", inputs=True)
    # Their structural non-zeros, for the MPC's sparsity (1 where an entry is not
    # identically zero).
    for name, jacobian, doc in [("flow_a_pattern", flow_a, "d x' / d x"), ("flow_b_pattern", flow_b, "d x' / d u")]:
        s.constant(name, [[int(e != 0) for e in row] for row in jacobian],
                   f"1 where {doc} (the flow output's) is not identically zero, else 0.")

    positions, velocities = [], []
    for leg in range(4):
        positions.append([p[i] + e for i, e in enumerate(matvec(rotation, arms[leg]))])
        # The foot's velocity: the body's motion at the foot plus the leg's own.
        leg_rate = [sum((se.diff(arms[leg][i], qj) * rj for qj, rj in zip(q, rates, strict=True)), se.Integer(0))
                    for i in range(3)]
        local = [v[i] + cross(w, arms[leg])[i] + leg_rate[i] for i in range(3)]
        velocities.append(matvec(rotation, local))
    flat_p = [e for foot in positions for e in foot]
    flat_v = [e for foot in velocities for e in foot]
    s.output("feet", [
        ("positions", positions, "foot sphere centres, world [m], LF RF LH RH"),
        ("position_jacobians", _jacobian(flat_p, x), "d position / d x: rows 3i..3i+3 are foot i's x y z"),
        ("velocities", velocities, "foot centre velocities, world [m/s]"),
        ("velocity_jacobians_x", _jacobian(flat_v, x), "d velocity / d x, rows as position_jacobians"),
        ("velocity_jacobians_u", _jacobian(flat_v, u), "d velocity / d u, rows as position_jacobians"),
    ], doc="The feet: each sphere centre's world position and velocity, with their Jacobians.", inputs=True)

    s.output("orientation", [
        ("rotation", rotation, "R: world from trunk"),
        ("derivatives", [[se.diff(rotation[i][j], a) for i in range(3) for j in range(3)] for a in euler],
         "dR/d roll, dR/d pitch, dR/d yaw, each row-major"),
    ], doc="The trunk's rotation and its derivatives in roll, pitch, yaw.")

    def foot_region(prm):
        c = [p[i] + e for i, e in enumerate(matvec(rotation, _arm(prm.index, q, prm.let)))]
        return [("inside", prm.offset - sum((n * e for n, e in zip(prm.normal, c, strict=True)), se.Integer(0)))]

    s.family("foot_region", foot_region,
             params={"normal": ((3,), "half-space normal n, world frame (outward; unit for h in metres)"),
                     "offset": ((), "half-space offset d [m]: the region is n . c <= d")},
             over=legs, capacity=anymal_robot.MAX_HALF_SPACES, poles=CBF_RATE,
             doc="A foot sphere's centre c inside the half-space n . c <= d: h = d - n . c (metres when |n| = 1), "
                 "relative degree 1 in the joint velocities (seed 004, eq. 25).")

    for name, value, doc in [
        ("legs", anymal_robot.LEGS, "The legs, in force-input order and member order of foot_region."),
        ("joint_names", anymal_robot.JOINT_NAMES, "The URDF's joints, in state and joint-velocity order."),
        ("standing_joints", anymal_robot.STANDING_JOINTS, "The SRDF's standing joint angles [rad]."),
        ("standing_com_height", STANDING_COM_HEIGHT, "The standing robot's centre-of-mass height [m]."),
        ("mass", MASS, "The robot's mass [kg] (URDF)."),
        ("com_offset", COM_OFFSET, "The standing robot's centre of mass in the trunk frame [m]."),
        ("inertia", INERTIA, "The standing robot's rotational inertia about its centre of mass, trunk frame "
                             "[kg m^2]."),
        ("gravity", GRAVITY, "Gravity's magnitude [m/s^2], along -z."),
        ("foot_radius", anymal_robot.FOOT_RADIUS, "Foot sphere radius [m] (URDF)."),
        ("q_min", anymal_robot.Q_MIN, "Joint angle lower limits [rad] (URDF)."),
        ("q_max", anymal_robot.Q_MAX, "Joint angle upper limits [rad] (URDF)."),
        ("qd_max", anymal_robot.QD_MAX, "Joint velocity limits [rad/s] (URDF)."),
    ]:
        s.constant(name, value, doc)
    return s

