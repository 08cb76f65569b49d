"""Smooth Separating Axis Theorem (SSAT) between two oriented boxes.

Tachyon 3 paper, section IV-B, eq. 7-10: h = smax(y_1..y_15), one y per candidate
separating axis, each y = |n.dp| - sum |n.r_jk| with |.| and max smoothed.

Formulation choices (they decide whether the barrier is safe and fast):

* **Box A's frame.** With t = R_A^T (p_B - p_A) and R = R_A^T R_B as named
  intermediates, A's axes are the unit vectors, B's axes are R's columns and every
  extent term is a half extent times some |R_ij| (Gottschalk's OBB test). The 15 axes
  then share nine smoothed |R_ij| instead of each smoothing its own world-frame dot
  products.
* **Parallel edges.** A cross axis e_i x f_j has length sqrt(1 - R_ij^2) and vanishes
  when the edges are parallel, where its y would read 0 ("touching") whatever the
  overlap. Each cross axis is therefore lowered by D * R_ij^8 with D = sum of all half
  extents: at parallel edges it sits at -D, below every face axis, and near
  perpendicular edges it is untouched. The term only ever lowers y, so no axis can
  claim a separation that is not there.
* **Overflow.** The smooth max is shifted by the runtime max of the y (see
  :class:`symbolic.smoothing.SmoothMax`): every exp() argument is <= 0.
* **Certified margin.** Each axis records how far its smoothed y can exceed the exact
  (unnormalised) y; with the smooth max's own overshoot this gives m such that
  h - m >= 0 implies some exact axis has a gap >= 0, i.e. the boxes do not overlap.
  The margin is emitted as its own kernel, next to the formula it certifies.
"""

from __future__ import annotations

from collections.abc import Sequence

import symengine as se

from ..kernel import Kernel, chain_linear, hessian
from ..smoothing import SMOOTH_ABS, SMOOTH_MAX, SmoothAbs, SmoothMax

AXIS_COUNT = 15
PARALLEL_PENALTY_POWER = 8
AXES = "xyz"
ROT = [f"{i}{j}" for i in range(3) for j in range(3)]


def _levi_civita(i: int, j: int, k: int) -> int:
    return (i - j) * (j - k) * (k - i) // 2


def separating_axes(
    t: Sequence[se.Expr],
    rot: Sequence[Sequence[se.Expr]],
    half_a: Sequence[se.Expr],
    half_b: Sequence[se.Expr],
    sabs: SmoothAbs,
    alpha: se.Expr,
    alpha_rot: se.Expr,
    let_=None,
) -> list[tuple[se.Expr, se.Expr]]:
    """The 15 (y, overshoot bound) pairs in box A's frame.

    ``t`` is B's centre in A's frame, ``rot[i][j]`` = e_i . f_j (A axis i, B axis j).
    ``sabs`` smooths |.|: distances with sharpness ``alpha``, rotation entries with
    ``alpha_rot``. The bound is an upper bound on y_smooth - y_exact. With a let factory
    the nine smoothed |R_ij|, each shared by several axes, become named intermediates.
    """
    abs_rot = [[sabs(rot[i][j], alpha_rot) for j in range(3)] for i in range(3)]
    if let_ is not None:
        abs_rot = [[let_(f"abs_rot_{i}{j}", abs_rot[i][j]) for j in range(3)] for i in range(3)]
    centre_over = sabs.over(alpha)
    extent_under = sabs.under(alpha_rot)
    penalty_scale = se.Add(*half_a) + se.Add(*half_b)
    axes: list[tuple[se.Expr, se.Expr]] = []

    for i in range(3):  # face normals of A
        y = sabs(t[i], alpha) - half_a[i] - se.Add(*[half_b[j] * abs_rot[i][j] for j in range(3)])
        axes.append((y, centre_over + extent_under * se.Add(*half_b)))

    for j in range(3):  # face normals of B
        proj = se.Add(*[rot[i][j] * t[i] for i in range(3)])
        y = sabs(proj, alpha) - se.Add(*[half_a[i] * abs_rot[i][j] for i in range(3)]) - half_b[j]
        axes.append((y, centre_over + extent_under * se.Add(*half_a)))

    for i in range(3):  # edge-edge axes e_i x f_j
        for j in range(3):
            others_a = [k for k in range(3) if k != i]
            others_b = [k for k in range(3) if k != j]
            # (e_i x f_j)_k = eps_{i m k} R_mj with m the index that is neither i nor k.
            proj = se.Add(*[_levi_civita(i, 3 - i - k, k) * rot[3 - i - k][j] * t[k]
                            for k in others_a])
            # (e_i x f_j) . f_k = e_i . (f_j x f_k) = +-R_il with l neither j nor k.
            extent = (se.Add(*[half_a[k] * abs_rot[3 - i - k][j] for k in others_a])
                      + se.Add(*[half_b[k] * abs_rot[i][3 - j - k] for k in others_b]))
            parallel = penalty_scale * rot[i][j] ** PARALLEL_PENALTY_POWER
            y = sabs(proj, alpha) - extent - parallel
            bound = centre_over + extent_under * (se.Add(*[half_a[k] for k in others_a])
                                                  + se.Add(*[half_b[k] for k in others_b]))
            axes.append((y, bound))
    assert len(axes) == AXIS_COUNT
    return axes


