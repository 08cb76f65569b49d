"""A kernel as straight-line code, in no target language.

All outputs of a kernel (value, gradient, Hessian, ...) go through a single
``symengine.cse`` pass, so work is shared between them. Statements are then ordered on
demand, depth first from the outputs, so every temporary, ``let`` and runtime max is
computed exactly once and only if something needs it. A backend prints the steps in
order; nothing here knows a target language.

Transcendental calls (``exp``, ``tanh``, ``log``) are gathered into batches the runtime
evaluates in SIMD lanes: the calls of one function whose arguments need the same number
of earlier transcendental calls (the SSAT value's 24 ``tanh`` at depth 1, its 15 ``exp`` at
depth 2) become one ``"lanes"`` step, computed once all their arguments are.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import symengine as se

from ..kernel import Kernel

# The functions the runtime evaluates in lanes, by SymEngine's name for them.
LANE_FUNCTIONS = ("exp", "tanh", "log")


@dataclass(frozen=True)
class Step:
    """One assignment: ``symbol`` from ``rhs``. ``kind`` is ``"let"`` (a named
    intermediate of the spec), ``"max"`` (a runtime max over ``rhs``), ``"tmp"`` (a
    common subexpression) or ``"lanes"``: ``symbols[i] = function(rhs[i])`` for every
    ``i``, one batched call (``symbol`` is ``symbols[0]``)."""

    symbol: se.Symbol
    kind: str
    rhs: Sequence[se.Expr]
    function: str = ""
    symbols: tuple[se.Symbol, ...] = ()


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
    batches = _gather_lanes(defs, order, outputs)
    order.update({sym: len(order) + i for i, sym in enumerate(batches)})

    steps: list[Step] = []
    done: set = set()
    used_inputs: set = set()

    def visit(expr: se.Expr) -> None:
        for sym in sorted(expr.free_symbols, key=lambda s: order.get(s, -1)):
            if sym in done:
                continue
            if sym in batches:
                function, symbols, args = batches[sym]
                done.update(symbols)
                for a in args:
                    visit(a)
                steps.append(Step(symbols[0], "lanes", args, function, symbols))
            elif sym not in defs:
                used_inputs.add(sym)
            else:
                done.add(sym)
                kind, rhs = defs[sym]
                for r in rhs:
                    visit(r)
                steps.append(Step(sym, kind, rhs))

    for e in outputs:
        visit(e)
    return StraightLine(steps, outputs, used_inputs)


def _lane_call(e: se.Expr) -> tuple[str, se.Expr] | None:
    """``(function, argument)`` if ``e`` is a call the runtime batches, else None."""
    if isinstance(e, se.Pow) and e.args[0] == se.E:
        return "exp", e.args[1]
    name = type(e).__name__
    if name in LANE_FUNCTIONS and len(e.args) == 1:
        return name, e.args[0]
    return None


def _gather_lanes(defs: dict, order: dict, outputs: list[se.Expr]
                  ) -> dict[se.Symbol, tuple[str, tuple[se.Symbol, ...], list[se.Expr]]]:
    """Replace every batched call in ``defs`` and ``outputs`` (in place) by a new symbol,
    and group the calls by function and depth (how many batched calls deep their argument
    is). Returns, for each new symbol, its group: ``(function, symbols, arguments)``.
    Deterministic: symbols are numbered in the order the calls are met, definitions in
    ``order`` first, then the outputs."""
    calls: dict[tuple[str, se.Expr], se.Symbol] = {}
    call_args: dict[se.Symbol, tuple[str, se.Expr]] = {}
    rebuilt: dict[se.Expr, se.Expr] = {}

    def rebuild(e: se.Expr) -> se.Expr:
        if not e.args or not e.free_symbols:
            return e  # atoms, and constant calls such as ln(15), which print as literals
        hit = rebuilt.get(e)
        if hit is not None:
            return hit
        original = e.args
        args = [rebuild(a) for a in original]
        call = _lane_call(e)
        if call is not None:
            function = call[0]
            argument = args[1] if function == "exp" else args[0]
            key = (function, argument)
            out = calls.get(key)
            if out is None:
                out = se.Symbol(f"_lane{len(calls)}")
                calls[key] = out
                call_args[out] = key
        elif any(a is not b for a, b in zip(args, original, strict=True)):
            out = e.func(*args)
        else:
            out = e
        rebuilt[e] = out
        return out

    for sym in sorted(defs, key=lambda s: order.get(s, -1)):
        kind, rhs = defs[sym]
        defs[sym] = (kind, [rebuild(r) for r in rhs])
    outputs[:] = [rebuild(e) for e in outputs]
    if not calls:
        return {}

    depth: dict[se.Symbol, int] = {}

    def depth_of(sym: se.Symbol) -> int:
        # Iterative over the definitions' symbols: kernels nest thousands deep.
        stack = [sym]
        while stack:
            top = stack[-1]
            if top in depth:
                stack.pop()
                continue
            exprs = [call_args[top][1]] if top in call_args else defs[top][1] if top in defs else []
            pending = [s for e in exprs for s in e.free_symbols
                       if (s in defs or s in call_args) and s not in depth]
            if pending:
                stack.extend(pending)
                continue
            below = max((depth[s] for e in exprs for s in e.free_symbols if s in depth), default=0)
            depth[top] = below + (1 if top in call_args else 0)
            stack.pop()
        return depth[sym]

    groups: dict[tuple[str, int], list[se.Symbol]] = {}
    for sym in call_args:  # in the order the calls were met
        groups.setdefault((call_args[sym][0], depth_of(sym)), []).append(sym)
    batches = {}
    for (function, _), symbols in groups.items():
        group = (function, tuple(symbols), [call_args[s][1] for s in symbols])
        for s in symbols:
            batches[s] = group
    return batches


@dataclass(frozen=True)
class SplitLine:
    """A kernel's straight line cut in two for a family evaluated at many instances per
    state: ``state_steps`` read only the per-cycle inputs (the state, the time) and run once
    per cycle; ``instance_steps`` read an instance's parameters and run once per instance,
    from the ``interface`` values of the first part (state-part symbols and per-cycle input
    components, in the order the first part returns them)."""

    state_steps: list[Step]
    interface: list[se.Symbol]
    instance_steps: list[Step]
    outputs: list[se.Expr]
    state_inputs_used: set[se.Symbol]
    instance_inputs_used: set[se.Symbol]


def split(code: StraightLine, per_cycle: Sequence[se.Symbol]) -> SplitLine:
    """``code`` cut where its values start to depend on anything but ``per_cycle`` inputs.
    A batch of lane calls whose arguments fall on both sides becomes two batches (every
    lane width gives the same bits, so the results do not change)."""
    on_state = set(per_cycle)
    state_steps: list[Step] = []
    instance_steps: list[Step] = []

    def is_state(e: se.Expr) -> bool:
        return all(s in on_state for s in e.free_symbols)

    for step in code.steps:
        if step.kind == "lanes":
            sides = [is_state(a) for a in step.rhs]
            for side, target in ((True, state_steps), (False, instance_steps)):
                chosen = [i for i, s in enumerate(sides) if s == side]
                if not chosen:
                    continue
                symbols = tuple(step.symbols[i] for i in chosen)
                target.append(Step(symbols[0], "lanes", [step.rhs[i] for i in chosen], step.function, symbols))
                if side:
                    on_state.update(symbols)
        elif all(is_state(r) for r in step.rhs):
            state_steps.append(step)
            on_state.add(step.symbol)
        else:
            instance_steps.append(step)
    read_later: set[se.Symbol] = set()
    for step in instance_steps:
        for r in step.rhs:
            read_later |= r.free_symbols
    for e in code.outputs:
        read_later |= e.free_symbols
    inputs = [s for s in per_cycle if s in read_later]
    defined = [s for step in state_steps for s in (step.symbols or (step.symbol,)) if s in read_later]
    state_reads: set[se.Symbol] = set()
    for step in state_steps:
        for r in step.rhs:
            state_reads |= r.free_symbols
    per_cycle_set = set(per_cycle)
    return SplitLine(state_steps, inputs + defined, instance_steps, code.outputs,
                     (state_reads & per_cycle_set) | (set(inputs)),
                     {s for s in read_later if s not in on_state and s in code.used_inputs})
