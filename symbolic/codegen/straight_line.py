"""A kernel as straight-line code, in no target language.

All outputs of a kernel (value, gradient, Hessian, ...) go through a single
``symengine.cse`` pass, so work is shared between them. Statements are then ordered on
demand, depth first from the outputs, so every temporary, ``let`` and runtime max is
computed exactly once and only if something needs it. A backend prints the steps in
order; nothing here knows a target language.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import symengine as se

from ..kernel import Kernel


@dataclass(frozen=True)
class Step:
    """One assignment: ``symbol`` from ``rhs``. ``kind`` is ``"let"`` (a named
    intermediate of the spec), ``"max"`` (a runtime max over ``rhs``) or ``"tmp"`` (a
    common subexpression)."""

    symbol: se.Symbol
    kind: str
    rhs: Sequence[se.Expr]


@dataclass(frozen=True)
class StraightLine:
    """The steps in evaluation order, every output expression (the kernel's outputs
    flattened in order, in terms of the steps' symbols) and the input symbols read."""

    steps: list[Step]
    outputs: list[se.Expr]
    used_inputs: set[se.Symbol]


def straight_line(kernel: Kernel) -> StraightLine:
    """``kernel`` after one CSE pass, its statements ordered depth first from the outputs."""
    flat: list[se.Expr] = [let.expr for let in kernel.lets]
    for red in kernel.reductions:
        flat.extend(red.exprs)
    for out in kernel.outputs:
        flat.extend(out.exprs)
    replacements, reduced = se.cse(flat)

    # Every symbol the body may define, with the expression(s) defining it, and the order
    # in which dependencies are visited (so the result does not depend on hashing).
    defs: dict[se.Symbol, tuple[str, Sequence[se.Expr]]] = {}
    pos = 0
    for let in kernel.lets:
        defs[let.symbol] = ("let", [reduced[pos]])
        pos += 1
    for red in kernel.reductions:
        defs[red.symbol] = ("max", reduced[pos:pos + len(red.exprs)])
        pos += len(red.exprs)
    outputs = list(reduced[pos:])
    for sym, rhs in replacements:
        defs[sym] = ("tmp", [rhs])
    order = {sym: i for i, sym in enumerate([let.symbol for let in kernel.lets]
                                            + [r.symbol for r in kernel.reductions]
                                            + [s for s, _ in replacements])}

    steps: list[Step] = []
    done: set = set()
    used_inputs: set = set()

    def visit(expr: se.Expr) -> None:
        for sym in sorted(expr.free_symbols, key=lambda s: order.get(s, -1)):
            if sym not in defs:
                used_inputs.add(sym)
            elif sym not in done:
                done.add(sym)
                kind, rhs = defs[sym]
                for r in rhs:
                    visit(r)
                steps.append(Step(sym, kind, rhs))

    for e in outputs:
        visit(e)
    return StraightLine(steps, outputs, used_inputs)