def matrix(row_major: Sequence[se.Expr]) -> list[list[se.Expr]]:
    """3x3 nested list from nine row-major entries."""
    return [[row_major[3 * i + j] for j in range(3)] for i in range(3)]


def relative_pose(let_, p_a, r_a, p_b, r_b):
    """Box B's pose in box A's frame as lets: t = R_A^T (p_B - p_A) and R = R_A^T R_B.
    ``let_`` names them (``Kernel.let_``, or ``LieEngine.let_`` to differentiate through)."""
    t = [let_(f"t_{AXES[i]}", se.Add(*[r_a[k][i] * (p_b[k] - p_a[k]) for k in range(3)]))
         for i in range(3)]
    rot = [[let_(f"rot_{i}{j}", se.Add(*[r_a[k][i] * r_b[k][j] for k in range(3)]))
            for j in range(3)] for i in range(3)]
    return t, rot


BOUND_ROUNDING = 1e-12
"""Relative allowance the lower bounds subtract, of the pair's scale (sum of |t| and of
the half extents): both h and its bound round by about 1e-14 of it (the runtime's SSAT
rounding guard tallies h's at 240 u), so a bound that is tight in exact arithmetic stays
below the computed h."""


def lower_bound(let_, runtime_max, t: Sequence[se.Expr], rot: Sequence[Sequence[se.Expr]],
                half_a: Sequence[se.Expr], half_b: Sequence[se.Expr], sabs: SmoothAbs, smax: SmoothMax,
                alpha: se.Expr, alpha_rot: se.Expr, margin: se.Expr) -> se.Expr:
    """A cheap bound never above ``smax(ys) - margin`` (the SSAT row's h): the six face axes
    of the exact SAT, less what smoothing can take from each, less the margin. Along a
    face axis the smoothed centre term is at most ``sabs.under(alpha)`` below ``|t|`` and
    each smoothed extent ``|R_ij|`` at most ``sabs.over(alpha_rot)`` above it; log-sum-exp
    is never below its largest argument. (The Boltzmann operator can be far below it:
    no bound from the axes.) About 60 operations and no transcendental call, against the
    row's value and Lie derivatives."""
    if smax is not SMOOTH_MAX["lse"]:
        raise ValueError(f"lower_bound needs a smooth max never below the max (lse), not {smax.name}")
    slack = sabs.under(alpha) + sabs.over(alpha_rot) * (se.Add(*half_a) + se.Add(*half_b))
    faces = [se.Abs(t[i]) - half_a[i] - se.Add(*[half_b[j] * se.Abs(rot[i][j]) for j in range(3)])
             for i in range(3)]
    for j in range(3):
        proj = se.Add(*[rot[i][j] * t[i] for i in range(3)])
        faces.append(se.Abs(proj) - half_b[j] - se.Add(*[half_a[i] * se.Abs(rot[i][j]) for i in range(3)]))
    scale = se.Add(*[se.Abs(c) for c in t]) + se.Add(*half_a) + se.Add(*half_b)
    return runtime_max("face_sat", faces) - slack - margin - BOUND_ROUNDING * scale


def certified_margin(kernel: Kernel, smax: SmoothMax, axes, alpha: se.Expr) -> se.Expr:
    """m with h - m >= 0 => no overlap: the smooth max's overshoot plus the worst axis's
    overshoot bound (the second element of each ``separating_axes`` pair)."""
    worst_axis = kernel.runtime_max("worst_axis", [bound for _, bound in axes])
    return smax.over(AXIS_COUNT, alpha) + worst_axis


