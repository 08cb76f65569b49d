"""The Tachyon 3 model's dynamics and its six ECBF constraint families (paper section IV).

Every constraint kernel takes the state ``x`` and its runtime parameters, and returns,
per row, ``lie = [h, L_f h, ..., L_f^r h]`` and ``lg_lf = L_g L_f^(r-1) h`` on the input
columns listed in the kernel's ``*_INPUT_COLUMNS`` constant. The relative degree r is
found by :mod:`symbolic.lie`, never assumed. What is baked (the robot's structure,
smoothing, limits) comes from the model file; what is runtime (obstacles, floor heights,
foothold edges, stability bounds) is a kernel argument.
"""

from __future__ import annotations

import math

import symengine as se

from ..codegen.backends.rust.emitter import RawRust
from ..kernel import Kernel
from ..lie import LieEngine
from ..model import Leg, Tachyon3, load_tachyon3
from ..smoothing import LSE, XTANH
from .rows import RowBuilder, row_kernel, rust_str_array
from .ssat import AXES, ROT, certified_margin, matrix, relative_pose, separating_axes


def _row_kernel(system: Tachyon3, name: str, doc: str, build: RowBuilder) -> Kernel:
    return row_kernel(name, doc, system.state_names, system.x, system.f, system.g, build)


def _vec_input(k: Kernel, name: str, doc: str) -> list[se.Symbol]:
    return k.array_input(name, AXES, doc)


def _toe_world_lets(system: Tachyon3, engine: LieEngine, leg: Leg) -> list[se.Symbol]:
    return [engine.let_(f"toe_{c}", e) for c, e in zip(AXES, system.toe_world(leg), strict=False)]


# -------------------------------------------------------------------- families
def joint_limits(system: Tachyon3, leg: Leg) -> Kernel:
    m = system.model

    def build(k: Kernel, eng: LieEngine):
        dx, dz = system.leg_vector(leg)
        dx, dz = eng.let_("leg_dx", dx), eng.let_("leg_dz", dz)
        knee = eng.let_("knee", system.knee_length(dx, dz))
        hip = eng.let_("hip", system.hip_angle(leg, dx, dz))
        return [("knee_min", knee - m.knee_min), ("knee_max", m.knee_max - knee),
                ("hip_min", hip - leg.hip_min), ("hip_max", leg.hip_max - hip)]

    return _row_kernel(system, f"joint_limits_{leg.name.lower()}",
                       f"Joint limits of leg {leg.name} (eq. 4-6): knee length in "
                       f"[{m.knee_min}, {m.knee_max}] m, hip angle in "
                       f"[{math.degrees(leg.hip_min):g}, {math.degrees(leg.hip_max):g}] deg.", build)


def _edge_inputs(k: Kernel):
    center = _vec_input(k, "edge_center", "edge cuboid centre, world frame [m]")
    rot = k.array_input("edge_rotation", ROT, "edge cuboid rotation, row-major (columns = its axes)")
    half = _vec_input(k, "edge_half", "edge cuboid half extents [m]")
    return center, matrix(rot), half


def body_edge_ssat(system: Tachyon3) -> Kernel:
    m = system.model
    alpha, alpha_rot = se.RealDouble(m.ssat_alpha), se.RealDouble(m.ssat_alpha_rot)
    body_half = [se.RealDouble(v) for v in m.body_half_extents]

    def build(k: Kernel, eng: LieEngine):
        center, ra, half = _edge_inputs(k)
        pos = [eng.let_(f"body_{c}", e) for c, e in zip(AXES, system.body_position_world(), strict=False)]
        rb = system.body_rotation_world()
        rb = [[eng.let_(f"body_r{i}{j}", rb[i][j]) for j in range(3)] for i in range(3)]
        # Box A = the edge cuboid, box B = the body: the SSAT formulation in A's frame.
        t, rot = relative_pose(eng.let_, center, ra, pos, rb)
        axes = separating_axes(t, rot, half, body_half, XTANH, alpha, alpha_rot, eng.let_)
        # Axis values, and below the LSE's exponentials and sum, as lets: the engine then
        # carries per-axis rates (y', y'') and L_f^2 h costs O(15), not a dense Hessian
        # over the twelve pose intermediates or an n^2 expansion of the smooth max.
        ys = [eng.let_(f"y_{i}", y) for i, (y, _) in enumerate(axes)]
        shift = k.runtime_max("y_max", ys)
        # h - margin >= 0 certifies that the exact body and edge cuboid do not overlap.
        margin = certified_margin(k, LSE, axes, alpha)
        return [("body_edge", LSE(ys, alpha, shift, eng.let_) - margin)]

    return _row_kernel(system, "body_edge_ssat",
                       "Body vs edge cuboid by the smooth SAT (eq. 10), minus its certified margin:\n"
                       f"h >= 0 proves the boxes do not overlap. alpha = {m.ssat_alpha}, "
                       f"alpha_rot = {m.ssat_alpha_rot}.", build)


