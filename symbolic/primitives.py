"""The library's building blocks for barrier functions, in one place for spec authors.

Everything here is a re-export or a thin wrapper over what the built-in families use
(:mod:`symbolic.smoothing`, :mod:`symbolic.families.ssat`, :mod:`symbolic.linalg`), so a
user's barrier is the same mathematics as the library's own. Helpers that build named
intermediates take the family context ``p`` (the argument of a family's ``h``) first:
its ``let`` / ``runtime_max`` keep the expressions the size of the formula and let the
Lie engine differentiate through them.

Conventions: a rotation is a 3x3 nested list whose columns are the body's axes in the
world frame; a box is ``Box(center, rotation, half_extents)`` with 3, 3x3 and 3 entries
(symbols, numbers or expressions).

**Domains.** A primitive says what its inputs must be for its value to mean what it
says (:meth:`~symbolic.spec.FamilyContext.require`): a box's rotation a proper rotation
(``BOX_ROTATION``) and its half extents > 0, a sphere's radius > 0, a superellipsoid's
inflation >= 0, a half-space's normal of unit length. Where those inputs are a family's
parameters (``prim.Box(p.center, p.rotation, p.half)``), the domains are attached to the
parameters, so the generated validation refuses a box with a negative half extent or a
reflection for a rotation in every language, with no declaration in the spec. Numbers
are checked when the spec is generated.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import symengine as se

from .families import sphere_box as _sphere_box
from .families import ssat as ssat_family
from .families.ssat import AXIS_COUNT, certified_margin, relative_pose, separating_axes
from .linalg import matmul, matvec, rot_y, rot_z
from .smoothing import (
    BOLTZMANN,
    LSE,
    SMOOTH_ABS,
    SMOOTH_MAX,
    SQRT,
    SQRT_RAMP,
    SQRT_UNDER,
    XTANH,
    XTANH_ABS_GAP,
    SmoothAbs,
    SmoothMax,
    SmoothRamp,
)
from .spec import DEFAULT_TOLERANCE, FamilyContext, NonNegative, Positive, Rotation, UnitVector, require

__all__ = [
    "AXIS_COUNT", "BOLTZMANN", "BOX_ROTATION", "LSE", "NORMAL", "SMOOTH_ABS", "SMOOTH_MAX", "SQRT", "SQRT_RAMP",
    "SQRT_UNDER", "XTANH",
    "XTANH_ABS_GAP", "Box", "SmoothAbs", "SmoothMax", "SmoothRamp", "half_space", "identity", "matmul",
    "matvec", "rot_x", "rot_y", "rot_z", "sphere_box", "ssat", "superellipsoid", "transpose",
]


# A box's rotation: proper, orthonormal to the tolerance the runtime's OrientedBox accepts.
BOX_ROTATION = Rotation(DEFAULT_TOLERANCE)
# A half-space's normal: of unit length (the row is then a signed distance), to the same tolerance.
NORMAL = UnitVector(DEFAULT_TOLERANCE)


class _BoxFields(NamedTuple):
    center: Sequence[se.Expr]
    rotation: Sequence[Sequence[se.Expr]]
    half_extents: Sequence[se.Expr]


class Box(_BoxFields):
    """An oriented box: centre (3), rotation (3x3, columns = the box's axes in the world
    frame) and half extents along its own axes (3).

    Built inside a family's ``h``, it requires its rotation proper (``BOX_ROTATION``) and
    its half extents > 0: a family parameter given as either gets that domain."""

    __slots__ = ()

    def __new__(cls, center: Sequence[se.Expr], rotation: Sequence[Sequence[se.Expr]],
                half_extents: Sequence[se.Expr]) -> Box:
        box = super().__new__(cls, center, rotation, half_extents)
        _require_box(box, "prim.Box")
        return box


def _require_box(box: Sequence[object], who: str, p: FamilyContext | None = None) -> None:
    """``box``'s rotation proper and half extents > 0, on ``p`` (else the running family's)."""
    _, rotation, half = box
    ask = require if p is None else p.require
    ask(rotation, BOX_ROTATION, f"{who}'s box rotation")
    ask(half, Positive(), f"{who}'s box half extents")


# ------------------------------------------------------------------- rotations
def rot_x(a: se.Expr) -> list[list[se.Expr]]:
    """Rotation by ``a`` [rad] about x."""
    c, s = se.cos(a), se.sin(a)
    return [[1, 0, 0], [0, c, -s], [0, s, c]]


def identity() -> list[list[se.Expr]]:
    """The 3x3 identity rotation."""
    return [[se.Integer(int(i == j)) for j in range(3)] for i in range(3)]


def transpose(m: Sequence[Sequence[se.Expr]]) -> list[list[se.Expr]]:
    return [[m[i][j] for i in range(len(m))] for j in range(len(m[0]))]


# ------------------------------------------------------------------ primitives
def interval_rows(names: Sequence[str], values: Sequence[se.Expr], lower: Sequence[float],
                  upper: Sequence[float]) -> list[tuple[str, se.Expr]]:
    """Rows keeping each ``values[i]`` in ``[lower[i], upper[i]]``: ``<name>_min`` =
    value - lower and ``<name>_max`` = upper - value, in that order for each name (joint
    limits, rate limits)."""
    if not len(names) == len(values) == len(lower) == len(upper):
        raise ValueError(f"interval_rows: {len(names)} names, {len(values)} values, {len(lower)} lower and "
                         f"{len(upper)} upper bounds")
    rows = []
    for name, v, lo, hi in zip(names, values, lower, upper, strict=True):
        rows += [(f"{name}_min", v - lo), (f"{name}_max", hi - v)]
    return rows


def half_space(point: Sequence[se.Expr], normal: Sequence[se.Expr], offset: se.Expr) -> se.Expr:
    """``normal . point + offset``: >= 0 on the side the normal points to (the convex
    foothold constraint of the Tachyon 3 paper, eq. 12, in any dimension). The normal must
    have unit length (``NORMAL``), so h is the signed distance to the boundary and a
    zero normal (a row no input can move) is refused."""
    if len(point) != len(normal):
        raise ValueError(f"half_space: point has {len(point)} entries, normal {len(normal)}")
    require(list(normal), NORMAL, "prim.half_space's normal")
    return se.Add(*[n * q for n, q in zip(normal, point, strict=True)]) + offset


def superellipsoid(p: FamilyContext, point: Sequence[se.Expr], box: Box, n: int = 2,
                   inflate: se.Expr = 0, name: str = "rel") -> se.Expr:
    """``sum_i (r_i / (a_i + inflate))^(2n) - 1`` with ``r = R^T (point - centre)``: >= 0
    outside the superellipsoid inscribed in ``box`` grown by ``inflate`` (a sphere's
    radius, as the paper's eq. 11 folds the toe sphere into the edge cuboid). ``r`` is
    a named intermediate ``<name>_x/y/z``. Inscribed: not conservative at the edges and
    corners, so h >= 0 does not prove clearance; :func:`sphere_box` does (Tachyon 3's
    toe rows used this, the paper's eq. 11, until it was replaced for that reason).
    Requires ``box``'s domains and ``inflate`` >= 0."""
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"superellipsoid: n must be a positive integer, got {n!r}")
    _require_box(box, "prim.superellipsoid", p)
    p.require(inflate, NonNegative(), "prim.superellipsoid's inflation")
    c, rot, half = box
    rel = [p.let(f"{name}_{'xyz'[i]}", se.Add(*[rot[q][i] * (point[q] - c[q]) for q in range(3)]))
           for i in range(3)]
    return se.Add(*[(rel[i] / (half[i] + inflate)) ** (2 * n) for i in range(3)]) - 1


def sphere_box(p: FamilyContext, center: Sequence[se.Expr], radius: se.Expr, box: Box,
               alpha: se.Expr = 1500.0) -> se.Expr:
    """Certified clearance [m] between a sphere (``center``, ``radius``) and ``box``: a
    smooth distance from the centre to the box, minus the radius and the certified margin
    (sqrt(3) + 0.001)/alpha, so h >= 0 proves the sphere does not reach into the box
    (:mod:`symbolic.families.sphere_box` has the proof). ``alpha`` [1/m] is the inverse
    smoothing length: 1500 gives a 1.2 mm margin. Tachyon 3's toe-edge rows are this.
    Requires ``box``'s domains and ``radius`` > 0 (h subtracts it: a negative radius would
    read as extra clearance)."""
    _require_box(box, "prim.sphere_box", p)
    p.require(radius, Positive(), "prim.sphere_box's radius")
    return _sphere_box.clearance(p.let, center, box.center, box.rotation, box.half_extents,
                                 se.sympify(radius), se.sympify(alpha))


def ssat(p: FamilyContext, a: Box, b: Box, alpha: se.Expr = 100.0, alpha_rot: se.Expr = 100.0,
         smax: SmoothMax = LSE, sabs: SmoothAbs = XTANH, certified: bool = True,
         names: tuple[str | None, str | None] = (None, None)) -> se.Expr:
    """The smooth SAT separation of two oriented boxes (Tachyon 3 paper, eq. 7-10), in
    box A's frame as :mod:`symbolic.families.ssat` formulates it: > 0 separated, < 0
    overlapping. ``alpha`` [1/m] sharpens the smooth max and |.| on distances,
    ``alpha_rot`` the |.| on rotation entries. With ``certified`` (the default) the
    certified margin is subtracted, so h >= 0 proves the exact boxes do not overlap.
    Requires both boxes' domains (the proof is for boxes: proper rotations, half extents > 0).

    The relative pose, the smoothed |R_ij|, every axis value and the smooth max's pieces
    are named intermediates: L_f^2 h then costs O(15) instead of a dense Hessian.

    ``names`` name the boxes' pose kernels in a ``compose=True`` family (``pose_<name>``;
    say the frame when a box is placed in several: ``"link5_in_link1"``); unnamed, a
    pose kernel is named after the first member that uses it.
    """
    _require_box(a, "prim.ssat", p)
    _require_box(b, "prim.ssat", p)
    alpha, alpha_rot = se.sympify(alpha), se.sympify(alpha_rot)
    if p.composer is not None:  # a compose=True family: the generator builds it from parts
        return p.composer.record("ssat", ssat_value, (a, b), dict(alpha=alpha, alpha_rot=alpha_rot, smax=smax,
                                                                  sabs=sabs, certified=certified), names)
    return ssat_value(p, a, b, alpha=alpha, alpha_rot=alpha_rot, smax=smax, sabs=sabs, certified=certified)


def ssat_value(p: FamilyContext, a: Box, b: Box, *, alpha: se.Expr, alpha_rot: se.Expr, smax: SmoothMax,
               sabs: SmoothAbs, certified: bool) -> se.Expr:
    """:func:`ssat`'s expression, domains already required (what a composed family's chain
    kernel is built from)."""
    t, rot = relative_pose(p.let, a.center, a.rotation, b.center, b.rotation)
    axes = separating_axes(t, rot, a.half_extents, b.half_extents, sabs, alpha, alpha_rot, p.let)
    ys = [p.let(f"y_{i}", y) for i, (y, _) in enumerate(axes)]
    shift = p.runtime_max("y_max", ys)
    h = smax(ys, alpha, shift, p.let)
    return h - certified_margin(p, smax, axes, alpha) if certified else h


def ssat_lower_bound(p: FamilyContext, a: Box, b: Box, alpha: se.Expr = 100.0, alpha_rot: se.Expr = 100.0,
                     sabs: SmoothAbs = XTANH, certified: bool = True,
                     names: tuple[str | None, str | None] = (None, None)) -> se.Expr:
    """A cheap bound never above :func:`ssat` with the same arguments (log-sum-exp only):
    the exact SAT's six face axes less what smoothing can take from each, and the
    certified margin when ``certified``; no transcendental call. For a family's
    ``lower_bound=`` (see :meth:`symbolic.spec.System.family`); in a ``compose=True``
    family it reads the boxes' poses from value kernels ``pose_<name>_value`` (``names``
    as :func:`ssat`'s) and one bound kernel per family."""
    alpha, alpha_rot = se.sympify(alpha), se.sympify(alpha_rot)
    if p.composer is not None:
        return p.composer.record("ssat_lower_bound", ssat_lower_bound_value, (a, b),
                                 dict(alpha=alpha, alpha_rot=alpha_rot, sabs=sabs, certified=certified), names)
    return ssat_lower_bound_value(p, a, b, alpha=alpha, alpha_rot=alpha_rot, sabs=sabs, certified=certified)


def ssat_lower_bound_value(p: FamilyContext, a: Box, b: Box, *, alpha: se.Expr, alpha_rot: se.Expr,
                           sabs: SmoothAbs, certified: bool) -> se.Expr:
    """:func:`ssat_lower_bound`'s expression (what a composed family's bound kernel is built
    from)."""
    t, rot = relative_pose(p.let, a.center, a.rotation, b.center, b.rotation)
    axes = separating_axes(t, rot, a.half_extents, b.half_extents, sabs, alpha, alpha_rot, p.let)
    margin = certified_margin(p, LSE, axes, alpha) if certified else se.Integer(0)
    return ssat_family.lower_bound(p.let, p.runtime_max, t, rot, a.half_extents, b.half_extents, sabs, LSE,
                                   alpha, alpha_rot, margin)