class _BoxPair:
    """Inputs shared by every SSAT kernel, and the relative pose as named lets."""

    def __init__(self, kernel: Kernel, with_poses: bool = True):
        if with_poses:
            self.p_a = kernel.array_input("p_a", AXES, "centre of box A, world frame [m]", shape=(3,))
            self.r_a = kernel.array_input(
                "r_a", ROT, "rotation of box A; its columns are A's axes in the world frame", shape=(3, 3))
        self.half_a = kernel.array_input("half_a", AXES, "half extents of box A along its own axes [m]", shape=(3,))
        if with_poses:
            self.p_b = kernel.array_input("p_b", AXES, "centre of box B, world frame [m]", shape=(3,))
            self.r_b = kernel.array_input("r_b", ROT, "rotation of box B", shape=(3, 3))
        self.half_b = kernel.array_input("half_b", AXES, "half extents of box B [m]", shape=(3,))
        self.alpha = kernel.scalar_input(
            "alpha", "sharpness of the smooth max and of the smooth |.| on distances [1/m]")
        self.alpha_rot = kernel.scalar_input(
            "alpha_rot", "sharpness of the smooth |.| on rotation-matrix entries [-]")
        if not with_poses:
            return
        ra, rb = matrix(self.r_a), matrix(self.r_b)
        self.t, self.rot = relative_pose(kernel.let_, self.p_a, ra, self.p_b, rb)
        # d t / d p_B = R_A^T, a constant Jacobian: derivatives go through t by the chain rule.
        self.dt_dpb = [[ra[k][i] for k in range(3)] for i in range(3)]

    def axes(self, sabs: SmoothAbs):
        return separating_axes(self.t, self.rot, self.half_a, self.half_b,
                               sabs, self.alpha, self.alpha_rot)


def _variant_doc(smax: SmoothMax, sabs: SmoothAbs) -> str:
    return f"smooth max: {smax.doc}; smooth |.|: {sabs.doc}."


def value_kernel(smax: SmoothMax, sabs: SmoothAbs) -> Kernel:
    k = Kernel(f"ssat_{smax.name}_{sabs.name}",
               f"Smooth SAT value h for two oriented boxes ({_variant_doc(smax, sabs)})\n"
               "h > 0 reads as separated, h < 0 as overlapping; subtract the matching\n"
               "`_margin` kernel before treating h >= 0 as a proof of separation.")
    pair = _BoxPair(k)
    ys = [y for y, _ in pair.axes(sabs)]
    shift = k.runtime_max("y_max", ys)
    k.output_scalar("h", smax(ys, pair.alpha, shift), "the smooth separation value [m]")
    return k


def derivatives_kernel(smax: SmoothMax, sabs: SmoothAbs) -> Kernel:
    k = Kernel(f"ssat_{smax.name}_{sabs.name}_derivatives",
               f"Smooth SAT value with gradient and Hessian w.r.t. box B's centre p_b\n"
               f"({_variant_doc(smax, sabs)})")
    pair = _BoxPair(k)
    ys = [y for y, _ in pair.axes(sabs)]
    # The shift is a constant for differentiation: the smooth max does not depend on it.
    shift = k.runtime_max("y_max", ys)
    h = smax(ys, pair.alpha, shift)
    hess_t = hessian(h, pair.t)
    grad_t = [se.diff(h, v) for v in pair.t]
    grad, hess = chain_linear(grad_t, hess_t, pair.dt_dpb)
    k.output_scalar("h", h, "the smooth separation value [m]")
    k.output_vector("gradient", grad, "dh/dp_b, world frame [-]")
    k.output_symmetric("hessian", hess, "d2h/dp_b2, world frame [1/m]")
    return k


def margin_kernel(smax: SmoothMax, sabs: SmoothAbs) -> Kernel:
    k = Kernel(f"ssat_{smax.name}_{sabs.name}_margin",
               f"Certified margin m for `ssat_{smax.name}_{sabs.name}`: h - m >= 0 implies the\n"
               "exact boxes do not overlap. m = (smooth-max overshoot) + max over the 15 axes of\n"
               "(smooth-|.| overshoot of the centre term + undershoot of the extent terms).")
    pair = _BoxPair(k, with_poses=False)
    placeholder_t = [se.Integer(0)] * 3
    placeholder_rot = [[se.Integer(0)] * 3 for _ in range(3)]
    # The bounds depend on sizes and sharpness only; the pose placeholders never reach them.
    axes = separating_axes(placeholder_t, placeholder_rot, pair.half_a, pair.half_b,
                           sabs, pair.alpha, pair.alpha_rot)
    k.output_scalar("margin", certified_margin(k, smax, axes, pair.alpha), "the certified margin [m]")
    return k


VARIANTS = [(SMOOTH_MAX[m], SMOOTH_ABS[a]) for m in ("lse", "boltzmann") for a in ("xtanh", "sqrt")]


def kernels() -> list[Kernel]:
    out: list[Kernel] = []
    for smax, sabs in VARIANTS:
        out += [value_kernel(smax, sabs), derivatives_kernel(smax, sabs), margin_kernel(smax, sabs)]
    return out


MODULE_DOC = """Smooth Separating Axis Theorem kernels (Tachyon 3 paper eq. 7-10), formulated in
box A's frame; see `symbolic/families/ssat.py` for the derivation and `cbfgen::ssat` for
the safe API over these functions."""
