"""ANYbotics' ANYmal C on a floating base, built from its own robot description: joint
limits, feet kept inside convex foothold regions, and its legs kept off each other by
smooth SAT. The robot of seed 004's stepping-stone experiment.

**Description.** The robot's facts (kinematic tree, limits, link boxes, feet, the SRDF's
self-collision pairs and standing state) come from its URDF and SRDF through
``anymal_robot.py``, which this crate's three specs share.

**Model.** A floating base: states are the trunk's position p (world [m]) and orientation
as roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll), singular at pitch = +-pi/2, which a
walking trunk never nears), the 12 joint angles leg by leg (LF, RF, LH, RH; each HAA, HFE,
KFE) [rad], then the rates of all 18. Inputs are the 18 generalized accelerations, so
x' = [v, 0] + [0; I] u: the acceleration interface a whole-body controller works in (its
torques come through the floating-base dynamics, issue 37).

**Families** (rows in this order):

* ``joint_limits``: q_i - q_min,i >= 0 and q_max,i - q_i >= 0 (relative degree 2);
* ``velocity_limits``: qd_max,i - |q'_i| as two rows each (relative degree 1);
* ``foot_region``: a foot's sphere centre c inside half-spaces n . c <= d given at run
  time (world frame; with |n| = 1, h = d - n . c is in metres): a convex foothold region
  (seed 004's foot-placement constraint), or the ground (n = (0, 0, -1), d = -(g + r)
  keeps the sphere above z = g). One member per foot, up to ``MAX_HALF_SPACES`` each;
* ``self_collision``: SSAT between the boxes of each checked pair minus its certified
  margin (degree 2), in the trunk's frame, where the floating base drops out.

**Assumed** here: the SSAT sharpness, the poles and priorities (and, in
``anymal_robot.py``, the acceleration limits of the input box).
"""

from __future__ import annotations

import symengine as se

from symbolic import primitives as prim
from symbolic import urdf
from symbolic.spec import System

from anymal_robot import (
    BASE,
    BASE_ANGULAR_ACCELERATION,
    BASE_LINEAR_ACCELERATION,
    BOXES,
    COORDINATES,
    FOOT_RADIUS,
    JOINT_ACCELERATION,
    JOINT_NAMES,
    JOINTS,
    LEGS,
    LINKS,
    MAX_HALF_SPACES,
    Q_MAX,
    Q_MIN,
    QD_MAX,
    ROBOT,
    SELF_PAIRS,
    STANDING,
    TAU_MAX,
    foot_center,
    kinematics,
)

# SSAT sharpness, as the Panda's (systems/panda/spec/panda.py says why so soft).
SSAT_ALPHA = 100.0
SSAT_ALPHA_ROT = 20.0
POSITION_POLES = [5.0, 5.0]
VELOCITY_POLES = [20.0]
FOOT_POLES = [10.0, 10.0]
COLLISION_POLES = [4.0, 4.0]
SELF_ACTIVATION = 0.2
# Joint limits, footholds and collisions hold; the actuators' rate limits yield to them.
PRIORITIES = {"joint_limits": 0, "foot_region": 0, "self_collision": 0, "velocity_limits": 1}