def toe_edge(system: Tachyon3, leg: Leg) -> Kernel:
    m = system.model
    power = 2 * m.superellipsoid_n

    def build(k: Kernel, eng: LieEngine):
        center, ra, half = _edge_inputs(k)
        toe = _toe_world_lets(system, eng, leg)
        rel = [eng.let_(f"rel_{AXES[i]}", se.Add(*[ra[q][i] * (toe[q] - center[q]) for q in range(3)]))
               for i in range(3)]
        # The sphere is folded into the cuboid: each half extent grows by the toe radius.
        h = se.Add(*[(rel[i] / (half[i] + m.toe_radius)) ** power for i in range(3)]) - 1
        return [("toe_edge", h)]

    return _row_kernel(system, f"toe_edge_{leg.name.lower()}",
                       f"Toe sphere of leg {leg.name} vs edge cuboid by superellipsoid (eq. 11), "
                       f"exponent {power}.", build)


def foothold(system: Tachyon3, leg: Leg) -> Kernel:
    def build(k: Kernel, eng: LieEngine):
        normal = k.array_input("normal", "xy", "inward normal a of the foothold edge (world xy)")
        offset = k.scalar_input("offset", "offset b of the edge: the row is a . p_xy + b >= 0 [m]")
        toe = _toe_world_lets(system, eng, leg)
        return [("foothold", normal[0] * toe[0] + normal[1] * toe[1] + offset)]

    return _row_kernel(system, f"foothold_{leg.name.lower()}",
                       f"Convex foothold half-space on the world xy of toe {leg.name} (eq. 12).", build)


def foot_height(system: Tachyon3, leg: Leg) -> Kernel:
    def build(k: Kernel, eng: LieEngine):
        floor = k.scalar_input("floor_z", "height of the floor plane under the toe, world frame [m]")
        toe = _toe_world_lets(system, eng, leg)
        return [("foot_height", toe[2] - system.model.toe_radius - floor)]

    return _row_kernel(system, f"foot_height_{leg.name.lower()}",
                       f"Toe {leg.name} above the floor plane: wheel bottom height minus floor height.", build)


def stability(system: Tachyon3, leg: Leg) -> Kernel:
    def build(k: Kernel, eng: LieEngine):
        a = k.scalar_input("a", "slope a_i of eq. 13 (+1 / -1 for lower / upper bounds)")
        b = k.scalar_input("b", "offset b_i of eq. 13 [m]")
        t = leg.name.lower()
        return [("stability", a * (system.s[f"{t}_x"] - system.s["bx"]) + b)]

    return _row_kernel(system, f"stability_{leg.name.lower()}",
                       f"Approximate static stability of toe {leg.name} vs the body (eq. 13): "
                       "a (x_toe - x_body) + b >= 0, origin frame.", build)


