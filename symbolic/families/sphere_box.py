"""Certified smooth clearance between a sphere and an oriented box.

The barrier (one formula, used by Tachyon 3's toe-edge rows and by the kernel library
``generated/sphere_box.rs``), with eps = 1/alpha:

    rel  = R^T (p - c)                      the sphere's centre in the box's frame
    q_i  = s(rel_i) - a_i                   s(x) = sqrt(x^2 + eps^2) - eps  (SQRT_UNDER)
    g_i  = (q_i + sqrt(q_i^2 + 4 eps^2))/2  a smooth max(q_i, 0)            (SQRT_RAMP)
    d    = sqrt(g_x^2 + g_y^2 + g_z^2 + delta^2),   delta = SQRT_FLOOR * eps
    h    = d - r - m,                       m = sqrt(3) eps + delta

Why ``h >= 0`` proves the sphere and the box are apart. Let o_i = max(|rel_i| - a_i, 0),
so D = |o| is the exact distance from the centre to the (solid) box, 0 inside it.

* s never exceeds |x| and the ramp is increasing, so g_i <= ramp(|rel_i| - a_i).
* ramp(q) - max(q, 0) = (sqrt(q^2 + 4 eps^2) - |q|)/2 lies in (0, eps], so
  0 < g_i <= o_i + eps.
* The Euclidean norm grows with each non-negative entry and obeys the triangle
  inequality: |g| <= |o + eps (1, 1, 1)| <= D + sqrt(3) eps, and the floor adds at most
  delta: d <= D + m.
* Hence h >= 0 gives D >= d - m >= r: the centre is at least r from the box, so the
  sphere does not reach into it (exact sphere-box distance D - r >= 0).

The margin is tight up to delta and s's slack: at a corner (o = 0, every q_i = 0 when
s is exact there) d = sqrt(3) eps. In the other direction g_i >= max(q_i, 0) and
q_i >= |rel_i| - a_i - eps, so d >= D - sqrt(3) eps: outside the box, D - r - h lies in
[0, m + sqrt(3) eps] (``conservatism``). Along a face s undershoots |x| by about eps,
so a sphere held at h = 0 there keeps about m + eps of exact clearance. Inside the box
h only knows d in [delta, m]: the barrier is flat there, and it is meant to keep the
centre outside (the sphere's own radius is the room to recover in).

Why algebraic pieces rather than x tanh(alpha x) and a softplus ln(1 + e^(alpha q))/alpha:
the proof is the same (the softplus overshoots by ln(2)/alpha), but three tanh, six exp
and three ln per sphere made Tachyon 3's six-toe kernel seven times the cost of the
superellipsoid it replaces; square roots are a fraction of that. They also need no
overflow guard (the softplus needed a runtime shift): nothing overflows while the
squares of the coordinates stay finite, |rel| up to about 1e150 m. The floor delta keeps
d > 0 where every ramp rounds to 0 (a centre very deep inside a large box), where the
derivative of sqrt would otherwise divide 0 by 0.
"""

from __future__ import annotations

from collections.abc import Sequence

import symengine as se

from ..kernel import Kernel, chain_linear, hessian
from ..smoothing import SQRT_RAMP, SQRT_UNDER, SmoothAbs, SmoothRamp

AXES = "xyz"
SQRT_FLOOR = 1e-3
"""delta / eps: the floor under d, as a fraction of the smoothing length eps = 1/alpha."""


def margin(alpha: se.Expr, ramp: SmoothRamp = SQRT_RAMP) -> se.Expr:
    """m with d - m <= the exact distance from the centre to the box (see the module doc):
    the norm of three ramp overshoots, plus the floor."""
    return se.sqrt(3) * ramp.over(alpha) + SQRT_FLOOR / alpha


def conservatism(alpha: se.Expr, sabs: SmoothAbs = SQRT_UNDER, ramp: SmoothRamp = SQRT_RAMP) -> se.Expr:
    """Upper bound on (exact sphere-box distance) - h while the centre is outside the box."""
    return margin(alpha, ramp) + se.sqrt(3) * sabs.under(alpha)


def relative_position(let_, point: Sequence[se.Expr], center: Sequence[se.Expr],
                      rotation: Sequence[Sequence[se.Expr]], name: str = "rel") -> list[se.Expr]:
    """R^T (point - center) as lets ``<name>_x/y/z`` (rotation columns = the box's axes)."""
    return [let_(f"{name}_{AXES[i]}", se.Add(*[rotation[q][i] * (point[q] - center[q]) for q in range(3)]))
            for i in range(3)]


def smooth_distance(rel: Sequence[se.Expr], half: Sequence[se.Expr], alpha: se.Expr, let_=None) -> se.Expr:
    """d: a smooth upper bound (within ``margin``) of the distance from ``rel`` (box frame)
    to the box with half extents ``half``. With a let factory the per-axis ramps are
    named intermediates ``ramp_x/y/z``."""
    ramps = []
    for i in range(3):
        g = SQRT_RAMP(SQRT_UNDER(rel[i], alpha) - half[i], alpha)
        ramps.append(let_(f"ramp_{AXES[i]}", g) if let_ is not None else g)
    floor = SQRT_FLOOR / alpha
    return se.sqrt(se.Add(*[g * g for g in ramps]) + floor * floor)


