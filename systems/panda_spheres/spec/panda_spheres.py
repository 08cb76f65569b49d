"""Franka Emika's Panda as OSCBF models it, torque-controlled: 21 spheres on its links,
kept off sphere obstacles and above a table. The setting of OSCBF (operational-space
CBFs, IROS 2025), for a side-by-side measurement (docs/arm.md).

**Description.** Kinematics and dynamics from example-robot-data's ``panda.urdf`` (the
pinned wheel), fingers held open as in the ``panda`` system. The collision model is
OSCBF's: 21 spheres fixed in the link frames of joints 1-7 (centres and radii below,
their numbers), of which the 20 a joint moves are checked: the first sphere of link1 sits
on joint 1's axis, so no input changes its rows and they are no barrier (the spec
language refuses a row that depends on no state).

**Model.** States q (7 joint angles [rad]) and q' (7 rates [rad/s]); inputs q'' (7
joint accelerations [rad/s^2]). The filter takes joint torques through
``cbfgen::torque::JointTorque`` with this module's ``dynamics`` (M(q) and the bias from the
URDF's inertials), so every row has relative degree 2 through M(q)^-1.

**Families** (rows in this order):

* ``sphere_obstacle``: an arm sphere against an obstacle sphere given at run time,
  h = |p - c| - r - r_obstacle [m]; one member per arm sphere, each with up to
  ``MAX_OBSTACLES`` obstacles;
* ``table``: an arm sphere above a table plane z = height, h = p_z - r - height [m]; one
  member per arm sphere, at most one table.

Both have poles (10, 10): OSCBF's alpha(h) = 10 h at both orders. **Assumed**: the
activation distance (culling) and the finger opening. No joint-limit rows: OSCBF's count
(546 at 25 obstacles: 21 x 25 + 21) has none; here 20 x 25 + 18 = 518.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import symengine as se

from symbolic import urdf
from symbolic.dynamics import RigidBodyDynamics
from symbolic.spec import Positive, System

# Franka's facts the URDF does not hold: the arm system's file, shared.
FRANKA_FILE = Path(__file__).resolve().parents[2] / "panda" / "spec" / "franka.toml"
FRANKA = tomllib.loads(FRANKA_FILE.read_text())
ROBOT = urdf.load(urdf.description(FRANKA["urdf"]))
JOINT_NAMES = FRANKA["joints"]
JOINTS = len(JOINT_NAMES)
FINGER_OPENING = FRANKA["finger_opening"]
FINGERS = dict.fromkeys(FRANKA["finger_joints"], FINGER_OPENING)
Q_MIN, Q_MAX = (list(v) for v in zip(*ROBOT.limits(JOINT_NAMES, "position"), strict=True))
QD_MAX = [upper for _, upper in ROBOT.limits(JOINT_NAMES, "velocity")]
TAU_MAX = [upper for _, upper in ROBOT.limits(JOINT_NAMES, "effort")]
# The acceleration form's input box (the torque filter's is TAU_MAX).
QDD_MAX = FRANKA["joint_acceleration_max"]

# OSCBF's collision spheres: (link, centre in the link frame [m], radius [m]).
SPHERES = [
    ("panda_link1", (0.0, 0.0, -0.15), 0.06), ("panda_link1", (0.0, -0.065, 0.0), 0.06),
    ("panda_link2", (0.0, 0.0, 0.065), 0.06), ("panda_link2", (0.0, -0.14, 0.0), 0.06),
    ("panda_link3", (0.0, 0.0, -0.065), 0.06), ("panda_link3", (0.08, 0.065, 0.0), 0.055),
    ("panda_link4", (0.0, 0.0, 0.065), 0.055), ("panda_link4", (-0.08, 0.08, 0.0), 0.055),
    ("panda_link5", (0.0, 0.0, -0.23), 0.06), ("panda_link5", (0.0, 0.06, -0.18), 0.04),
    ("panda_link5", (0.0, 0.08, -0.125), 0.025), ("panda_link5", (0.0, 0.09, -0.075), 0.025),
    ("panda_link5", (0.0, 0.08, 0.0), 0.055),
    ("panda_link6", (0.0, 0.0, 0.01), 0.05), ("panda_link6", (0.08, 0.035, 0.0), 0.05),
    ("panda_link7", (0.0, 0.0, 0.08), 0.05), ("panda_link7", (0.04, 0.04, 0.09), 0.04),
    ("panda_link7", (0.055, 0.055, 0.15), 0.03), ("panda_link7", (-0.055, -0.055, 0.15), 0.03),
    ("panda_link7", (-0.055, -0.055, 0.11), 0.03), ("panda_link7", (0.0, 0.0, 0.20), 0.02),
]

POLES = [10.0, 10.0]
# Rows join the QP (and are evaluated) below this h [m]; +inf in the settings evaluates all.
ACTIVATION = 0.3
MAX_OBSTACLES = 64
# A family's lower bound is its own h, computed by a separate kernel whose rounding may
# differ from the row's by a few ulp: a nanometre below keeps it a bound.
ROUNDING = 1e-9


def sphere_center(k: int, fk: urdf.Kinematics) -> list[se.Expr]:
    """Arm sphere ``k``'s centre in the base frame."""
    link, center, _ = SPHERES[k]
    return urdf.Sphere(link, center, SPHERES[k][2]).placed(fk.pose(link))[0]


