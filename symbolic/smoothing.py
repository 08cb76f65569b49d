"""Smooth surrogates for |x| and max(x_1..x_n), each with its one-sided error bounds.

Every primitive states how far it can sit above (``over``) and below (``under``) the
exact function, as an expression in its sharpness parameter. Constraint families add
these bounds up to emit a *certified margin*: the amount by which a smoothed barrier
may overstate the exact one. That is how a smooth barrier still proves exact safety.

Sharpness is always a positive "alpha": larger is closer to the exact function.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import symengine as se


def _max_of_u_times_one_minus_tanh() -> float:
    """max over u > 0 of u * (1 - tanh u), rounded up in the 12th digit.

    This is the worst-case gap |x| - x*tanh(alpha*x), scaled by alpha. The maximiser
    solves d/du [u (1 - tanh u)] = 1 - tanh u - u sech^2 u = 0; bisection on that
    derivative is monotone enough on [0.1, 2] to converge without care.
    """

    def slope(u: float) -> float:
        th = math.tanh(u)
        return 1.0 - th - u * (1.0 - th * th)

    lo, hi = 0.1, 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if slope(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    u = 0.5 * (lo + hi)
    peak = u * (1.0 - math.tanh(u))
    return math.ceil(peak * 1e12) / 1e12


XTANH_ABS_GAP = _max_of_u_times_one_minus_tanh()
"""0 <= |x| - x*tanh(alpha*x) <= XTANH_ABS_GAP / alpha (about 0.2785 / alpha)."""


@dataclass(frozen=True)
class SmoothAbs:
    """A smooth, even surrogate s(x) for |x| with  -over <= |x| - s(x) <= under."""

    name: str
    doc: str
    value: Callable[[se.Expr, se.Expr], se.Expr]
    under: Callable[[se.Expr], se.Expr]
    over: Callable[[se.Expr], se.Expr]

    def __call__(self, x: se.Expr, alpha: se.Expr) -> se.Expr:
        return self.value(x, alpha)


XTANH = SmoothAbs(
    name="xtanh",
    doc="x*tanh(alpha*x): never above |x|, at most 0.2785/alpha below it",
    value=lambda x, alpha: x * se.tanh(alpha * x),
    under=lambda alpha: se.RealDouble(XTANH_ABS_GAP) / alpha,
    over=lambda alpha: se.Integer(0),
)

SQRT = SmoothAbs(
    name="sqrt",
    doc="sqrt(x^2 + eps^2) with eps = 1/alpha: never below |x|, at most eps above it",
    value=lambda x, alpha: se.sqrt(x * x + 1 / (alpha * alpha)),
    under=lambda alpha: se.Integer(0),
    over=lambda alpha: 1 / alpha,
)

SQRT_UNDER = SmoothAbs(
    name="sqrt_under",
    doc="sqrt(x^2 + eps^2) - eps with eps = 1/alpha: never above |x|, at most eps below it",
    value=lambda x, alpha: se.sqrt(x * x + 1 / (alpha * alpha)) - 1 / alpha,
    under=lambda alpha: 1 / alpha,
    over=lambda alpha: se.Integer(0),
)


@dataclass(frozen=True)
class SmoothRamp:
    """A smooth, increasing surrogate r(x) for max(x, 0) with 0 <= r(x) - max(x, 0) <= over."""

    name: str
    doc: str
    value: Callable[[se.Expr, se.Expr], se.Expr]
    over: Callable[[se.Expr], se.Expr]

    def __call__(self, x: se.Expr, alpha: se.Expr) -> se.Expr:
        return self.value(x, alpha)


SQRT_RAMP = SmoothRamp(
    name="sqrt_ramp",
    doc="(x + sqrt(x^2 + 4 eps^2))/2 with eps = 1/alpha: increasing, never below max(x, 0), at most eps "
        "above it (at x = 0); algebraic, so no exp() to overflow",
    value=lambda x, alpha: (x + se.sqrt(x * x + 4 / (alpha * alpha))) / 2,
    over=lambda alpha: 1 / alpha,
)
"""(sqrt(x^2 + 4 eps^2) - |x|)/2 lies in (0, eps]: the overshoot over max(x, 0)."""


@dataclass(frozen=True)
class SmoothMax:
    """A smooth surrogate S(y) for max(y) with  -under <= S(y) - max(y) <= over.

    ``value(ys, alpha, shift, let_=None)`` takes a *shift* symbol, and optionally a let
    factory (``LieEngine.let_``) to build its pieces as named intermediates. The
    surrogate is built so its value does not depend on the shift at all (exactly, not approximately); the emitted
    code sets the shift to the runtime max(y) so no exp() can overflow, and
    differentiation may treat the shift as a constant because every derivative of the
    surrogate with respect to it is identically zero.
    """

    name: str
    doc: str
    value: Callable[..., se.Expr]
    over: Callable[[int, se.Expr], se.Expr]

    def __call__(self, ys: Sequence[se.Expr], alpha: se.Expr, shift: se.Expr, let_=None) -> se.Expr:
        return self.value(ys, alpha, shift, let_)


def _lse(ys: Sequence[se.Expr], alpha: se.Expr, shift: se.Expr, let_=None) -> se.Expr:
    terms = [se.exp(alpha * (y - shift)) for y in ys]
    if let_ is not None:
        # Exponentials and their sum as named intermediates: differentiated forward, the
        # k-th derivative of h is then a short recurrence in the sum's derivatives
        # (h' = S'/(alpha S), h'' = (S''/S - (S'/S)^2)/alpha) instead of an n^2 expansion.
        terms = [let_(f"lse_e{i}", e) for i, e in enumerate(terms)]
        return shift + se.log(let_("lse_sum", se.Add(*terms))) / alpha
    return shift + se.log(se.Add(*terms)) / alpha


def _boltzmann(ys: Sequence[se.Expr], alpha: se.Expr, shift: se.Expr, let_=None) -> se.Expr:
    weights = [se.exp(alpha * (y - shift)) for y in ys]
    if let_ is not None:  # as for the LSE: weights and both sums as named intermediates
        weights = [let_(f"boltzmann_w{i}", w) for i, w in enumerate(weights)]
        numerator = let_("boltzmann_num", se.Add(*[y * w for y, w in zip(ys, weights, strict=False)]))
        return numerator / let_("boltzmann_den", se.Add(*weights))
    return se.Add(*[y * w for y, w in zip(ys, weights, strict=False)]) / se.Add(*weights)


LSE = SmoothMax(
    name="lse",
    doc="log-sum-exp: never below max, at most ln(n)/alpha above it",
    value=_lse,
    over=lambda n, alpha: se.log(se.Integer(n)) / alpha,
)

BOLTZMANN = SmoothMax(
    name="boltzmann",
    doc="Boltzmann operator (softmax-weighted mean): never above max",
    value=_boltzmann,
    over=lambda n, alpha: se.Integer(0),
)

SMOOTH_ABS = {s.name: s for s in (XTANH, SQRT)}
SMOOTH_MAX = {s.name: s for s in (LSE, BOLTZMANN)}
