"""A Franka-Panda-like 7-DoF arm, kept inside its joint limits, off its obstacles and off
itself by smooth SAT: the second robot on the generic toolchain.

The Tachyon 3 paper closes by noting that the SSAT CBF applies to other links and to
self-collision as well as to a body against the environment; this spec is that claim
made concrete, with nothing but the spec language and the primitives every user has.

**Model.** States q (7 joint angles [rad]) and q' (7 rates [rad/s]); inputs q'' (7
joint accelerations [rad/s^2]), so x' = [q', 0] + [0; I] u. A joint-space
acceleration interface is what a torque-controlled arm's inner loop (computed torque)
offers, and it makes every barrier's relative degree the order of q it depends on.

**Kinematics.** Franka's published Craig (modified) Denavit-Hartenberg table, the
flange 0.107 m past joint 7, and the hand mounted 45 degrees about the flange axis:
frame i = frame i-1 * Rx(alpha_i) * Tx(a_i) * Rz(q_i) * Tz(d_i).

**Families** (rows in this order):

* ``joint_limits``: q_i - q_min,i >= 0 and q_max,i - q_i >= 0 (relative degree 2);
* ``velocity_limits``: qd_max,i - |q'_i| as two rows each (relative degree 1);
* ``obstacle``: a link box against an obstacle box given at run time, by SSAT minus its
  certified margin (degree 2); one member per link box, each with up to a capacity of
  obstacles;
* ``self_collision``: SSAT between the non-adjacent link boxes that can meet (degree 2),
  one member per pair.

Published values (Franka Emika's datasheet and control-interface documentation): the DH
table, joint position, velocity and acceleration limits. **Assumed** values: the link
boxes (sized here to enclose the links as capsules of about 6-7 cm radius around the
segments between joint axes, not taken from Franka's meshes), the SSAT sharpness, the
poles and slack weights, and the self-collision pairs (those that never overlap by
construction of the boxes: checked by sampling the joint box, see docs/arm.md).
"""

from __future__ import annotations

import symengine as se

from symbolic import primitives as prim
from symbolic.spec import System

JOINTS = 7
# (a_i-1 [m], d_i [m], alpha_i-1 [in quarter turns]) per joint, then the flange (Craig's
# convention, as Franka publishes it). Quarter turns keep Rx exact: cos(pi/2) is 0.
DH = [
    (0.0, 0.333, 0),
    (0.0, 0.0, -1),
    (0.0, 0.316, 1),
    (0.0825, 0.0, 1),
    (-0.0825, 0.384, -1),
    (0.0, 0.0, 1),
    (0.088, 0.0, 1),
]
FLANGE_OFFSET = 0.107
HAND_YAW = se.Rational(-1, 4) * se.pi  # the hand sits -45 degrees about the flange axis
# Published limits: position [rad], velocity [rad/s], acceleration [rad/s^2].
Q_MIN = [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973]
Q_MAX = [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973]
QD_MAX = [2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100]
QDD_MAX = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]

# Frames: 0 base, 1-7 after each joint, 8 flange, 9 hand.
HAND_FRAME = 9
# Link boxes (assumed): frame, centre in that frame [m], half extents along its axes [m].
LINK_BOXES = {
    "link1": (1, (0.0, 0.0, -0.07), (0.07, 0.07, 0.13)),  # shoulder column
    "link2": (2, (0.0, -0.12, 0.0), (0.07, 0.19, 0.07)),  # upper arm
    "link3": (3, (0.04, 0.0, -0.03), (0.11, 0.07, 0.10)),  # elbow, upper side
    "link4": (4, (-0.04, 0.03, 0.0), (0.11, 0.10, 0.07)),  # elbow, lower side
    "link5": (5, (0.0, 0.0, -0.11), (0.07, 0.07, 0.16)),  # forearm
    "link6": (6, (0.04, 0.0, 0.0), (0.10, 0.06, 0.08)),  # wrist
    "link7": (7, (0.0, 0.0, 0.04), (0.05, 0.05, 0.08)),  # flange
    "hand": (HAND_FRAME, (0.0, 0.0, 0.07), (0.03, 0.11, 0.07)),  # hand and fingers
}
# Checked self-collision pairs: the shoulder and upper arm against the forearm, wrist,
# flange and hand, and the elbow against the hand. Other non-adjacent pairs overlap by
# construction somewhere inside the joint limits (boxes meeting at a joint).
SELF_PAIRS = [(a, b) for a in ("link1", "link2") for b in ("link5", "link6", "link7", "hand")] + [("link3", "hand")]