def build() -> System:
    s = System("anymal", doc="ANYmal C on a floating base from its URDF (systems/anymal/spec/anymal.py): joint "
                             "limits, feet inside convex foothold regions, legs off each other by smooth SAT.")
    joint_names = [j.lower() for j in JOINT_NAMES]
    names = BASE + joint_names
    docs = (["trunk x, world [m]", "trunk y, world [m]", "trunk z, world [m]", "trunk roll [rad]",
             "trunk pitch [rad]", "trunk yaw [rad]"] + [f"joint {j} angle [rad]" for j in JOINT_NAMES])
    x = s.states(names + [f"{n}_rate" for n in names],
                 docs=docs + [f"rate of: {d}".replace(" [m]", " [m/s]").replace(" [rad]", " [rad/s]") for d in docs])
    position, rate = x[:COORDINATES], x[COORDINATES:]
    base, q, qd = position[:len(BASE)], position[len(BASE):], rate[len(BASE):]
    s.inputs([f"{n}_acc" for n in names],
             limits=[(-v, v) for v in [BASE_LINEAR_ACCELERATION] * 3 + [BASE_ANGULAR_ACCELERATION] * 3
                     + [JOINT_ACCELERATION] * JOINTS],
             docs=[f"second derivative of: {d}".replace(" [m]", " [m/s^2]").replace(" [rad]", " [rad/s^2]")
                   for d in docs])
    s.dynamics(f=list(rate) + [0] * COORDINATES,
               g=[[0] * COORDINATES for _ in range(COORDINATES)]
               + [[int(r == c) for c in range(COORDINATES)] for r in range(COORDINATES)])

    s.family("joint_limits", lambda p: prim.interval_rows(joint_names, q, Q_MIN, Q_MAX),
             poles=POSITION_POLES, priority=PRIORITIES["joint_limits"],
             doc="Joint angles inside the URDF's limits [rad].")

    s.family("velocity_limits",
             lambda p: prim.interval_rows([f"{j}_rate" for j in joint_names], qd, [-v for v in QD_MAX], QD_MAX),
             poles=VELOCITY_POLES, priority=PRIORITIES["velocity_limits"],
             doc="Joint rates inside the URDF's limits [rad/s].")

    def foot_region(p):
        c = foot_center(p.index, kinematics(base, q, p.let))
        return [("inside", p.offset - sum((n * v for n, v in zip(p.normal, c, strict=True)), se.Integer(0)))]

    s.family("foot_region", foot_region,
             params={"normal": ((3,), "half-space normal n, world frame (outward; unit for h in metres)"),
                     "offset": ((), "half-space offset d [m]: the region is n . c <= d")},
             over=[leg.lower() for leg in LEGS], capacity=MAX_HALF_SPACES, poles=FOOT_POLES,
             priority=PRIORITIES["foot_region"],
             doc="A foot sphere's centre c inside the half-space n . c <= d: h = d - n . c (metres when |n| = 1). "
                 "One member per foot; a foothold region is its half-spaces.")

    alpha, alpha_rot = se.RealDouble(SSAT_ALPHA), se.RealDouble(SSAT_ALPHA_ROT)

    def pair_boxes(p):
        a, b = SELF_PAIRS[p.index]
        # In the frame of the link both hang from (the trunk, for two legs): the floating
        # base moves both boxes alike and drops out, exactly.
        fk = kinematics(base, q, p.let, frame=urdf.common_ancestor(ROBOT, a, b))
        return BOXES[a].placed(fk.pose(a)), BOXES[b].placed(fk.pose(b))

    def names(p):
        # Each box's pose kernel is named after its link (all are placed in the trunk's frame).
        return tuple(link.lower() for link in SELF_PAIRS[p.index])

    def self_collision(p):
        return [("self_collision", prim.ssat(p, *pair_boxes(p), alpha, alpha_rot, names=names(p)))]

    s.family("self_collision", self_collision,
             over=[f"{a}_{b}".lower() for a, b in SELF_PAIRS], poles=COLLISION_POLES,
             priority=PRIORITIES["self_collision"], activation=SELF_ACTIVATION, compose=True,
             lower_bound=lambda p: prim.ssat_lower_bound(p, *pair_boxes(p), alpha, alpha_rot, names=names(p)),
             doc="Two link boxes the SRDF lets meet, by smooth SAT minus its certified margin [m]: h >= 0 proves they "
                 f"do not overlap. Active while h < {SELF_ACTIVATION} m.")

    fk = kinematics(base, q)
    feet = [foot_center(leg, fk) for leg in range(len(LEGS))]
    s.output("feet", [
        ("positions", feet, "foot sphere centres, world [m], LF RF LH RH"),
        ("velocities", [[sum((se.diff(e, v) * d for v, d in zip(position, rate, strict=True)), se.Integer(0))
                         for e in foot] for foot in feet], "their velocities, world [m/s]"),
    ], doc="The feet: each foot sphere's centre and its velocity, in the world.")
    boxes = [BOXES[link].placed(fk.pose(link)) for link in LINKS]
    s.output("link_boxes", [
        ("centers", [list(b.center) for b in boxes], "link box centres, world [m], one row per link box"),
        ("rotations", [[b.rotation[r][c] for r in range(3) for c in range(3)] for b in boxes],
         "link box rotations, row-major (columns = the box's axes), one row per link box"),
    ], doc="Every link box's world pose, in LINK_NAMES order.")
    for name, value, doc in [
        ("legs", LEGS, "The legs, in member order of foot_region and row order of feet."),
        ("joint_names", JOINT_NAMES, "The URDF's joints, in state order (after the trunk's six coordinates)."),
        ("standing", STANDING, "The SRDF's standing state: trunk x y z roll pitch yaw, then the joints."),
        ("foot_radius", FOOT_RADIUS, "Foot sphere radius [m] (URDF)."),
        ("link_names", LINKS, "Link boxes, in row order of link_boxes."),
        ("link_half_extents", [list(BOXES[link].half) for link in LINKS], "Link box half extents [m]."),
        ("self_pairs", [[LINKS.index(a), LINKS.index(b)] for a, b in SELF_PAIRS],
         "Checked self-collision pairs, as link box indices (the self_collision members' order)."),
        ("q_min", Q_MIN, "Joint angle lower limits [rad] (URDF)."),
        ("q_max", Q_MAX, "Joint angle upper limits [rad] (URDF)."),
        ("qd_max", QD_MAX, "Joint rate limits [rad/s] (URDF)."),
        ("tau_max", TAU_MAX, "Joint torque limits [N m] (URDF)."),
        ("ssat_alpha", [SSAT_ALPHA, SSAT_ALPHA_ROT], "SSAT sharpness of the collision rows (alpha [1/m], alpha_rot)."),
    ]:
        s.constant(name, value, doc)
    return s
