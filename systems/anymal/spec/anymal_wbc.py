"""ANYmal C for a whole-body controller: the floating base in Pinocchio's free-flyer
coordinates, its rigid-body dynamics, the feet as contact points, and the foothold CBF
rows written in the generalized accelerations the controller solves for (seed 004,
Table I, priority 0, eq. 26).

**Description.** The same URDF and SRDF as ``anymal.py``, through ``anymal_robot.py``
(the robot, its legs, feet, limits and standing state are stated once, there).

**Model.** States: the trunk's position p (world [m]) and rotation R (world from trunk,
row-major ``r00 .. r22``; its columns are the trunk's axes), the 12 joint angles, the
trunk's twist in its own frame — linear velocity of its origin (v) and angular velocity
(w), as Pinocchio's free flyer orders them — and the 12 joint rates. Inputs: the 18
generalized accelerations nu' = (v', w', q''). So p' = R v, R' = R [w]x, q' = q'.
A rotation as nine states has no singularity (roll-pitch-yaw has one) and is what a
simulator's quaternion gives directly.

**Outputs.** ``dynamics``: M(q) and C(q, nu) nu + g(R, q) (the floating-base
equations of motion M nu' + b = S^T tau + sum_i J_i^T f_i); ``contacts``: for each foot
sphere's centre its world position, its 3 x 18 world-velocity Jacobian J and J' nu (its
acceleration when nu' = 0), as Pinocchio's LOCAL_WORLD_ALIGNED frame quantities.

**Family.** ``foot_region``: a foot's sphere centre inside half-spaces n . c <= d given at
run time (world), grown by m(t) so that a swing foot's set can shrink onto its landing region
at touchdown (seed 004's eq. 24 set; m = 0: the region itself), relative degree 2 in nu'.
The growth is given by its value and first two time derivatives at the time ``at`` of the
cycle (its second-order Taylor polynomial): the rows at ``at`` need no more, and the shape of
the shrink stays in one place, the runtime's (``cbfgen_anymal::gait::Trot::shrinking_growth``).
With its input columns ``a`` and drift, a row is ``a . nu' >= -drift``: affine in torques and
contact forces through the equations of motion.
"""

from __future__ import annotations

import symengine as se

from symbolic import urdf
from symbolic.dynamics import BASE_DOFS, RigidBodyDynamics, contact_point
from symbolic.spec import System

import anymal_robot

LINEAR = ["vx", "vy", "vz"]
ANGULAR = ["wx", "wy", "wz"]
ROTATION = [f"r{i}{j}" for i in range(3) for j in range(3)]
FOOT_POLES = [10.0, 10.0]