def kinematics(q, let=None) -> urdf.Kinematics:
    return urdf.Kinematics(ROBOT, {**dict(zip(JOINT_NAMES, q, strict=True)), **FINGERS}, let)


def _moving(coordinates: range) -> list[int]:
    """The spheres whose centre's ``coordinates`` some joint moves."""
    centers = [sphere_center(k, kinematics(se.symbols("q1:8"))) for k in range(len(SPHERES))]
    return [k for k, c in enumerate(centers) if any(c[i].free_symbols for i in coordinates)]


# A row no input can change is no barrier (the spec language refuses one): link1's first
# sphere sits on joint 1's axis, and no joint changes the height of link1's spheres or of
# link2's first (on joint 2's axis). OSCBF counts all 21 for both; 20 obstacle and 18 table
# members remain here.
MOVING = _moving(range(3))
RISING = _moving(range(2, 3))
SPHERE_NAMES = [f"{SPHERES[k][0].removeprefix('panda_')}_{k}" for k in MOVING]
TABLE_NAMES = [f"{SPHERES[k][0].removeprefix('panda_')}_{k}" for k in RISING]


def build() -> System:
    s = System("panda_spheres", doc="Franka Emika's Panda as OSCBF models it (systems/panda_spheres/spec/"
                                    "panda_spheres.py): 21 spheres on its links against sphere obstacles and a "
                                    "table, for joint-torque control through the URDF's dynamics.")
    s.depends_on(FRANKA_FILE)  # Franka's facts: editing them regenerates the module
    x = s.states([f"q{i}" for i in range(1, JOINTS + 1)] + [f"qd{i}" for i in range(1, JOINTS + 1)],
                 docs=[f"joint {i} angle [rad]" for i in range(1, JOINTS + 1)]
                 + [f"joint {i} rate [rad/s]" for i in range(1, JOINTS + 1)])
    q, qd = x[:JOINTS], x[JOINTS:]
    s.inputs([f"qdd{i}" for i in range(1, JOINTS + 1)], limits=[(-v, v) for v in QDD_MAX],
             docs=[f"joint {i} acceleration [rad/s^2]" for i in range(1, JOINTS + 1)])
    s.dynamics(f=list(qd) + [0] * JOINTS,
               g=[[0] * JOINTS for _ in range(JOINTS)]
               + [[int(r == c) for c in range(JOINTS)] for r in range(JOINTS)])

    def sphere_obstacle(p):
        k = MOVING[p.index]
        d = [a - b for a, b in zip(sphere_center(k, kinematics(q, p.let)), p.center, strict=True)]
        distance = p.let("distance", se.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2))
        return [("clearance", distance - SPHERES[k][2] - p.radius)]

    s.family("sphere_obstacle", sphere_obstacle,
             params={"center": ((3,), "obstacle centre, base frame [m]"),
                     "radius": ((), "obstacle radius [m]", Positive())},
             over=SPHERE_NAMES, capacity=MAX_OBSTACLES, poles=POLES, activation=ACTIVATION,
             lower_bound=lambda p: sphere_obstacle(p)[0][1] - ROUNDING,
             doc="An arm sphere against an obstacle sphere: centre distance less both radii [m]. Its own "
                 "value (less a nanometre for rounding) is its lower bound: culled beyond the activation "
                 "distance.")

    def table(p):
        k = RISING[p.index]
        return [("height", sphere_center(k, kinematics(q, p.let))[2] - SPHERES[k][2] - p.height)]

    s.family("table", table, params={"height": ((), "table top height, base frame [m]")}, over=TABLE_NAMES,
             capacity=1, poles=POLES, activation=ACTIVATION, lower_bound=lambda p: table(p)[0][1] - ROUNDING,
             doc="An arm sphere above the table plane: its lowest point's height over the table [m].")

    fk = kinematics(q)
    s.output("sphere_centers", [("centers", [sphere_center(k, fk) for k in MOVING],
                                 "arm sphere centres, base frame [m], SPHERE_NAMES order")],
             doc="Every arm sphere's centre.")
    dynamics = RigidBodyDynamics(ROBOT, {**dict(zip(JOINT_NAMES, q, strict=True)), **FINGERS})
    s.rigid_body_output("dynamics", dynamics, qd,
                        doc="The arm's rigid-body dynamics from the URDF's inertials: tau = M(q) q'' + bias(q, q').",
                        mass_doc="joint-space mass matrix M(q) [kg m^2], fingers held still",
                        bias_doc="C(q, q') q' + g(q) [N m]")
    for name, value, doc in [
        ("sphere_names", SPHERE_NAMES, "Arm spheres, in member order of sphere_obstacle and of sphere_centers."),
        ("table_spheres", [MOVING.index(k) for k in RISING],
         "The table family's members, as indices into SPHERE_NAMES."),
        ("sphere_radii", [SPHERES[k][2] for k in MOVING], "Arm sphere radii [m] (OSCBF's), SPHERE_NAMES order."),
        ("q_min", Q_MIN, "Joint angle lower limits [rad] (URDF)."),
        ("q_max", Q_MAX, "Joint angle upper limits [rad] (URDF)."),
        ("qd_max", QD_MAX, "Joint rate limits [rad/s] (URDF)."),
        ("tau_max", TAU_MAX, "Joint torque limits [N m] (URDF)."),
    ]:
        s.constant(name, value, doc)
    return s
