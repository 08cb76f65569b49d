"""Lie derivatives of constraints h(x, params) along a control-affine system x' = f + g u.

Derivatives are taken *forward*, through the kernel's named intermediates: when h uses
a let L (say, the relative pose of two boxes), its derivative along a vector field v is

    D_v h = sum_k dh/dx_k v_k + sum_L dh/dL * D_v L,

and D_v L becomes a let of its own (``<L>_df`` for f, ``<L>_dg<u>`` for input column u),
created on first use and shared by everything that needs it. Expressions therefore stay
the size of the formula rather than of its fully substituted form, and CSE can share
every intermediate rate between h, L_f h, L_f^2 h and L_g L_f h.

Time-varying constraints h(x, t) (a moving boundary, say) pass the time symbol as
``time=t``. The drift field then gets the extra component dt/dt = 1, as if t were a state
with t' = 1 and no input column, so

    L_f h = dh/dt + sum_k dh/dx_k f_k + sum_L dh/dL * D_f L,

lets included (a let of t alone has the rate dL/dt). The input fields are unchanged:
L_g h has no time term. Without ``time`` the engine is exactly the time-invariant one.

The relative degree is found, not assumed: the first k with L_g L_f^k h structurally
non-zero. Runtime reductions (a smooth max's shift) are neither states nor lets, so they
are constants here, which is exact for the shift-invariant smooth maxima.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import symengine as se

from .kernel import Kernel

MAX_RELATIVE_DEGREE = 4


class RelativeDegreeError(ValueError):
    """The constraint never depends on the input within MAX_RELATIVE_DEGREE derivatives."""


@dataclass(frozen=True)
class LieRow:
    """``lf[k]`` is L_f^k h for k = 0..r (so lf[0] = h and lf[r] = L_f^r h);
    ``lg`` maps each structurally non-zero input column u to L_g_u L_f^(r-1) h."""

    degree: int
    lf: tuple[se.Expr, ...]
    lg: dict[int, se.Expr]


class LieEngine:
    def __init__(self, kernel: Kernel, x: Sequence[se.Symbol], f: Sequence[se.Expr],
                 g: Sequence[Sequence[se.Expr]], time: se.Symbol | None = None):
        self.kernel = kernel
        self.time = time
        self.x = list(x)
        self.f = list(f)
        self.g = [list(row) for row in g]
        self.nu = len(self.g[0])
        self._f_support = [k for k, fk in enumerate(self.f) if fk != 0]
        self._g_support = [[k for k in range(len(self.x)) if self.g[k][u] != 0] for u in range(self.nu)]
        self._defs: dict[se.Symbol, se.Expr] = {}
        self._rates: dict[tuple[se.Symbol, int | None], se.Expr] = {}

    def let_(self, name: str, expr: se.Expr) -> se.Symbol:
        """A named intermediate the engine may differentiate through."""
        sym = self.kernel.let_(name, expr)
        self._defs[sym] = se.sympify(expr)
        return sym

    def along(self, e: se.Expr, column: int | None) -> se.Expr:
        """D_f e (``column=None``, with d/dt when the engine has a time symbol) or
        D_{g_u} e (``column=u``)."""
        if column is None:
            field = [(k, self.f[k]) for k in self._f_support]
        else:
            field = [(k, self.g[k][column]) for k in self._g_support[column]]
        terms: list[se.Expr] = []
        if column is None and self.time is not None:
            d = se.diff(e, self.time)  # t' = 1: the augmented drift's time component
            if d != 0:
                terms.append(d)
        for k, vk in field:
            d = se.diff(e, self.x[k])
            if d != 0:
                terms.append(d * vk)
        for sym in sorted(e.free_symbols & self._defs.keys(), key=str):
            rate = self._rate(sym, column)
            if rate != 0:
                d = se.diff(e, sym)
                if d != 0:
                    terms.append(d * rate)
        return se.Add(*terms) if terms else se.Integer(0)

    def _rate(self, sym: se.Symbol, column: int | None) -> se.Expr:
        key = (sym, column)
        if key not in self._rates:
            rate = self.along(self._defs[sym], column)
            if rate != 0 and not (rate.is_Symbol or rate.is_Number):
                suffix = "df" if column is None else f"dg{column}"
                rate = self.let_(f"{sym}_{suffix}", rate)
            self._rates[key] = rate
        return self._rates[key]

    def row(self, h: se.Expr, what: str) -> LieRow:
        """Differentiate h to its relative degree."""
        lf = [se.sympify(h)]
        for k in range(MAX_RELATIVE_DEGREE):
            lg = {u: self.along(lf[-1], u) for u in range(self.nu)}
            lg = {u: e for u, e in lg.items() if e != 0}
            lf.append(self.along(lf[-1], None))
            if lg:
                return LieRow(k + 1, tuple(lf), lg)
        raise RelativeDegreeError(
            f"{what}: L_g L_f^k h is identically zero for k < {MAX_RELATIVE_DEGREE}; the "
            "constraint does not depend on the input, so no CBF can enforce it")