def clearance(let_, point: Sequence[se.Expr], center: Sequence[se.Expr], rotation: Sequence[Sequence[se.Expr]],
              half: Sequence[se.Expr], radius: se.Expr, alpha: se.Expr) -> se.Expr:
    """h = d - radius - margin: ``h >= 0`` proves the sphere (centre ``point``) and the box
    (``center``, ``rotation``, ``half``) do not overlap. ``let_`` names the intermediates
    (a family context's ``p.let``, or ``Kernel.let_``)."""
    rel = relative_position(let_, point, center, rotation)
    return smooth_distance(rel, half, alpha, let_) - radius - margin(alpha)


BOUND_ROUNDING = 1e-12
"""Relative allowance :func:`lower_bound` subtracts, of the scale |rel|_1 + sum(half) +
radius + 1/alpha: h and its bound each round by far less."""


def lower_bound(let_, runtime_max, point: Sequence[se.Expr], center: Sequence[se.Expr],
                rotation: Sequence[Sequence[se.Expr]], half: Sequence[se.Expr], radius: se.Expr, alpha: se.Expr,
                name: str = "bound_rel") -> se.Expr:
    """A cheap bound never above :func:`clearance`: the exact distance D from the centre to
    the box is at least the largest ``|rel_i| - half_i`` (0 inside), and h >= D - radius -
    ``conservatism`` everywhere (see the module doc). Square-root free."""
    rel = relative_position(let_, point, center, rotation, name)
    gaps = [se.Abs(rel[i]) - half[i] for i in range(3)]
    scale = se.Add(*[se.Abs(c) for c in rel]) + se.Add(*half) + radius + 1 / alpha
    return runtime_max(f"{name}_gap", gaps) - radius - conservatism(alpha) - BOUND_ROUNDING * scale


# ---------------------------------------------------------------- kernel library
class _Inputs:
    def __init__(self, k: Kernel, with_pose: bool = True):
        if with_pose:
            self.point = k.array_input("point", AXES, "sphere centre, world frame [m]", shape=(3,))
            self.center = k.array_input("center", AXES, "box centre, world frame [m]", shape=(3,))
            self.rotation = k.array_input("rotation", [f"{i}{j}" for i in range(3) for j in range(3)],
                                          "box rotation; its columns are the box's axes in the world frame",
                                          shape=(3, 3))
            self.half = k.array_input("half", AXES, "box half extents along its own axes [m]", shape=(3,))
            self.radius = k.scalar_input("radius", "sphere radius [m]")
        self.alpha = k.scalar_input("alpha", "sharpness: the smoothing length is eps = 1/alpha [1/m]")

    def rotation_matrix(self) -> list[list[se.Expr]]:
        return [[self.rotation[3 * i + j] for j in range(3)] for i in range(3)]


def value_kernel() -> Kernel:
    k = Kernel("certified_clearance",
               "Certified smooth clearance h between a sphere and an oriented box [m]:\n"
               "h >= 0 proves the sphere does not reach into the box (exact arithmetic).\n"
               "h is at most the exact distance, and at most `certified_clearance_conservatism`\n"
               "below it while the centre is outside the box.")
    a = _Inputs(k)
    k.output_scalar("h", clearance(k.let_, a.point, a.center, a.rotation_matrix(), a.half, a.radius, a.alpha),
                    "the certified clearance [m]")
    return k


def derivatives_kernel() -> Kernel:
    k = Kernel("certified_clearance_derivatives",
               "`certified_clearance` with its gradient and Hessian w.r.t. the sphere centre.")
    a = _Inputs(k)
    rot = a.rotation_matrix()
    rel = relative_position(k.let_, a.point, a.center, rot)
    h = smooth_distance(rel, a.half, a.alpha) - a.radius - margin(a.alpha)
    # d rel / d point = R^T, a constant Jacobian.
    grad, hess = chain_linear([se.diff(h, v) for v in rel], hessian(h, rel),
                              [[rot[q][i] for q in range(3)] for i in range(3)])
    k.output_scalar("h", h, "the certified clearance [m]")
    k.output_vector("gradient", grad, "dh/dpoint, world frame [-]")
    k.output_symmetric("hessian", hess, "d2h/dpoint2, world frame [1/m]")
    return k


def _alpha_only_kernel(name: str, doc: str, output: str, value, output_doc: str) -> Kernel:
    """A kernel of alpha alone: one scalar output, ``value(alpha)``."""
    k = Kernel(name, doc)
    a = _Inputs(k, with_pose=False)
    k.output_scalar(output, value(a.alpha), output_doc)
    return k


def margin_kernel() -> Kernel:
    return _alpha_only_kernel(
        "certified_clearance_margin",
        "The margin m `certified_clearance` already subtracts: sqrt(3) eps + delta, with\n"
        "eps = 1/alpha and delta = eps/1000.",
        "margin", margin, "the certified margin [m]")


def conservatism_kernel() -> Kernel:
    return _alpha_only_kernel(
        "certified_clearance_conservatism",
        "Largest gap (exact sphere-box distance) - h while the sphere's centre is outside\n"
        "the box: the margin plus sqrt(3) eps, the smooth |.|'s undershoot on three axes.",
        "bound", conservatism, "the conservatism bound [m]")


def kernels() -> list[Kernel]:
    return [value_kernel(), derivatives_kernel(), margin_kernel(), conservatism_kernel()]


MODULE_DOC = """Certified smooth sphere-box clearance (the Tachyon 3 toe-edge barrier); see
`symbolic/families/sphere_box.py` for the proof and `cbfgen::sphere_box` for the safe API."""
