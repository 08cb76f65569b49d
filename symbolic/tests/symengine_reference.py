"""A kernel's definitions evaluated numerically by SymEngine, fast enough for thousands
of samples.

:meth:`symbolic.kernel.Kernel.evaluate` substitutes values into every expression, which
takes tens of milliseconds for the larger kernels. This compiles each definition (let,
runtime maximum, outputs) once with ``symengine.Lambdify`` and evaluates them in the
kernel's declaration order. It evaluates the same expressions the generator hands to
the emitter, through SymEngine's own numeric visitor: no generated code is involved.
The outputs are compiled with SymEngine's CSE (``cse=True``) because some are DAGs far
larger as trees (an x tanh(x) Hessian takes minutes to compile without it); the
emitter's own CSE pass, its Rust text and the compiler are what this checks.

Before that, the outputs' equal subexpressions are made one object (:func:`interned`):
outputs often hold separate, equal copies of their common parts, which SymEngine's CSE
compares node by node wherever it meets them: 80 s for ANYmal's mass matrix, 0.3 s
interned. Interning rebuilds each node from its own arguments and checks it against the
original's structural hash: the expressions SymEngine evaluates are the same.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from decimal import Decimal

import numpy as np
import symengine as se

from symbolic.kernel import Kernel, Let

Values = Mapping[str, float | Sequence[float] | np.ndarray]

# SymEngine's closure backend. The LLVM one (Lambdify's default where the wheel has it)
# takes milliseconds to compile each function: seconds for a kernel of a thousand lets,
# or for ANYmal's mass matrix, against a few hundred milliseconds evaluating 500 samples.
BACKEND = "lambda"


def interned(exprs: Sequence[se.Basic]) -> list[se.Basic]:
    """``exprs`` rebuilt so that structurally equal subexpressions are one object.

    Nodes are identified bottom-up by their type, structural hash and the identities of
    their arguments (unordered for sums and products), so no two copies are ever compared
    node by node; each distinct node is rebuilt once, from its already rebuilt arguments.
    """
    node_of: dict[tuple, se.Basic] = {}  # (type, hash, argument identities) -> the rebuilt node
    identity: dict[int, int] = {}  # id(rebuilt node) -> its identity (node_of keeps it alive)
    out = []
    for root in exprs:
        # Within one expression, its repeated nodes are shared objects: cheap to compare.
        rebuilt: dict[se.Basic, se.Basic] = {}
        stack: list[tuple[se.Basic, tuple | None]] = [(root, None)]
        while stack:
            e, args = stack.pop()
            if e in rebuilt:
                continue
            if args is None:
                args = e.args
                if args:  # its arguments first
                    stack.append((e, args))
                    stack.extend((a, None) for a in args)
                    continue
            kids = [rebuilt[a] for a in args]
            ids = tuple(identity[id(k)] for k in kids)
            key = (type(e), hash(e), tuple(sorted(ids)) if isinstance(e, (se.Add, se.Mul)) else ids) if args else (e,)
            node = node_of.get(key)
            if node is None:
                node = node_of[key] = rebuild(e, kids) if args else e
                identity[id(node)] = len(identity)
            rebuilt[e] = node
        out.append(rebuilt[root])
    return out


def rebuild(e: se.Basic, args: Sequence[se.Basic]) -> se.Basic:
    """``e`` with ``args`` (equal to its own) as its arguments; checked by structural hash."""
    node = e.func(*args)
    if hash(node) != hash(e) and isinstance(e, se.Add):
        # A sum's args leave out a constant term that is a floating-point zero (0.0 + x).
        node = se.Add(e.as_coefficients_dict()[se.Integer(1)], *args)
    assert hash(node) == hash(e), f"rebuilding a {type(e).__name__} changed it"
    return node


class SymEngineReference:
    def __init__(self, kernel: Kernel):
        self.kernel = kernel
        known: list[se.Symbol] = [s for inp in kernel.inputs for s in inp.symbols]
        column = {s: i for i, s in enumerate(known)}
        # Each definition as a function of the columns it reads (its free symbols), so a
        # batch gathers a few columns per step rather than copying all that came before.
        self._steps = []
        for d in kernel.definitions:
            exprs = [d.expr] if isinstance(d, Let) else list(d.exprs)
            reads = sorted({column[s] for e in exprs for s in e.free_symbols if s in column})
            # (Lambdify takes no zero-argument function: a constant reads column 0 unused.)
            reads = reads or [0]
            f = se.Lambdify([known[i] for i in reads], exprs, backend=BACKEND)
            self._steps.append((d, [known[i] for i in reads], reads, f))
            column[d.symbol] = len(known)
            known.append(d.symbol)
        outputs = interned([e for out in self.kernel.outputs for e in out.exprs])
        self._outputs = se.Lambdify(known, outputs, cse=True, backend=BACKEND)
        # All outputs as the arguments of one function call, so that one substitution
        # evaluates each shared node once (SymEngine's xreplace remembers what it visited).
        self._all_outputs = se.Function("outputs")(*outputs)
        self._splits = np.cumsum([len(out.exprs) for out in kernel.outputs])[:-1]

    def flat_inputs(self, values: Values) -> list[float]:
        flat: list[float] = []
        for inp in self.kernel.inputs:
            v = np.asarray(values[inp.name], dtype=float).ravel()
            if v.size != len(inp.symbols):
                raise ValueError(f"{self.kernel.name}.{inp.name}: expected {len(inp.symbols)} values")
            flat.extend(v.tolist())
        return flat

    def __call__(self, values: Values) -> dict[str, np.ndarray]:
        """Output name -> its values (flat, in the kernel's output layout)."""
        return {name: part[0] for name, part in self.batch([values]).items()}

    def batch(self, samples: Sequence[Values]) -> dict[str, np.ndarray]:
        """Output name -> its values for every sample (samples x flat values). Each
        definition is evaluated once over all samples (Lambdify broadcasts over leading
        axes): a kernel of a thousand lets costs a thousand calls, not a thousand per sample."""
        n, given = len(samples), sum(len(inp.symbols) for inp in self.kernel.inputs)
        v = np.empty((n, given + len(self._steps)))
        v[:, :given] = np.array([self.flat_inputs(values) for values in samples], dtype=float).reshape(n, given)
        for k, (d, _, reads, f) in enumerate(self._steps):
            r = np.asarray(f(v[:, reads]), dtype=float).reshape(n, -1)
            v[:, given + k] = r[:, 0] if isinstance(d, Let) else r.max(axis=1)
        flat = np.asarray(self._outputs(v), dtype=float).reshape(n, -1)
        return {out.name: part for out, part in
                zip(self.kernel.outputs, np.split(flat, self._splits, axis=1), strict=False)}

    def high_precision(self, values: Values, bits: int = 256) -> dict[str, np.ndarray]:
        """The same outputs computed in ``bits``-bit MPFR arithmetic from the exact double
        inputs (and the model's double constants, taken exactly): the truth that tells a
        well-conditioned value from a cancelling one. Slow; for a few samples."""
        exact = lambda v: se.RealMPFR(str(Decimal(float(v))), bits)  # noqa: E731
        symbols = [s for inp in self.kernel.inputs for s in inp.symbols]
        subs = {s: exact(v) for s, v in zip(symbols, self.flat_inputs(values), strict=False)}
        for d, reads, _, _ in self._steps:
            read = {s: subs[s] for s in reads}
            if isinstance(d, Let):
                subs[d.symbol] = d.expr.xreplace(read)
            else:
                subs[d.symbol] = max((e.xreplace(read) for e in d.exprs), key=float)
        flat = np.array([float(e) for e in self._all_outputs.xreplace(subs).args])
        return {out.name: part for out, part in zip(self.kernel.outputs, np.split(flat, self._splits), strict=False)}