# SSAT sharpness: alpha [1/m] on distances, alpha_rot [-] on the relative rotation's
# entries. The filter's L_f^2 h carries their curvature times the squared rates (alpha_rot
# also times the boxes' extents, up to the table's 0.8 m), so an arm moving at a few
# tenths of a rad/s needs them far softer than Tachyon 3's 200: at 400 the ECBF asked for
# more deceleration than the joints have. The certified margin grows as they drop (about
# 3 cm for a link against the table here), which is the price.
SSAT_ALPHA = 100.0
SSAT_ALPHA_ROT = 20.0
# Poles [1/s]: slow enough that a joint at its velocity limit stops within its
# acceleration limit (a critically damped approach asks up to about pole * speed).
POSITION_POLES = [3.0, 3.0]
VELOCITY_POLES = [20.0]
COLLISION_POLES = [4.0, 4.0]
# Obstacle rows join the QP below this h [m].
OBSTACLE_ACTIVATION = 0.3
SELF_ACTIVATION = 0.3
MAX_OBSTACLES = 64
# Who yields when rows conflict (lower numbers are met first): joint limits and collisions
# hold; velocity limits are the actuators' and yield to them.
PRIORITIES = {"joint_limits": 0, "obstacle": 0, "self_collision": 0, "velocity_limits": 1}

# No domains declared: prim.Box (in obstacle's h) gives the rotation its proper-rotation
# domain and the half extents theirs (> 0), as it gives any user's spec.
OBSTACLE_PARAMS = {
    "center": ((3,), "obstacle box centre, world (base) frame [m]"),
    "rotation": ((3, 3), "obstacle box rotation (columns = its axes in the world frame)"),
    "half": ((3,), "obstacle box half extents [m]"),
}


def _rot_x_quarter(turns: int) -> list[list[se.Expr]]:
    return prim.rot_x(turns * se.pi / 2)


def frames(q, let=None, base: int = 0) -> list[tuple[list[list[se.Expr]], list[se.Expr]] | None]:
    """(rotation, origin) of frames 0-9 for joint angles ``q``, expressed in frame ``base``
    (the base frame by default; entries below ``base`` are None). With ``let`` (a family
    context's), every frame's entries are named intermediates, so a kernel differentiates
    each frame once."""

    def name(i, tag, value):
        return value if let is None else let(f"frame{i}_{tag}", value)

    rot, origin = prim.identity(), [se.Integer(0)] * 3
    out: list = [None] * base + [(rot, origin)]
    for i, (a, d, quarter) in enumerate(DH, start=1):
        if i <= base:
            continue
        tilt = prim.matmul(rot, _rot_x_quarter(quarter))
        offset = prim.matvec(tilt, [a, 0, 0])
        new_rot = prim.matmul(tilt, prim.rot_z(q[i - 1]))
        new_rot = [[name(i, f"r{r}{c}", new_rot[r][c]) for c in range(3)] for r in range(3)]
        z_axis = [new_rot[r][2] for r in range(3)]
        origin = [name(i, f"p{r}", origin[r] + offset[r] + d * z_axis[r]) for r in range(3)]
        rot = new_rot
        out.append((rot, origin))
    flange = [name(8, f"p{r}", origin[r] + FLANGE_OFFSET * rot[r][2]) for r in range(3)]
    out.append((rot, flange))
    out.append((prim.matmul(rot, prim.rot_z(HAND_YAW)), flange))
    return out


def link_box(name: str, poses) -> prim.Box:
    """The world box of link ``name`` given every frame's pose."""
    frame, center, half = LINK_BOXES[name]
    rot, origin = poses[frame]
    world = prim.matvec(rot, list(center))
    return prim.Box([origin[r] + world[r] for r in range(3)], rot, [se.RealDouble(v) for v in half])


