"""Tachyon 3 (the reference paper's hexapod on wheels) as a system spec.

The robot's numbers live in ``tachyon3.toml`` beside this file; ``tachyon3_model.py``
(also beside it) reads them and builds the kinematics (the ground-moving origin, the origin-relative body
and six toes in their legs' lateral planes, paper section II-B). This file declares what
the generator needs from them: the states and inputs, x' = f(x) + g(x) u, the six ECBF
constraint families of the paper's section IV, the world kinematics the simulation
checks clearance with, and the constants its scenario code uses.

Row order (the filter's QP rows): joint limits (4 per leg), foot height (1 per leg),
static stability (lower and upper per leg, each optional), body-edge SSAT (1 per edge
slot), toe-edge certified sphere-box clearance (one row per toe, per edge slot), foothold half-planes
(per leg, its capacity), then the foothold pull (one optional control-Lyapunov row per leg).
Per-leg families are indexed by the legs (``over``), so each leg keeps its own kernel with
its hip baked in.
"""

from __future__ import annotations

from pathlib import Path

import symengine as se

from symbolic.families import sphere_box, ssat
from symbolic.families.ssat import certified_margin, relative_pose, separating_axes
from symbolic.smoothing import LSE, XTANH
from symbolic.spec import DEFAULT_TOLERANCE, MAX_PRIORITY, Interval, Rotation, System, UnitVector

from tachyon3_model import MODEL_FILE, Leg, Tachyon3, load_model

AXES = "xyz"
# Largest capacities: 1025 edge cuboids make 7175 collision rows, far beyond what a 1 ms
# QP can take (the paper's worst case has 20); 256 half-planes per foothold polygon.
MAX_EDGES = 1025
MAX_FOOTHOLD_EDGES = 256
# The toe-edge rows join the QP below this h, a distance [m]. With the default poles
# (20, 20) a row's bound 40 h' + 400 h is still >= 0 at h = 0.3 m for a toe closing at
# up to 3 m/s, so a row asks for no deceleration yet when it joins.
TOE_EDGE_ACTIVATION = 0.3
# An edge cuboid's parameters take exactly what the hand-written path takes
# (Environment.push_edge through OrientedBox::new, src/geometry.rs): a centre within
# +-1e6 m (PARAM_LIMIT, the Real default), half extents in [MIN_HALF_EXTENT, MAX_HALF_EXTENT]
# (the domain the SSAT and sphere-box certificates are tested on) and a proper rotation
# within ROTATION_TOLERANCE, so a box set through the generic Params is refused where
# push_edge refuses it.
MIN_HALF_EXTENT, MAX_HALF_EXTENT = 1e-6, 1e4
EDGE_PARAMS = {
    "center": ((3,), "edge cuboid centre, world frame [m]"),
    "rotation": ((3, 3), "edge cuboid rotation (columns = its axes in the world frame)", Rotation(DEFAULT_TOLERANCE)),
    "half": ((3,), "edge cuboid half extents [m]", Interval(MIN_HALF_EXTENT, MAX_HALF_EXTENT)),
}

# Who yields when rows conflict. The filter meets every row exactly when the input limits
# allow it; where they do not, lower numbers are met first, as a lexicographic order (no
# ratio of weights, so a row's strength does not depend on the units its barrier is in):
#   0  joint limits and collisions (body-edge SSAT, toe-edge): the mechanism and the
#      environment; they yield only where no input within the actuator limits meets them.
#   1  foot height: the toe above the floor plane. A wheel pressed into a tread is a
#      collision too, but the floor under a toe is the gait's estimate, switched at
#      risers, so it yields before the collision rows.
#   2  static stability (eq. 13): an approximation with its own margin (a reach, not a
#      support polygon).
#   3  footholds: where the gait would like a swinging toe to stay.
#   15 the foothold pull (a CLF, below every barrier: convergence, never safety).
PRIORITIES = {
    "joint_limits": 0,
    "body_edge": 0,
    "toe_edge": 0,
    "foot_height": 1,
    "stability": 2,
    "foothold": 3,
    "foothold_pull": MAX_PRIORITY,
}

