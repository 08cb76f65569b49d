"""ANYbotics' ANYmal C as its robot description gives it: what every ANYmal spec of this
crate (the kinematic filter ``anymal.py``, the whole-body controller ``anymal_wbc.py``, the
kino-dynamic MPC ``anymal_mpc.py``) reads of the robot, kept apart from any one spec's
choices so that an edit to one spec (its poles, its SSAT sharpness) regenerates that spec
alone.

**Description.** example-robot-data's ``anymal_c_simple_description`` (``anymal.urdf``
and ``anymal.srdf``, the wheel pinned in symbolic/requirements-urdf.txt, read offline):
the kinematic tree, the joint position, velocity and torque limits, one box per link
fitted to its collision primitives (boxes as given; cylinders and the foot spheres
bounded, the containment checked at generation), the foot spheres; the self-collision
pairs are the SRDF's, every pair of links with geometry that it does not disable and that
is not adjacent, and must be clear at its ``standing`` state. **Assumed**: the
acceleration limits of the input box (ANYmal's description has none) and the most
half-spaces a foothold region has.
"""

from __future__ import annotations

import symengine as se

from symbolic import urdf

ROBOT = urdf.load(urdf.description("anymal_c_simple_description/urdf/anymal.urdf"))
SRDF = urdf.load_srdf(urdf.description("anymal_c_simple_description/srdf/anymal.srdf"), ROBOT)
LEGS = ["LF", "RF", "LH", "RH"]
JOINT_NAMES = [f"{leg}_{joint}" for leg in LEGS for joint in ("HAA", "HFE", "KFE")]
JOINTS = len(JOINT_NAMES)
BASE = ["x", "y", "z", "roll", "pitch", "yaw"]
COORDINATES = len(BASE) + JOINTS
Q_MIN, Q_MAX = (list(v) for v in zip(*ROBOT.limits(JOINT_NAMES, "position"), strict=True))
QD_MAX = [upper for _, upper in ROBOT.limits(JOINT_NAMES, "velocity")]
TAU_MAX = [upper for _, upper in ROBOT.limits(JOINT_NAMES, "effort")]
# The input box [m/s^2, rad/s^2]: assumed, generous for a 50 kg trunk and its drives, so
# that the barrier rows and not the box decide what is feasible.
BASE_LINEAR_ACCELERATION = 30.0
BASE_ANGULAR_ACCELERATION = 60.0
JOINT_ACCELERATION = 200.0

# The SRDF's standing state: joint angles, and the trunk's pose (its floating virtual
# joint: x y z qx qy qz qw; the identity quaternion there, so roll = pitch = yaw = 0).
STANDING_STATE = "standing"
STANDING_JOINTS = [SRDF.states[STANDING_STATE][j] for j in JOINT_NAMES]
(_ROOT_JOINT, _STANDING_POSE), = SRDF.virtual_states[STANDING_STATE].items()
if tuple(_STANDING_POSE[3:]) != (0.0, 0.0, 0.0, 1.0):
    raise ValueError(f"anymal.srdf's {STANDING_STATE!r} trunk is not level: {_STANDING_POSE}")
STANDING = [*_STANDING_POSE[:3], 0.0, 0.0, 0.0, *STANDING_JOINTS]

# The feet: each FOOT link's collision sphere (its centre is the point the foothold rows
# keep in their region).
FEET = [next(s for s in urdf.collision_shapes(ROBOT, f"{leg}_FOOT") if isinstance(s, urdf.Sphere)) for leg in LEGS]
FOOT_RADIUS = FEET[0].radius
if any(f.radius != FOOT_RADIUS for f in FEET):
    raise ValueError("anymal.urdf's four foot spheres differ in radius")

LINKS = [link for link in ROBOT.links if ROBOT.collision(link)]
BOXES = {link: urdf.link_box(ROBOT, link) for link in LINKS}
SELF_PAIRS = urdf.self_collision_pairs(ROBOT, SRDF, LINKS)
urdf.require_clear(ROBOT, SELF_PAIRS, BOXES, SRDF.states[STANDING_STATE], f"anymal.srdf's {STANDING_STATE!r} state")

# The most half-spaces of one foot's foothold region: the size of the foothold rows of
# every spec (the filter's foot_region, the controllers' foothold constraints).
MAX_HALF_SPACES = 8


def kinematics(base, joints, let=None, frame: str | None = None) -> urdf.Kinematics:
    """Link poses for the trunk pose ``base`` (x y z roll pitch yaw) and ``joints``, in the
    world; in link ``frame``'s frame instead if given (then ``base`` is not used)."""
    q = dict(zip(JOINT_NAMES, joints, strict=True))
    if frame is not None:
        return urdf.Kinematics(ROBOT, q, let, frame)
    return urdf.Kinematics(ROBOT, q, let, root_pose=(urdf.euler_zyx(*base[3:]), list(base[:3])))


def foot_center(leg: int, fk: urdf.Kinematics) -> list[se.Expr]:
    """Leg ``leg``'s foot sphere centre in ``fk``'s frame."""
    return FEET[leg].placed(fk.pose(f"{LEGS[leg]}_FOOT"))[0]
