"""A kernel: one straight-line function from named inputs to named outputs.

A family (SSAT, joint limits, ...) builds a :class:`Kernel` out of SymEngine
expressions; the emitter turns it into Rust. The kernel is also the symbolic truth the
tests evaluate numerically, so it keeps every definition it was built from.

Three kinds of named intermediate exist besides inputs and outputs:

* ``let_`` - a value computed once from inputs (e.g. the relative pose of two boxes).
  Later expressions use its symbol as an atom, which keeps them small and lets the
  family differentiate with respect to it and apply the chain rule itself.
* ``runtime_max`` - max() over expressions, evaluated numerically at run time. Used
  only where the result does not change the outputs mathematically (the overflow shift
  of a log-sum-exp), so derivatives may treat it as a constant.
* generated constants - integer tables such as the input columns a row touches.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import symengine as se

_IDENT = re.compile(r"^[a-z][a-z0-9_]*$")
# SymEngine's cse() names its temporaries x0, x1, ...; inputs must not look like those.
_CSE_TEMP = re.compile(r"^x\d+$")


@dataclass(frozen=True)
class Input:
    name: str
    symbols: tuple[se.Symbol, ...]
    is_array: bool
    doc: str
    # A parameter's shape, ``(n,)`` or ``(rows, cols)``: the argument is then the nalgebra
    # vector or matrix the generated ``Params`` hold (its symbols row by row); ``None`` for
    # a plain array (the state).
    shape: tuple[int, ...] | None = None


@dataclass(frozen=True)
class Let:
    symbol: se.Symbol
    expr: se.Expr


@dataclass(frozen=True)
class RuntimeMax:
    symbol: se.Symbol
    exprs: tuple[se.Expr, ...]


@dataclass(frozen=True)
class Output:
    """``kind`` is ``scalar``, ``vector`` (length dim), ``symmetric`` (dim x dim, from the
    upper triangle: ``exprs`` holds it row by row) or ``matrix`` (dim rows of ``cols``,
    row-major)."""

    name: str
    kind: str
    exprs: tuple[se.Expr, ...]
    dim: int
    doc: str
    cols: int = 1


@dataclass(frozen=True)
class Constant:
    name: str
    rust_type: str
    value: str
    doc: str


def symmetric_upper(matrix: Sequence[Sequence[se.Expr]]) -> tuple[se.Expr, ...]:
    n = len(matrix)
    return tuple(matrix[i][j] for i in range(n) for j in range(i, n))


@dataclass
class Kernel:
    name: str
    doc: str
    inputs: list[Input] = field(default_factory=list)
    lets: list[Let] = field(default_factory=list)
    reductions: list[RuntimeMax] = field(default_factory=list)
    outputs: list[Output] = field(default_factory=list)
    constants: list[Constant] = field(default_factory=list)
    # Lets and runtime maxima interleave (a max over lets, lets over that max), so their
    # declaration order is the evaluation order.
    definitions: list[Let | RuntimeMax] = field(default_factory=list)
    _names: set = field(default_factory=set)

    def _claim(self, name: str) -> str:
        if not _IDENT.match(name) or _CSE_TEMP.match(name):
            raise ValueError(f"kernel {self.name}: '{name}' is not a usable identifier")
        if name in self._names:
            raise ValueError(f"kernel {self.name}: name '{name}' used twice")
        self._names.add(name)
        return name

    # ----------------------------------------------------------------- inputs
    def scalar_input(self, name: str, doc: str) -> se.Symbol:
        sym = se.Symbol(self._claim(name))
        self.inputs.append(Input(name, (sym,), False, doc))
        return sym

    def array_input(self, name: str, components: Sequence[str], doc: str,
                    shape: tuple[int, ...] | None = None) -> list[se.Symbol]:
        """An ``&[f64; n]`` argument, or with ``shape`` a parameter's nalgebra vector or
        matrix (components row by row); component ``c`` becomes the local ``{name}_{c}``."""
        self._claim(name)
        syms = tuple(se.Symbol(self._claim(f"{name}_{c}")) for c in components)
        if shape is not None and math.prod(shape) != len(syms):
            raise ValueError(f"kernel {self.name}: '{name}' has {len(syms)} components, not shape {shape}")
        self.inputs.append(Input(name, syms, True, doc, shape))
        return list(syms)

    # ---------------------------------------------------------- intermediates
    def let_(self, name: str, expr: se.Expr) -> se.Symbol:
        sym = se.Symbol(self._claim(name))
        self.lets.append(Let(sym, se.sympify(expr)))
        self.definitions.append(self.lets[-1])
        return sym

    def runtime_max(self, name: str, exprs: Sequence[se.Expr]) -> se.Symbol:
        if not exprs:
            raise ValueError(f"kernel {self.name}: runtime_max '{name}' over nothing")
        sym = se.Symbol(self._claim(name))
        self.reductions.append(RuntimeMax(sym, tuple(se.sympify(e) for e in exprs)))
        self.definitions.append(self.reductions[-1])
        return sym

    # ---------------------------------------------------------------- outputs
    def output_scalar(self, name: str, expr: se.Expr, doc: str) -> None:
        self.outputs.append(Output(self._claim(name), "scalar", (se.sympify(expr),), 1, doc))

    def output_vector(self, name: str, exprs: Sequence[se.Expr], doc: str) -> None:
        exprs = tuple(se.sympify(e) for e in exprs)
        self.outputs.append(Output(self._claim(name), "vector", exprs, len(exprs), doc))

    def output_symmetric(self, name: str, matrix: Sequence[Sequence[se.Expr]], doc: str) -> None:
        n = len(matrix)
        if any(len(row) != n for row in matrix):
            raise ValueError(f"kernel {self.name}: '{name}' is not square")
        upper = tuple(se.sympify(e) for e in symmetric_upper(matrix))
        self.outputs.append(Output(self._claim(name), "symmetric", upper, n, doc))

    def output_matrix(self, name: str, rows: Sequence[Sequence[se.Expr]], doc: str) -> None:
        cols = len(rows[0]) if rows else 0
        if not rows or any(len(r) != cols for r in rows):
            raise ValueError(f"kernel {self.name}: '{name}' rows differ in length")
        flat = tuple(se.sympify(e) for r in rows for e in r)
        self.outputs.append(Output(self._claim(name), "matrix", flat, len(rows), doc, cols))

    def constant(self, name: str, rust_type: str, value: str, doc: str) -> None:
        self.constants.append(Constant(name, rust_type, value, doc))

    # ------------------------------------------------------------- evaluation
    def evaluate(self, values: dict[str, float | Sequence[float]]) -> dict[str, list[float]]:
        """Evaluate the kernel's definitions with SymEngine, independently of any
        emitted code: the reference the cross-validation tests compare Rust against.

        ``values`` maps each input name to a float or a sequence of floats.
        """
        subs: dict[se.Symbol, se.Expr] = {}
        for inp in self.inputs:
            given = values[inp.name]
            seq = list(given) if inp.is_array else [given]
            if len(seq) != len(inp.symbols):
                raise ValueError(f"input {inp.name}: expected {len(inp.symbols)} values")
            for sym, v in zip(inp.symbols, seq, strict=False):
                subs[sym] = se.RealDouble(float(v))
        for d in self.definitions:
            if isinstance(d, Let):
                subs[d.symbol] = se.RealDouble(float(d.expr.xreplace(subs)))
            else:
                subs[d.symbol] = se.RealDouble(max(float(e.xreplace(subs)) for e in d.exprs))
        return {
            out.name: [float(e.xreplace(subs)) for e in out.exprs] for out in self.outputs
        }


def gradient(expr: se.Expr, wrt: Sequence[se.Symbol]) -> list[se.Expr]:
    return [se.diff(expr, v) for v in wrt]


def hessian(expr: se.Expr, wrt: Sequence[se.Symbol]) -> list[list[se.Expr]]:
    """Full symmetric Hessian; the lower triangle reuses the upper one's expressions."""
    grad = gradient(expr, wrt)
    n = len(wrt)
    upper: dict[tuple[int, int], se.Expr] = {}
    for i in range(n):
        for j in range(i, n):
            upper[(i, j)] = se.diff(grad[i], wrt[j])
    return [[upper[(min(i, j), max(i, j))] for j in range(n)] for i in range(n)]


def chain_linear(
    grad_inner: Sequence[se.Expr],
    hess_inner: Sequence[Sequence[se.Expr]] | None,
    jacobian: Sequence[Sequence[se.Expr]],
) -> tuple[list[se.Expr], list[list[se.Expr]] | None]:
    """Gradient and Hessian with respect to z when the inner variables are u = J z + c
    with J constant: grad_z = J^T grad_u and H_z = J^T H_u J."""
    rows, cols = len(jacobian), len(jacobian[0])
    grad = [se.Add(*[jacobian[k][i] * grad_inner[k] for k in range(rows)]) for i in range(cols)]
    if hess_inner is None:
        return grad, None
    hj = [[se.Add(*[hess_inner[k][m] * jacobian[m][j] for m in range(rows)])
           for j in range(cols)] for k in range(rows)]
    hess_upper = {}
    for i in range(cols):
        for j in range(i, cols):
            hess_upper[(i, j)] = se.Add(*[jacobian[k][i] * hj[k][j] for k in range(rows)])
    hess = [[hess_upper[(min(i, j), max(i, j))] for j in range(cols)] for i in range(cols)]
    return grad, hess