def build() -> System:
    s = System("anymal_wbc", doc="ANYmal C for a whole-body controller (systems/anymal/spec/anymal_wbc.py): "
                                 "free-flyer coordinates, rigid-body dynamics, foot contact points, feet inside "
                                 "convex foothold regions in generalized accelerations.")
    joints = [j.lower() for j in anymal_robot.JOINT_NAMES]
    names = ["x", "y", "z", *ROTATION, *joints, *LINEAR, *ANGULAR, *(f"{j}_rate" for j in joints)]
    docs = (["trunk x, world [m]", "trunk y, world [m]", "trunk z, world [m]"]
            + [f"trunk rotation R[{i}][{j}] (world from trunk)" for i in range(3) for j in range(3)]
            + [f"joint {j} angle [rad]" for j in anymal_robot.JOINT_NAMES]
            + [f"trunk origin velocity {a}, trunk frame [m/s]" for a in "xyz"]
            + [f"trunk angular velocity {a}, trunk frame [rad/s]" for a in "xyz"]
            + [f"joint {j} rate [rad/s]" for j in anymal_robot.JOINT_NAMES])
    x = s.states(names, docs=docs)
    p, flat, q = x[0:3], x[3:12], x[12:24]
    rotation = [flat[3 * i:3 * i + 3] for i in range(3)]
    twist, qd = x[24:30], x[30:42]
    v, w = twist[:3], twist[3:]
    velocity = [*twist, *qd]
    s.inputs([f"{n}_acc" for n in [*LINEAR, *ANGULAR, *joints]],
             limits=[(-a, a) for a in [anymal_robot.BASE_LINEAR_ACCELERATION] * 3
                     + [anymal_robot.BASE_ANGULAR_ACCELERATION] * 3
                     + [anymal_robot.JOINT_ACCELERATION] * anymal_robot.JOINTS],
             docs=[f"rate of the trunk's twist {d}, trunk frame" for d in [*LINEAR, *ANGULAR]]
             + [f"joint {j} acceleration [rad/s^2]" for j in anymal_robot.JOINT_NAMES])
    # p' = R v, R' = R [w]x: column k of R' is R (w x e_k).
    skew = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
    p_dot = [sum((rotation[i][k] * v[k] for k in range(3)), se.Integer(0)) for i in range(3)]
    r_dot = [sum((rotation[i][k] * skew[k][j] for k in range(3)), se.Integer(0)) for i in range(3) for j in range(3)]
    nv = len(velocity)
    positions = 3 + 9 + anymal_robot.JOINTS
    s.dynamics(f=p_dot + r_dot + list(qd) + [0] * nv,
               g=[[0] * nv for _ in range(positions)] + [[int(r == c) for c in range(nv)] for r in range(nv)])

    joint_q = dict(zip(anymal_robot.JOINT_NAMES, q, strict=True))

    def foot_center(leg: int, let=None) -> list[se.Expr]:
        fk = urdf.Kinematics(anymal_robot.ROBOT, joint_q, let, root_pose=(rotation, list(p)))
        return anymal_robot.foot_center(leg, fk)

    def foot_region(prm):
        c = foot_center(prm.index, prm.let)
        since = prm.t - prm.at
        growth = prm.growth[0] + prm.growth[1] * since + prm.growth[2] * since**2 / 2
        return [("inside", prm.offset + growth - sum((n * e for n, e in zip(prm.normal, c, strict=True)),
                                                      se.Integer(0)))]

    s.family("foot_region", foot_region,
             params={"normal": ((3,), "half-space normal n, world frame (outward; unit for h in metres)"),
                     "offset": ((), "half-space offset d [m]: the region is n . c <= d"),
                     "growth": ((3,), "the half-space's growth m and its first two time derivatives at `at` "
                                      "[m, m/s, m/s^2] (zeros: the half-space itself)"),
                     "at": ((), "when the growth is given [s]: the cycle's time")},
             over=[leg.lower() for leg in anymal_robot.LEGS], capacity=anymal_robot.MAX_HALF_SPACES, poles=FOOT_POLES,
             time=True,
             doc="A foot sphere's centre c inside the half-space n . c <= d + m(t): h = d + m(t) - n . c (metres "
                 "when |n| = 1), m from its value and first two derivatives at the cycle's time, m = 0 for the "
                 "landing region itself. One member per foot; a foothold region "
                 "is its half-spaces (seed 004, eqs. 24 and 26).")

    dynamics = RigidBodyDynamics(anymal_robot.ROBOT, joint_q, base_rotation=rotation)
    # The dynamics number the joints in tree order; the states, leg by leg.
    order = [dynamics.dofs.index(name) for name in [*BASE_DOFS, *anymal_robot.JOINT_NAMES]]
    velocity_in_tree_order = [velocity[order.index(k)] for k in range(nv)]
    s.rigid_body_output(
        "dynamics", dynamics, velocity_in_tree_order, order=order,
        doc="The floating-base equations of motion M nu' + bias = S^T tau + sum_i J_i^T f_i, from the URDF's "
            "inertials (gravity 9.81 m/s^2 along -z), as Pinocchio's crba and nonLinearEffects.",
        mass_doc="M(q) [kg, kg m, kg m^2], free-flyer coordinates (trunk twist in its own frame, linear first, then "
                 "the joints in state order)",
        bias_doc="C(q, nu) nu + g(R, q): the generalized forces at nu' = 0 [N, N m]")

    rates = dict(zip(anymal_robot.JOINT_NAMES, qd, strict=True))
    positions, jacobians, drifts = [], [], []
    for leg, foot in zip(anymal_robot.LEGS, anymal_robot.FEET, strict=True):
        r, jacobian, jdot_v = contact_point(anymal_robot.ROBOT, joint_q, rates, rotation, twist, f"{leg}_FOOT",
                                            foot.center)
        positions.append([p[i] + sum((rotation[i][k] * r[k] for k in range(3)), se.Integer(0)) for i in range(3)])
        jacobians.extend(jacobian)
        drifts.append(jdot_v)
    s.output("contacts", [
        ("positions", positions, "foot sphere centres, world [m], LF RF LH RH"),
        ("jacobians", jacobians, "their world-velocity Jacobians: rows 3i..3i+3 are foot i's x y z, columns nu"),
        ("drifts", drifts, "J' nu: each foot centre's world acceleration when nu' = 0 [m/s^2]"),
    ], doc="The feet as contact points (each foot sphere's centre): position, Jacobian and J' nu, world frame.")
    for name, value, doc in [
        ("legs", anymal_robot.LEGS, "The legs, in member order of foot_region and row order of contacts."),
        ("joint_names", anymal_robot.JOINT_NAMES, "The URDF's joints, in state and torque order."),
        ("standing_joints", anymal_robot.STANDING_JOINTS, "The SRDF's standing joint angles [rad]."),
        ("standing_height", anymal_robot.STANDING[2], "The SRDF's standing trunk height [m]."),
        ("foot_radius", anymal_robot.FOOT_RADIUS, "Foot sphere radius [m] (URDF)."),
        ("tau_max", anymal_robot.TAU_MAX, "Joint torque limits [N m] (URDF)."),
        ("q_min", anymal_robot.Q_MIN, "Joint angle lower limits [rad] (URDF)."),
        ("q_max", anymal_robot.Q_MAX, "Joint angle upper limits [rad] (URDF)."),
        ("total_mass", sum(i.mass for i in anymal_robot.ROBOT.inertials.values()), "The robot's mass [kg] (URDF)."),
    ]:
        s.constant(name, value, doc)
    return s
