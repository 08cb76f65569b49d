"""Partial functions in a family's rows: a square root, fractional power, division or log
of something that can reach 0 or below, where the row (or a derivative of it) is not
finite.

A base is accepted when it is *provably non-negative* from its form alone: numbers, sums
and products of non-negative terms, even powers, ``exp``/``cosh``, and parameters whose
domain is ``Positive``, ``NonNegative`` or an ``Interval`` above 0. A sum of squares
passes though it vanishes where every square does (the knee length ``sqrt(x² + z²)``):
that is one point, not a surface a trajectory crosses. Everything else — ``sqrt(p_z)``,
``1 / (x - 1)`` — is reported with a guarded form, as a warning: the spec may know better
(a state that physically stays positive), and the filter answers a non-finite row with a
flagged fallback, never a wrong input.
"""

from __future__ import annotations

import symengine as se

from ..kernel import Kernel, Let, RuntimeMax
from ..spec import Interval, NonNegative, Param, Positive

_POSITIVE, _NON_NEGATIVE = 2, 1


def _domain_sign(param: Param) -> int:
    d = param.domain
    if isinstance(d, Positive) or (isinstance(d, Interval) and d.lo > 0.0):
        return _POSITIVE
    if isinstance(d, NonNegative) or (isinstance(d, Interval) and d.lo >= 0.0):
        return _NON_NEGATIVE
    return 0


class _Signs:
    """What the form of an expression proves about its sign: 2 (> 0), 1 (>= 0) or 0."""

    def __init__(self, kernel: Kernel, params: tuple[Param, ...]):
        self.known: dict[se.Expr, int] = {}
        by_name = {p.name: p for p in params}
        for inp in kernel.inputs:
            if inp.name in by_name:
                for sym in inp.symbols:
                    self.known[sym] = _domain_sign(by_name[inp.name])
        self.lets = {d.symbol: d.expr for d in kernel.definitions if isinstance(d, Let)}
        self.maxima = {d.symbol: d.exprs for d in kernel.definitions if isinstance(d, RuntimeMax)}

    def of(self, e: se.Expr) -> int:
        if e in self.known:
            return self.known[e]
        self.known[e] = 0  # a cycle through lets proves nothing
        self.known[e] = sign = self._of(e)
        return sign

    def _of(self, e: se.Expr) -> int:
        if e.is_Number or not e.free_symbols:  # numbers and constants (E, pi)
            v = float(e)
            return _POSITIVE if v > 0 else _NON_NEGATIVE if v == 0 else 0
        if e.is_Symbol:
            if e in self.lets:
                return self.of(self.lets[e])
            if e in self.maxima:
                return max(self.of(x) for x in self.maxima[e])
            return 0
        args = e.args
        if isinstance(e, (se.Add, se.Mul)):
            signs = [self.of(a) for a in args]
            if min(signs) == 0:
                return 0
            if isinstance(e, se.Add):
                return max(signs)
            return min(signs)
        if isinstance(e, se.Pow):
            base, exponent = args
            if exponent.is_Integer and int(exponent) % 2 == 0:
                return _POSITIVE if self.of(base) == _POSITIVE else _NON_NEGATIVE
            return self.of(base)
        if isinstance(e, se.cosh):  # exp(x) is Pow(E, x), positive through its base
            return _POSITIVE
        if isinstance(e, se.Abs):
            return _NON_NEGATIVE
        return 0


def _partial_bases(e: se.Expr) -> list[tuple[str, se.Expr]]:
    """Each ``(function, base)`` in ``e`` where it is partial: ``sqrt``, ``division`` or
    ``power`` (a fractional power's base), ``log`` (its argument)."""
    found = []
    for p in e.atoms(se.Pow):
        base, exponent = p.args
        if not (exponent.is_Integer and int(exponent) >= 0):
            found.append(("sqrt" if exponent == se.Rational(1, 2) else "division" if exponent.is_Integer
                          else "power", base))
    found.extend(("log", f.args[0]) for f in e.atoms(se.log))
    return found


_USES = {"sqrt": "sqrt({b})", "division": "1 / ({b})", "power": "a fractional power of ({b})", "log": "log({b})"}
_GUARDED = {
    "sqrt": "sqrt({b} + eps**2) where {b} >= 0 holds (eps: the error you accept)",
    "division": "({b}) / (({b})**2 + eps**2) for 1 / ({b})",
    "power": "a power of ({b})**2 + eps**2",
    "log": "log({b} + eps) where {b} >= 0 holds, or log of a sum of exponentials",
}


def partial_warnings(where: str, kernel: Kernel, params: tuple[Param, ...]) -> list[str]:
    """A warning for each base of a partial function in ``kernel`` (the rows and their
    intermediates) that is not provably non-negative."""
    signs = _Signs(kernel, params)
    seen: set[se.Expr] = set()
    warnings = []
    exprs = [d.expr for d in kernel.definitions if isinstance(d, Let)]
    exprs += [x for d in kernel.definitions if isinstance(d, RuntimeMax) for x in d.exprs]
    exprs += [x for o in kernel.outputs for x in o.exprs]
    for e in exprs:
        for what, base in _partial_bases(e):
            if base in seen or signs.of(base) > 0:
                continue
            seen.add(base)
            b = signs.lets.get(base, base) if base.is_Symbol else base
            warnings.append(f"{where}: h uses {_USES[what].format(b=b)}, and {b} is not provably >= 0: where it "
                            "reaches 0 (or below) the row or its derivatives are not finite and the filter falls "
                            f"back, flagged. Write {_GUARDED[what].format(b=b)}, use a parameter declared "
                            "Positive, or keep it if the state cannot get there")
    return warnings