def build() -> System:
    s = System("panda", doc="A Franka-Panda-like 7-DoF arm (systems/panda/spec/panda.py): joint position and "
                            "velocity limits, link boxes against obstacle boxes and against each other by "
                            "smooth SAT.")
    joints = range(1, JOINTS + 1)
    x = s.states([f"q{i}" for i in joints] + [f"qd{i}" for i in joints],
                 docs=[f"joint {i} angle [rad]" for i in joints] + [f"joint {i} rate [rad/s]" for i in joints])
    q, qd = x[:JOINTS], x[JOINTS:]
    s.inputs([f"qdd{i}" for i in range(1, JOINTS + 1)], limits=[(-v, v) for v in QDD_MAX],
             docs=[f"joint {i} acceleration [rad/s^2]" for i in range(1, 8)])
    s.dynamics(f=list(qd) + [0] * JOINTS,
               g=[[0] * JOINTS for _ in range(JOINTS)]
               + [[int(r == c) for c in range(JOINTS)] for r in range(JOINTS)])

    def joint_limits(p):
        rows = []
        for i in range(JOINTS):
            rows += [(f"q{i + 1}_min", q[i] - Q_MIN[i]), (f"q{i + 1}_max", Q_MAX[i] - q[i])]
        return rows

    s.family("joint_limits", joint_limits, poles=POSITION_POLES, priority=PRIORITIES["joint_limits"],
             doc="Joint angles inside Franka's published limits [rad].")

    def velocity_limits(p):
        rows = []
        for i in range(JOINTS):
            rows += [(f"qd{i + 1}_min", qd[i] + QD_MAX[i]), (f"qd{i + 1}_max", QD_MAX[i] - qd[i])]
        return rows

    s.family("velocity_limits", velocity_limits, poles=VELOCITY_POLES, priority=PRIORITIES["velocity_limits"],
             doc="Joint rates inside Franka's published limits [rad/s].")

    alpha, alpha_rot = se.RealDouble(SSAT_ALPHA), se.RealDouble(SSAT_ALPHA_ROT)

    def obstacle(p):
        box = prim.Box(p.center, p.rotation, p.half)
        return [("obstacle", prim.ssat(p, box, link_box(p.label, frames(q, p.let)), alpha, alpha_rot))]

    def obstacle_far(p):
        # The exact SAT's face axes less the smoothing: an obstacle beyond the activation
        # distance from a link is not evaluated.
        box = prim.Box(p.center, p.rotation, p.half)
        return prim.ssat_lower_bound(p, box, link_box(p.label, frames(q, p.let)), alpha, alpha_rot)

    # One member per link box, each with its own obstacle list: a kernel per link stays a
    # few thousand temporaries (all eight links in one kernel made 17 000, past what rustc's
    # debug-info pass recurses through), and a user may check a link against only the
    # obstacles it can reach.
    s.family("obstacle", obstacle, params=OBSTACLE_PARAMS, over=list(LINK_BOXES), capacity=MAX_OBSTACLES,
             poles=COLLISION_POLES, priority=PRIORITIES["obstacle"], activation=OBSTACLE_ACTIVATION,
             lower_bound=obstacle_far,
             doc="A link box against an obstacle box by smooth SAT minus its certified margin [m]: h >= 0 proves "
                 f"no overlap. One member per link box, each with its obstacles. alpha = {SSAT_ALPHA}, alpha_rot = "
                 f"{SSAT_ALPHA_ROT}; active while "
                 f"h < {OBSTACLE_ACTIVATION} m.")

    def self_collision(p):
        a, b = SELF_PAIRS[p.index]
        # In the frame of the lower link's box: the joints before it move both boxes alike
        # and drop out, exactly (the input columns then list only the joints between).
        poses = frames(q, p.let, base=LINK_BOXES[a][0])
        return [("self_collision", prim.ssat(p, link_box(a, poses), link_box(b, poses), alpha, alpha_rot))]

    s.family("self_collision", self_collision, over=[f"{a}_{b}" for a, b in SELF_PAIRS], poles=COLLISION_POLES,
             priority=PRIORITIES["self_collision"], activation=SELF_ACTIVATION,
             doc="Two non-adjacent link boxes by smooth SAT minus its certified margin [m]: h >= 0 proves they "
                 f"do not overlap. Active while h < {SELF_ACTIVATION} m.")

    poses = frames(q)
    boxes = [link_box(name, poses) for name in LINK_BOXES]
    s.output("link_boxes", [
        ("centers", [list(b.center) for b in boxes], "link box centres, base frame [m], one row per link box"),
        ("rotations", [[b.rotation[r][c] for r in range(3) for c in range(3)] for b in boxes],
         "link box rotations, row-major (columns = the box's axes), one row per link box"),
    ], doc="Every link box's world pose, in LINK_NAMES order.")
    s.output("frame_origins", [("origins", [list(o) for _, o in poses[1:]], "origins of frames 1-9 [m]")],
             doc="Origins of frames 1-7 (after each joint), the flange (8) and the hand (9), base frame.")
    for name, value, doc in [
        ("link_names", list(LINK_BOXES), "Link boxes, in row order of every per-link output and family."),
        ("link_frames", [f for f, _, _ in LINK_BOXES.values()], "The frame each link box is fixed in."),
        ("link_centers", [list(c) for _, c, _ in LINK_BOXES.values()], "Link box centres in their frames [m]."),
        ("link_half_extents", [list(h) for _, _, h in LINK_BOXES.values()], "Link box half extents [m]."),
        ("self_pairs", [[list(LINK_BOXES).index(a), list(LINK_BOXES).index(b)] for a, b in SELF_PAIRS],
         "Checked self-collision pairs, as link box indices (the self_collision members' order)."),
        ("dh", [[a, d, quarter * 0.5] for a, d, quarter in DH],
         "Craig DH rows (a_i-1 [m], d_i [m], alpha_i-1 [units of pi]) of joints 1-7."),
        ("flange_offset", FLANGE_OFFSET, "Flange distance past joint 7 along its axis [m]."),
        ("hand_yaw", float(HAND_YAW), "Hand rotation about the flange axis [rad]."),
        ("q_min", Q_MIN, "Joint angle lower limits [rad]."),
        ("q_max", Q_MAX, "Joint angle upper limits [rad]."),
        ("qd_max", QD_MAX, "Joint rate limits [rad/s]."),
        ("qdd_max", QDD_MAX, "Joint acceleration limits [rad/s^2]."),
        ("ssat_alpha", [SSAT_ALPHA, SSAT_ALPHA_ROT], "SSAT sharpness of the collision rows (alpha [1/m], alpha_rot)."),
    ]:
        s.constant(name, value, doc)
    return s
