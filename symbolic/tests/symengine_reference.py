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
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from decimal import Decimal

import numpy as np
import symengine as se

from symbolic.kernel import Kernel, Let

Values = Mapping[str, float | Sequence[float] | np.ndarray]


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
            self._steps.append((isinstance(d, Let), reads, se.Lambdify([known[i] for i in reads], exprs)))
            column[d.symbol] = len(known)
            known.append(d.symbol)
        self._outputs = se.Lambdify(known, [e for out in kernel.outputs for e in out.exprs], cse=True)
        self._splits = np.cumsum([len(out.exprs) for out in kernel.outputs])[:-1]
        self._cse = None

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
        for k, (is_let, reads, f) in enumerate(self._steps):
            r = np.asarray(f(v[:, reads]), dtype=float).reshape(n, -1)
            v[:, given + k] = r[:, 0] if is_let else r.max(axis=1)
        flat = np.asarray(self._outputs(v), dtype=float).reshape(n, -1)
        return {out.name: part for out, part in
                zip(self.kernel.outputs, np.split(flat, self._splits, axis=1), strict=False)}

    def high_precision(self, values: Values, bits: int = 256) -> dict[str, np.ndarray]:
        """The same outputs computed in ``bits``-bit MPFR arithmetic from the exact double
        inputs (and the model's double constants, taken exactly): the truth that tells a
        well-conditioned value from a cancelling one. Slow; for a few samples."""
        if self._cse is None:
            self._cse = se.cse([e for out in self.kernel.outputs for e in out.exprs])
        exact = lambda v: se.RealMPFR(str(Decimal(float(v))), bits)  # noqa: E731
        symbols = [s for inp in self.kernel.inputs for s in inp.symbols]
        subs = {s: exact(v) for s, v in zip(symbols, self.flat_inputs(values), strict=False)}
        for d in self.kernel.definitions:
            if isinstance(d, Let):
                subs[d.symbol] = d.expr.xreplace(subs)
            else:
                subs[d.symbol] = max((e.xreplace(subs) for e in d.exprs), key=float)
        replacements, reduced = self._cse
        for sym, expr in replacements:
            subs[sym] = expr.xreplace(subs)
        flat = np.array([float(e.xreplace(subs)) for e in reduced])
        return {out.name: part for out, part in zip(self.kernel.outputs, np.split(flat, self._splits), strict=False)}
