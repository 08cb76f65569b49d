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
        self._steps = []
        for d in kernel.definitions:
            exprs = [d.expr] if isinstance(d, Let) else list(d.exprs)
            self._steps.append((isinstance(d, Let), se.Lambdify(list(known), exprs)))
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
        v = self.flat_inputs(values)
        for is_let, f in self._steps:
            r = np.asarray(f(v), dtype=float).ravel()
            v.append(float(r[0]) if is_let else float(r.max()))
        flat = np.asarray(self._outputs(v), dtype=float).ravel()
        return {out.name: part for out, part in zip(self.kernel.outputs, np.split(flat, self._splits), strict=False)}

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