# -------------------------------------------------------------------- dynamics
def dynamics(system: Tachyon3) -> list[Kernel]:
    m = system.model
    f = Kernel("dynamics_f", "Drift f(x) of x' = f(x) + g(x) u (paper eq. 1-3).")
    f.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    f.output_vector("f", system.f, "f(x)")
    pattern = [(r, c) for r in range(len(system.x)) for c in range(len(system.input_names))
               if system.g[r][c] != 0]
    g = Kernel("dynamics_g", "Non-zeros of the input matrix g(x), in the order of `G_PATTERN`.")
    g.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    g.output_vector("g", [system.g[r][c] for r, c in pattern], "g(x) at `G_PATTERN`")
    consts = [
        ("NX", "usize", str(len(system.x)), "State dimension."),
        ("NU", "usize", str(len(system.input_names)), "Input dimension."),
        ("STATE_NAMES", f"[&str; {len(system.x)}]", rust_str_array(system.state_names), "State layout."),
        ("INPUT_NAMES", f"[&str; {len(system.input_names)}]", rust_str_array(system.input_names), "Input layout."),
        ("LEG_NAMES", "[&str; 6]", rust_str_array(leg.name for leg in m.legs), "Legs, in the order of the toe blocks."),
        ("G_PATTERN", f"[(usize, usize); {len(pattern)}]", str(pattern), "(row, column) of each non-zero of g."),
        ("BODY_HALF_EXTENTS", "[f64; 3]", str(list(m.body_half_extents)), "Body box half extents [m]."),
        ("NOMINAL_CLEARANCE", "f64", repr(m.nominal_clearance),
         "Body underside above ground in the standard posture [m]."),
        ("TOE_RADIUS", "f64", repr(m.toe_radius), "Toe sphere radius [m]."),
        ("KNEE_RANGE", "[f64; 2]", str([m.knee_min, m.knee_max]), "Knee length limits [m]."),
        ("HIP_POSITIONS", "[[f64; 3]; 6]", str([list(leg.hip) for leg in m.legs]), "Hip mounts, body frame [m]."),
        ("HIP_RANGES", "[[f64; 2]; 6]", str([[leg.hip_min, leg.hip_max] for leg in m.legs]),
         "Hip angle limits [rad], positive outward."),
        ("HIP_OUTWARD", "[f64; 6]", str([leg.outward for leg in m.legs]), "+1 where outward is forward, -1 backward."),
        ("SSAT_ALPHA", "[f64; 2]", str([m.ssat_alpha, m.ssat_alpha_rot]), "Body SSAT sharpness (alpha, alpha_rot)."),
        ("SUPERELLIPSOID_N", "u32", str(m.superellipsoid_n), "Toe-edge superellipsoid exponent is 2N."),
        ("ECBF_POLES", "[f64; 2]", str(list(m.ecbf_poles)), "Default ECBF poles [1/s]."),
        ("INPUT_LIMITS", f"[f64; {len(m.input_limits)}]", str(list(m.input_limits)),
         "Input magnitude limits, INPUT_NAMES order."),
    ]
    for name, ty, value, doc in consts:
        f.constant(name, ty, value, doc)
    return [f, g]


def _leg_table(family: str, per_leg: list[Kernel]) -> RawRust:
    """``FAMILY: [fn; 6]`` and ``FAMILY_INPUT_COLUMNS: [[usize; n]; 6]`` in leg order, so the
    runtime can treat the six legs' kernels of one family alike."""
    signatures = {tuple((i.name, len(i.symbols), i.is_array) for i in k.inputs) for k in per_leg}
    shapes = {tuple((o.dim, o.cols) for o in k.outputs) for k in per_leg}
    if len(signatures) != 1 or len(shapes) != 1:
        raise ValueError(f"{family}: the legs' kernels differ in signature; cannot tabulate them")
    k0 = per_leg[0]
    args = ", ".join(f"&[f64; {len(i.symbols)}]" if i.is_array else "f64" for i in k0.inputs)
    (lie_rows, lie_cols), (lg_rows, lg_cols) = [(o.dim, o.cols) for o in k0.outputs]
    ret = f"([[f64; {lie_cols}]; {lie_rows}], [[f64; {lg_cols}]; {lg_rows}])"
    upper = family.upper()
    names = ", ".join(k.name for k in per_leg)
    cols = ", ".join(f"{k.name.upper()}_INPUT_COLUMNS" for k in per_leg)
    return RawRust(
        f"/// The {family} kernels of the six legs, in `LEG_NAMES` order.\n"
        f"pub const {upper}: [fn({args}) -> {ret}; 6] = [{names}];\n"
        f"/// Input columns of each entry of [`{upper}`].\n"
        f"pub const {upper}_INPUT_COLUMNS: [[usize; {lg_cols}]; 6] = [{cols}];\n")


def world_kinematics(system: Tachyon3) -> Kernel:
    """Body pose and toe centres in the world frame: what a simulator or a collision
    check needs, from the same expressions the constraint rows differentiate."""
    k = Kernel("world_kinematics", "Body pose and toe sphere centres in the world frame.")
    k.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    k.output_vector("body_center", system.body_position_world(), "body box centre [m]")
    k.output_matrix("body_rotation", system.body_rotation_world(), "body rotation (columns = body axes)")
    k.output_matrix("toes", [system.toe_world(leg) for leg in system.model.legs],
                    "toe sphere centres [m], one row per leg in `LEG_NAMES` order")
    return k


def kernels(system: Tachyon3 | None = None) -> list[Kernel | RawRust]:
    system = system or load_tachyon3()
    out: list[Kernel | RawRust] = dynamics(system)
    out.append(world_kinematics(system))
    out.append(body_edge_ssat(system))
    for family in (joint_limits, toe_edge, foothold, foot_height, stability):
        per_leg = [family(system, leg) for leg in system.model.legs]
        out += per_leg
        out.append(_leg_table(family.__name__, per_leg))
    return out


MODULE_DOC = """The Tachyon 3 model (`symbolic/models/tachyon3.toml`): dynamics, layout constants and
the six ECBF constraint families of the paper's section IV, each differentiated to its
relative degree. See `symbolic/families/tachyon3.py`."""