# The foothold pull (the paper's section IV-D: a swing toe outside its region is brought
# in by a CLF, one inside is kept there by the CBF). V = 1/2 (d . (p + lead p' - c))^2 on
# the toe's world xy p, towards the point c along the unit direction d: the toe's
# position has relative degree 2 in these accelerations, so V looks ahead by `lead`
# seconds to make V' depend on the input. V' + rate V <= 0 makes z = d . (p + lead p' - c)
# decay at least at rate / 2 (z' <= -rate z / 2), and the toe then follows z with time
# constant `lead`: poles (8, 8) 1/s, so
# a toe 9 cm out reaches a target 1 cm inside in about 0.5 s of the paper's 1.2 s swing,
# asking at most 64 * 0.09 = 5.8 m/s^2 of the 10 m/s^2 a toe has.
FOOTHOLD_PULL_RATE = 16.0
FOOTHOLD_PULL_LEAD = 0.125


def _toe_world(p, robot: Tachyon3, leg: Leg) -> list[se.Symbol]:
    return [p.let(f"toe_{c}", e) for c, e in zip(AXES, robot.toe_world(leg), strict=True)]


def build(model: Path | None = None) -> System:
    """The system from ``model`` (default: ``tachyon3.toml`` beside this file)."""
    model = MODEL_FILE if model is None else Path(model)
    robot = Tachyon3(load_model(model))
    m = robot.model
    legs = {leg.name.lower(): leg for leg in m.legs}
    members = list(legs)

    s = System("tachyon3", doc="The Tachyon 3 model (systems/tachyon3/spec/tachyon3.toml): a hexapod on wheels "
                               "climbing stairs, with the six ECBF families of the paper's section IV and its "
                               "foothold CLF.")
    s.depends_on(model)  # the robot's numbers: editing them regenerates the module
    s.states(robot.state_names)
    s.inputs(robot.input_names, limits=[(-lim, lim) for lim in m.input_limits])
    s.dynamics(f=robot.f, g=robot.g)
    poles = list(m.ecbf_poles)

    # ------------------------------------------------------------- families
    def joint_limits(p):
        leg = legs[p.label]
        dx, dz = robot.leg_vector(leg)
        dx, dz = p.let("leg_dx", dx), p.let("leg_dz", dz)
        knee = p.let("knee", robot.knee_length(dx, dz))
        hip = p.let("hip", robot.hip_angle(leg, dx, dz))
        return [("knee_min", knee - m.knee_min), ("knee_max", m.knee_max - knee),
                ("hip_min", hip - leg.hip_min), ("hip_max", leg.hip_max - hip)]

    s.family("joint_limits", joint_limits, priority=PRIORITIES["joint_limits"], over=members, poles=poles,
             doc=f"Joint limits (eq. 4-6): knee length in [{m.knee_min}, {m.knee_max}] m, hip angle "
                 "within the leg's range (model file).")

    def foot_height(p):
        toe = _toe_world(p, robot, legs[p.label])
        return [("foot_height", toe[2] - m.toe_radius - p.floor_z)]

    s.family("foot_height", foot_height, priority=PRIORITIES["foot_height"], over=members, poles=poles,
             params={"floor_z": ((), "height of the floor plane under the toe, world frame [m]")},
             # The world's ground plane until the terrain says otherwise (Environment::set_floors).
             defaults={"floor_z": 0.0},
             doc="Toe above the floor plane: wheel bottom height minus floor height.")

    def stability(p):
        t = p.label
        return [("stability", p.a * (robot.s[f"{t}_x"] - robot.s["bx"]) + p.b)]

    s.family("stability", stability, priority=PRIORITIES["stability"], over=members, count=2, optional=True,
             poles=poles,
             params={"a": ((), "slope a_i of eq. 13 (+1 / -1 for lower / upper bounds)"),
                     "b": ((), "offset b_i of eq. 13 [m]")},
             doc="Approximate static stability of the toe vs the body (eq. 13): a (x_toe - x_body) + b >= 0, "
                 "origin frame; instance 0 is the lower bound, 1 the upper.")

    alpha, alpha_rot = se.RealDouble(m.ssat_alpha), se.RealDouble(m.ssat_alpha_rot)
    body_half = [se.RealDouble(v) for v in m.body_half_extents]

    def body_and_edge(p):
        pos = [p.let(f"body_{c}", e) for c, e in zip(AXES, robot.body_position_world(), strict=True)]
        rb = robot.body_rotation_world()
        rb = [[p.let(f"body_r{i}{j}", rb[i][j]) for j in range(3)] for i in range(3)]
        # Box A = the edge cuboid, box B = the body: the SSAT formulation in A's frame.
        t, rot = relative_pose(p.let, p.center, p.rotation, pos, rb)
        return t, rot, separating_axes(t, rot, p.half, body_half, XTANH, alpha, alpha_rot, p.let)

    def body_edge(p):
        t, rot, axes = body_and_edge(p)
        # Axis values, and below the LSE's exponentials and sum, as lets: the engine then
        # carries per-axis rates (y', y'') and L_f^2 h costs O(15), not a dense Hessian
        # over the twelve pose intermediates or an n^2 expansion of the smooth max.
        ys = [p.let(f"y_{i}", y) for i, (y, _) in enumerate(axes)]
        shift = p.runtime_max("y_max", ys)
        # h - margin >= 0 certifies that the exact body and edge cuboid do not overlap.
        return [("body_edge", LSE(ys, alpha, shift, p.let) - certified_margin(p, LSE, axes, alpha))]

    def body_edge_bound(p):
        # The exact SAT's face axes less the smoothing's slack: no transcendental call.
        t, rot, axes = body_and_edge(p)
        return ssat.lower_bound(p.let, p.runtime_max, t, rot, p.half, body_half, XTANH, LSE, alpha, alpha_rot,
                                certified_margin(p, LSE, axes, alpha))

    s.family("body_edge", body_edge, priority=PRIORITIES["body_edge"], capacity=MAX_EDGES, params=EDGE_PARAMS,
             poles=poles, activation=0.5, lower_bound=body_edge_bound,
             doc="Body vs edge cuboid by the smooth SAT (eq. 10), minus its certified margin: h >= 0 proves the "
                 f"boxes do not overlap. alpha = {m.ssat_alpha}, alpha_rot = {m.ssat_alpha_rot}. Active while "
                 "h < 0.5 m.")

    toe_alpha = se.RealDouble(m.toe_alpha)

    def toe_edge(p):
        # h = smooth distance from the toe centre to the cuboid - toe radius - certified
        # margin (symbolic/families/sphere_box.py): h >= 0 proves the toe sphere is clear.
        return [(name, sphere_box.clearance(p.let, _toe_world(p, robot, leg), p.center, p.rotation, p.half,
                                           se.RealDouble(m.toe_radius), toe_alpha))
                for name, leg in legs.items()]

    def toe_edge_bound(p):
        # The nearest toe's distance to the cuboid along its own axes, less the smoothing.
        toes = [sphere_box.lower_bound(p.let, p.runtime_max, _toe_world(p, robot, leg), p.center, p.rotation,
                                       p.half, se.RealDouble(m.toe_radius), toe_alpha, name=f"rel_{name}")
                for name, leg in legs.items()]
        return -p.runtime_max("farthest_below", [-b for b in toes])

    toe_margin = float(sphere_box.margin(toe_alpha))
    s.family("toe_edge", toe_edge, capacity=MAX_EDGES, params=EDGE_PARAMS, poles=poles,
             activation=TOE_EDGE_ACTIVATION, priority=PRIORITIES["toe_edge"], lower_bound=toe_edge_bound,
             doc="Every toe sphere vs an edge cuboid: a smooth distance from the toe centre to the cuboid "
                 f"minus the toe radius and a certified margin of {toe_margin * 1e3:.2f} mm (alpha = "
                 f"{m.toe_alpha}), so h >= 0 proves the sphere does not reach into the cuboid; one row per "
                 f"leg. Replaces the paper's superellipsoid (eq. 11), which is not conservative at the "
                 f"cuboid's corners. Active while h < {TOE_EDGE_ACTIVATION} m.")

    def foothold(p):
        toe = _toe_world(p, robot, legs[p.label])
        return [("foothold", p.normal[0] * toe[0] + p.normal[1] * toe[1] + p.offset)]

    s.family("foothold", foothold, priority=PRIORITIES["foothold"], over=members, capacity=MAX_FOOTHOLD_EDGES,
             poles=poles,
             params={"normal": ((2,), "inward unit normal a of the foothold edge (world xy); HalfPlane::new "
                                       "normalises one", UnitVector(DEFAULT_TOLERANCE)),
                     "offset": ((), "offset b of the edge: the row is a . p_xy + b >= 0 [m]")},
             doc="Convex foothold half-space on the toe's world xy (eq. 12); switch a leg's set off while it "
                 "stands.")

    def foothold_pull(p):
        toe = robot.toe_world(legs[p.label])[:2]
        # The toe's world velocity: its position does not depend on the input directly.
        velocity = [sum((se.diff(c, xi) * fi for xi, fi in zip(robot.x, robot.f, strict=True)), se.Integer(0))
                    for c in toe]
        ahead = [p.let(f"ahead_{a}", toe[k] + FOOTHOLD_PULL_LEAD * velocity[k] - p.target[k])
                 for k, a in enumerate("xy")]
        along = p.let("along", p.direction[0] * ahead[0] + p.direction[1] * ahead[1])
        return along * along / 2

    s.lyapunov("foothold_pull", foothold_pull, rate=FOOTHOLD_PULL_RATE, priority=PRIORITIES["foothold_pull"],
               over=members, optional=True,
               params={"target": ((2,), "world xy point the toe is pulled to, inside its foothold [m]"),
                       "direction": ((2,), "unit world xy direction from the toe to the target, along which "
                                           "the pull acts", UnitVector(DEFAULT_TOLERANCE))},
               doc="Control-Lyapunov pull of a swing toe outside its foothold (section IV-D): V = 1/2 (d . (p + "
                   f"{FOOTHOLD_PULL_LEAD} p' - c))^2 [m^2] on the toe's world xy p, decreasing at "
                   f"{FOOTHOLD_PULL_RATE} 1/s. Switched on (with the leg's foothold rows off) while the toe is "
                   "outside; relaxed as convergence given up, never as a safety verdict.")

    # ------------------------------------------------------ outputs, constants
    s.output("world_kinematics", [
        ("body_center", robot.body_position_world(), "body box centre [m]"),
        ("body_rotation", robot.body_rotation_world(), "body rotation (columns = body axes)"),
        ("toes", [robot.toe_world(leg) for leg in m.legs], "toe sphere centres [m], one row per leg"),
    ], doc="Body pose and toe sphere centres in the world frame.")
    for name, value, doc in [
        ("leg_names", [leg.name for leg in m.legs], "Legs, in the order of the toe blocks."),
        ("body_half_extents", list(m.body_half_extents), "Body box half extents [m]."),
        ("nominal_clearance", m.nominal_clearance, "Body underside above ground in the standard posture [m]."),
        ("toe_radius", m.toe_radius, "Toe sphere radius [m]."),
        ("knee_range", [m.knee_min, m.knee_max], "Knee length limits [m]."),
        ("hip_positions", [list(leg.hip) for leg in m.legs], "Hip mounts, body frame [m]."),
        ("hip_ranges", [[leg.hip_min, leg.hip_max] for leg in m.legs], "Hip angle limits [rad], positive outward."),
        ("hip_outward", [leg.outward for leg in m.legs], "+1 where outward is forward, -1 backward."),
        ("ssat_alpha", [m.ssat_alpha, m.ssat_alpha_rot], "Body SSAT sharpness (alpha, alpha_rot)."),
        ("toe_alpha", m.toe_alpha, "Toe-edge smoothing sharpness [1/m]."),
        ("ecbf_poles", list(m.ecbf_poles), "Default ECBF poles [1/s]."),
        ("foothold_pull_rate", FOOTHOLD_PULL_RATE, "The foothold pull's decay rate: V' + rate V <= 0 [1/s]."),
        ("foothold_pull_lead", FOOTHOLD_PULL_LEAD, "How far ahead the foothold pull's V looks along the toe's "
                                                   "velocity [s]."),
        ("input_limits", list(m.input_limits), "Input magnitude limits, INPUT_NAMES order."),
    ]:
        s.constant(name, value, doc)
    return s
