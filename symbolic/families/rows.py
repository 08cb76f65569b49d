"""One kernel of ECBF rows: the shared builder of every constraint family.

A family gives the state layout, the control-affine field (f, g) and a ``build`` that
declares its runtime inputs and returns named rows h. The builder differentiates each
row to its relative degree with :class:`~symbolic.lie.LieEngine` and emits, per row,
``lie = [h, L_f h, ..., L_f^r h]`` and ``lg_lf = L_g L_f^(r-1) h`` on the input columns
listed in the kernel's ``*_INPUT_COLUMNS`` constant.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, replace

import symengine as se

from ..kernel import Kernel
from ..lie import LieEngine

RowBuilder = Callable[[Kernel, LieEngine], list[tuple[str, se.Expr]]]


def rust_str_array(items) -> str:
    return "[" + ", ".join(f'"{i}"' for i in items) + "]"


@dataclass(frozen=True)
class RowKernel:
    """A row kernel with what was found building it."""

    kernel: Kernel
    degree: int
    columns: tuple[int, ...]
    row_names: tuple[str, ...]
    row_columns: tuple[tuple[int, ...], ...]  # per row: the columns its L_g L_f^(r-1) h can touch


def row_kernel(name: str, doc: str, state_names: Sequence[str], x: Sequence[se.Symbol],
               f: Sequence[se.Expr], g: Sequence[Sequence[se.Expr]], build: RowBuilder,
               time_input: tuple[str, str] | None = None) -> Kernel:
    """``time_input = (name, doc)`` makes the rows time-varying: a scalar input t that the
    engine differentiates as a clock (t' = 1), so L_f^k h include the dh/dt terms."""
    return build_row_kernel(name, doc, state_names, x, f, g, build, time_input).kernel


def build_row_kernel(name: str, doc: str, state_names: Sequence[str], x: Sequence[se.Symbol],
                     f: Sequence[se.Expr], g: Sequence[Sequence[se.Expr]], build: RowBuilder,
                     time_input: tuple[str, str] | None = None) -> RowKernel:
    """:func:`row_kernel`, also returning the degree, input columns and row names."""
    k = Kernel(name, doc)
    k.array_input("x", state_names, "state, laid out as `STATE_NAMES`")
    time = k.scalar_input(*time_input) if time_input else None
    engine = LieEngine(k, x, f, g, time=time)
    return finish_row_kernel(k, engine, build(k, engine))


def finish_row_kernel(k: Kernel, engine: LieEngine, rows: Sequence[tuple[str, se.Expr]],
                      columns_possible: Collection[int] | None = None) -> RowKernel:
    """Differentiate ``rows`` along ``engine``'s field into ``k``'s outputs and constants;
    ``columns_possible``, when given, are the only input columns that can be non-zero (the
    others are zero to rounding: dropped)."""
    name = k.name
    lie = [engine.row(h, f"{name}.{row}") for row, h in rows]
    if columns_possible is not None:
        lie = [replace(r, lg={u: e for u, e in r.lg.items() if u in columns_possible}) for r in lie]
    degrees = {r.degree for r in lie}
    if len(degrees) != 1:
        raise ValueError(f"{name}: rows of one kernel must share a relative degree, got {degrees}")
    degree = degrees.pop()
    columns = sorted(set().union(*(r.lg for r in lie)))
    upper = name.upper()
    k.constant(f"{upper}_RELATIVE_DEGREE", "usize", str(degree),
               f"Relative degree of every row of [`{name}`] (found symbolically).")
    k.constant(f"{upper}_INPUT_COLUMNS", f"[usize; {len(columns)}]", str(columns),
               f"Input columns of `lg_lf` in [`{name}`]: the only inputs its rows depend on.")
    k.constant(f"{upper}_ROW_NAMES", f"[&str; {len(rows)}]", rust_str_array(r for r, _ in rows),
               f"What each row of [`{name}`] constrains.")
    k.output_matrix("lie", [list(r.lf) for r in lie], "per row: h, L_f h, ..., L_f^r h")
    k.output_matrix("lg_lf", [[r.lg.get(u, se.Integer(0)) for u in columns] for r in lie],
                    f"per row: L_g L_f^(r-1) h on the columns `{upper}_INPUT_COLUMNS`")
    return RowKernel(k, degree, tuple(columns), tuple(r for r, _ in rows), tuple(tuple(sorted(r.lg)) for r in lie))
