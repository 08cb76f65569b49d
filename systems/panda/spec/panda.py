"""Franka Emika's Panda, 7 DoF, kept inside its joint limits, off its obstacles and off
itself by smooth SAT, built from Franka's own robot description.

The Tachyon 3 paper closes by noting that the SSAT CBF applies to other links and to
self-collision as well as to a body against the environment; this spec is that claim made
concrete on a real arm, with nothing but the spec language and its URDF front end.

**Description.** example-robot-data's ``panda.urdf`` and ``panda.srdf`` (the wheel pinned
in symbolic/requirements-urdf.txt, read offline): the kinematic tree, the joint position
and velocity limits, one box per link fitted to Franka's collision meshes (and around the
fingers' URDF boxes), each checked at generation to contain every vertex exactly; the
self-collision pairs are the SRDF's: every pair of links with geometry that the SRDF does
not disable and that is not adjacent.

**Model.** States q (7 joint angles [rad]) and q' (7 rates [rad/s]); inputs q'' (7 joint
accelerations [rad/s^2]), so x' = [q', 0] + [0; I] u: the joint-acceleration interface a
torque-controlled arm's inner loop (computed torque) offers. The fingers are held open
(``FINGER_OPENING``).

**Families** (rows in this order):

* ``joint_limits``: q_i - q_min,i >= 0 and q_max,i - q_i >= 0 (relative degree 2);
* ``velocity_limits``: qd_max,i - |q'_i| as two rows each (relative degree 1);
* ``obstacle``: a link box against an obstacle box given at run time, by SSAT minus its
  certified margin (degree 2); one member per moving link, each with up to a capacity of
  obstacles;
* ``self_collision``: SSAT between the boxes of each checked pair (degree 2), one member
  per pair.

From the URDF: kinematics, position and velocity limits, collision geometry; from the
SRDF: the checked pairs. From Franka's datasheet: the acceleration limits (a URDF has
none). **Assumed**: the finger opening, the SSAT sharpness, the poles and priorities.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import symengine as se

from symbolic import primitives as prim
from symbolic import urdf
from symbolic.dynamics import RigidBodyDynamics
from symbolic.spec import System

# Franka's facts the URDF does not hold, shared with the panda_spheres spec.
FRANKA_FILE = Path(__file__).with_name("franka.toml")
FRANKA = tomllib.loads(FRANKA_FILE.read_text())
ROBOT = urdf.load(urdf.description(FRANKA["urdf"]))
SRDF = urdf.load_srdf(urdf.description(FRANKA["srdf"]), ROBOT)
JOINT_NAMES = FRANKA["joints"]
JOINTS = len(JOINT_NAMES)
FINGER_OPENING = FRANKA["finger_opening"]
FINGERS = dict.fromkeys(FRANKA["finger_joints"], FINGER_OPENING)
Q_MIN, Q_MAX = (list(v) for v in zip(*ROBOT.limits(JOINT_NAMES, "position"), strict=True))
QD_MAX = [upper for _, upper in ROBOT.limits(JOINT_NAMES, "velocity")]
TAU_MAX = [upper for _, upper in ROBOT.limits(JOINT_NAMES, "effort")]
QDD_MAX = FRANKA["joint_acceleration_max"]

# Every link with collision geometry, its box, and the frame it is fixed in: frames are
# 0 the base (link0), 1-7 after each joint, 8 the flange (link8), 9 the hand, 10-11 the
# fingers; frame_origins gives 1-11.
FRAME_LINKS = ["panda_link0", *[f"panda_link{i}" for i in range(1, 9)], "panda_hand", "panda_leftfinger",
               "panda_rightfinger"]
LINKS = [link for link in ROBOT.links if ROBOT.collision(link)]
BOXES = {link: urdf.link_box(ROBOT, link) for link in LINKS}
# Obstacles are checked against every link that moves (link0 is the base, bolted down).
OBSTACLE_LINKS = [link for link in LINKS if link != ROBOT.root]
SELF_PAIRS = urdf.self_collision_pairs(ROBOT, SRDF, LINKS)
# Every checked pair must be clear at the SRDF's default state (else generation stops and
# names it).
urdf.require_clear(ROBOT, SELF_PAIRS, BOXES, {**SRDF.states["default"], **FINGERS}, "panda.srdf's default state")


def short(link: str) -> str:
    return link.removeprefix("panda_")


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


def kinematics(q, let=None, base: str | None = None) -> urdf.Kinematics:
    """The arm's link poses for joint angles ``q`` (fingers held open), in the frame of
    link ``base`` (the base by default)."""
    return urdf.Kinematics(ROBOT, {**dict(zip(JOINT_NAMES, q, strict=True)), **FINGERS}, let, base)


def box(link: str, fk: urdf.Kinematics) -> prim.Box:
    """Link ``link``'s box in ``fk``'s frame."""
    return BOXES[link].placed(fk.pose(link))


def build() -> System:
    s = System("panda", doc="Franka Emika's Panda from its URDF (systems/panda/spec/panda.py): joint position "
                            "and velocity limits, link boxes fitted to its meshes against obstacle boxes and "
                            "against each other by smooth SAT.")
    s.depends_on(FRANKA_FILE)  # Franka's facts: editing them regenerates the module
    joints = range(1, JOINTS + 1)
    x = s.states([f"q{i}" for i in joints] + [f"qd{i}" for i in joints],
                 docs=[f"joint {i} angle [rad]" for i in joints] + [f"joint {i} rate [rad/s]" for i in joints])
    q, qd = x[:JOINTS], x[JOINTS:]
    s.inputs([f"qdd{i}" for i in range(1, JOINTS + 1)], limits=[(-v, v) for v in QDD_MAX],
             docs=[f"joint {i} acceleration [rad/s^2]" for i in range(1, 8)])
    s.dynamics(f=list(qd) + [0] * JOINTS,
               g=[[0] * JOINTS for _ in range(JOINTS)]
               + [[int(r == c) for c in range(JOINTS)] for r in range(JOINTS)])

    s.family("joint_limits", lambda p: prim.interval_rows([f"q{i}" for i in joints], q, Q_MIN, Q_MAX),
             poles=POSITION_POLES, priority=PRIORITIES["joint_limits"],
             doc="Joint angles inside the URDF's limits [rad].")

    s.family("velocity_limits",
             lambda p: prim.interval_rows([f"qd{i}" for i in joints], qd, [-v for v in QD_MAX], QD_MAX),
             poles=VELOCITY_POLES, priority=PRIORITIES["velocity_limits"],
             doc="Joint rates inside the URDF's limits [rad/s].")

    alpha, alpha_rot = se.RealDouble(SSAT_ALPHA), se.RealDouble(SSAT_ALPHA_ROT)

    def obstacle(p):
        obstacle_box = prim.Box(p.center, p.rotation, p.half)
        link = f"panda_{p.label}"
        return [("obstacle", prim.ssat(p, obstacle_box, box(link, kinematics(q, p.let)), alpha, alpha_rot,
                                       names=(None, p.label)))]

    def obstacle_far(p):
        # The exact SAT's face axes less the smoothing: an obstacle beyond the activation
        # distance from a link is not evaluated.
        obstacle_box = prim.Box(p.center, p.rotation, p.half)
        link = f"panda_{p.label}"
        return prim.ssat_lower_bound(p, obstacle_box, box(link, kinematics(q, p.let)), alpha, alpha_rot,
                                     names=(None, p.label))

    # One member per link box, each with its own obstacle list: a kernel per link stays a
    # few thousand temporaries (all eight links in one kernel made 17 000, past what rustc's
    # debug-info pass recurses through), and a user may check a link against only the
    # obstacles it can reach.
    s.family("obstacle", obstacle, params=OBSTACLE_PARAMS, over=[short(link) for link in OBSTACLE_LINKS],
             capacity=MAX_OBSTACLES,
             poles=COLLISION_POLES, priority=PRIORITIES["obstacle"], activation=OBSTACLE_ACTIVATION,
             lower_bound=obstacle_far, compose=True,
             doc="A link box against an obstacle box by smooth SAT minus its certified margin [m]: h >= 0 proves "
                 f"no overlap. One member per link box, each with its obstacles. alpha = {SSAT_ALPHA}, alpha_rot = "
                 f"{SSAT_ALPHA_ROT}; active while "
                 f"h < {OBSTACLE_ACTIVATION} m.")

    def self_boxes(p):
        # Both boxes in the base frame, where the obstacle rows place them: each link's
        # pose kernel serves every row on it. (In the frame of the link both hang from,
        # the joints above would drop out exactly, but every pair would need its own
        # relative poses: 14 more pose kernels and their value-only twins, a third of the
        # module.)
        a, b = SELF_PAIRS[p.index]
        fk = kinematics(q, p.let)
        return box(a, fk), box(b, fk)

    def self_names(p):
        return tuple(short(link) for link in SELF_PAIRS[p.index])

    def self_collision(p):
        return [("self_collision", prim.ssat(p, *self_boxes(p), alpha, alpha_rot, names=self_names(p)))]

    def self_collision_far(p):
        # As obstacle_far: a pair farther apart than the activation distance is not evaluated.
        return prim.ssat_lower_bound(p, *self_boxes(p), alpha, alpha_rot, names=self_names(p))

    s.family("self_collision", self_collision, over=[f"{short(a)}_{short(b)}" for a, b in SELF_PAIRS],
             poles=COLLISION_POLES,
             priority=PRIORITIES["self_collision"], activation=SELF_ACTIVATION, lower_bound=self_collision_far,
             compose=True,
             doc="Two link boxes the SRDF lets meet, by smooth SAT minus its certified margin [m]: h >= 0 proves they "
                 f"do not overlap. Active while h < {SELF_ACTIVATION} m.")

    fk = kinematics(q)
    boxes = [box(link, fk) for link in LINKS]
    s.output("link_boxes", [
        ("centers", [list(b.center) for b in boxes], "link box centres, base frame [m], one row per link box"),
        ("rotations", [[b.rotation[r][c] for r in range(3) for c in range(3)] for b in boxes],
         "link box rotations, row-major (columns = the box's axes), one row per link box"),
    ], doc="Every link box's world pose, in LINK_NAMES order.")
    s.output("frame_origins", [("origins", [list(fk.pose(link)[1]) for link in FRAME_LINKS[1:]],
                                "origins of frames 1-11 [m]")],
             doc="Origins of frames 1-7 (after each joint), the flange (8), the hand (9) and the fingers (10, 11), "
                 "base frame.")
    hand_rotation, hand_position = fk.pose("panda_hand")
    linear, angular = fk.jacobian("panda_hand", q)
    s.output("hand", [
        ("position", list(hand_position), "hand frame origin, base frame [m]"),
        ("rotation", [e for row in hand_rotation for e in row], "hand frame rotation, row-major (columns = its axes)"),
        ("jacobian", linear + angular, "geometric Jacobian [linear; angular] of the hand frame origin, base frame: "
                                       "its velocity and angular velocity are jacobian @ q'"),
    ], doc="The hand frame (panda_hand, the flange side of the gripper): its pose and its 6 x 7 Jacobian, as "
           "Pinocchio's LOCAL_WORLD_ALIGNED frame Jacobian; what an operational-space controller starts from.")
    dynamics = RigidBodyDynamics(ROBOT, {**dict(zip(JOINT_NAMES, q, strict=True)), **FINGERS})
    s.rigid_body_output("dynamics", dynamics, qd,
                        doc="The arm's rigid-body dynamics from the URDF's inertials (gravity 9.81 m/s^2 along -z): "
                            "tau = M(q) q'' + bias(q, q').",
                        mass_doc="joint-space mass matrix M(q) [kg m^2], fingers held still",
                        bias_doc="C(q, q') q' + g(q) [N m]: the torques that hold the arm at q'' = 0")
    for name, value, doc in [
        ("link_names", [short(link) for link in LINKS], "Link boxes, in row order of every per-link output."),
        ("obstacle_links", [LINKS.index(link) for link in OBSTACLE_LINKS],
         "The link boxes the obstacle family's members check, in member order (indices into LINK_NAMES)."),
        ("link_frames", [FRAME_LINKS.index(link) for link in LINKS], "The frame each link box is fixed in."),
        ("link_centers", [list(BOXES[link].center) for link in LINKS], "Link box centres in their frames [m]."),
        ("link_rotations", [[v for row in BOXES[link].rotation for v in row] for link in LINKS],
         "Link box rotations in their frames, row-major (columns = the box's axes)."),
        ("link_half_extents", [list(BOXES[link].half) for link in LINKS], "Link box half extents [m]."),
        ("self_pairs", [[LINKS.index(a), LINKS.index(b)] for a, b in SELF_PAIRS],
         "Checked self-collision pairs, as link box indices (the self_collision members' order)."),
        ("finger_opening", FINGER_OPENING, "How far each finger is held open [m]."),
        ("q_min", Q_MIN, "Joint angle lower limits [rad] (URDF)."),
        ("q_max", Q_MAX, "Joint angle upper limits [rad] (URDF)."),
        ("qd_max", QD_MAX, "Joint rate limits [rad/s] (URDF)."),
        ("qdd_max", QDD_MAX, "Joint acceleration limits [rad/s^2] (Franka's datasheet)."),
        ("tau_max", TAU_MAX, "Joint torque limits [N m] (URDF), for the rows mapped to torques "
                             "(cbfgen::torque::JointTorque with `dynamics`)."),
        ("ssat_alpha", [SSAT_ALPHA, SSAT_ALPHA_ROT], "SSAT sharpness of the collision rows (alpha [1/m], alpha_rot)."),
    ]:
        s.constant(name, value, doc)
    return s
