"""Print a :class:`~symbolic.kernel.Kernel` as one straight-line Rust function.

The statements and their order come from the language-neutral
:func:`~symbolic.codegen.straight_line.straight_line`; this module prints them
(:class:`RustPrinter` for expressions): arithmetic on any ``cbfgen::scalar::Scalar`` ``S``
(the filter's ``f64``, the sampled-data certificate's intervals), no loops, no heap,
constants as ``S::from(..)``, integer powers as products, ``sqrt`` for half powers, and
``exp``/``tanh``/``ln`` through the runtime's ``lanes`` (``S::exp_lanes`` and friends:
batched where the straight line batches them, their one-argument forms otherwise), whose
error bounds the certificates count. On ``f64`` every call is the ``f64`` function it
names, so the machine code is that of a kernel written for ``f64``.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

import symengine as se

from ....kernel import Input, Kernel
from ....spec import SpecError
from ...straight_line import StraightLine, split, straight_line

_ADD, _MUL, _UNARY, _ATOM = 1, 2, 3, 4


class OpCount:
    """The operations a printed kernel performs once, by kind, in the order of the core's
    ``cbfgen::ops::OpCount``: the printer counts each operation it writes, so the count is
    the text's (the core's ``Counted`` scalar checks it by running the compiled kernel)."""

    KINDS = ("add", "neg", "mul", "div", "sqrt", "elementary", "lanes", "compare")

    def __init__(self):
        self.counts = dict.fromkeys(self.KINDS, 0)

    def tally(self, kind: str, n: int = 1) -> None:
        self.counts[kind] += n

    def as_list(self) -> list[int]:
        return [self.counts[k] for k in self.KINDS]

_METHODS = {
    "tanh": "tanh", "sinh": "sinh", "cosh": "cosh", "sin": "sin", "cos": "cos",
    "tan": "tan", "asin": "asin", "acos": "acos", "atan": "atan", "log": "ln",
    "Abs": "abs",
}



_BRACKETS = str.maketrans({"[": "\\[", "]": "\\]"})


def rustdoc_text(text: str) -> str:
    """Doc text as rustdoc reads it: square brackets outside code spans are escaped, so
    units such as ``[m]`` or ``[1/s]`` are not taken for intra-doc links."""
    parts = text.split("`")
    return "`".join(part if i % 2 else part.translate(_BRACKETS) for i, part in enumerate(parts))

# Most dependency levels one kernel function may have (its temporaries are bound one
# `let` per level, see `_body`). Each `let` opens a scope nested in the last, and rustc
# (1.95, LLVM 22) recurses once per scope when it writes debug info (any level, even line
# tables): a function of 4 076 single `let`s overflowed its stack here, one of 2 101 did
# not. The deepest built-in kernel has a few hundred levels.
MAX_KERNEL_LEVELS = 2000


def float_literal(value: float) -> str:
    """A Rust f64 literal that round-trips ``value`` exactly."""
    if value != value or value in (float("inf"), float("-inf")):
        raise ValueError(f"non-finite constant {value} in generated code")
    text = repr(float(value))
    if "." not in text and "e" not in text:
        text += ".0"
    return text


def _number(e: se.Expr) -> float:
    if isinstance(e, se.Integer):
        return float(int(e))
    if isinstance(e, se.Rational):
        return float(Fraction(int(e.p), int(e.q)))
    return float(e)


def _is_number(e: se.Expr) -> bool:
    return isinstance(e, (se.Integer, se.Rational, se.RealDouble))


# The generic scalar every emitted kernel computes in (`cbfgen::scalar::Scalar`).
SCALAR = "S"


def constant(value: float) -> str:
    """A constant in a kernel's body: the f64 literal lifted into the kernel's scalar."""
    return f"{SCALAR}::from({float_literal(value)})"


class RustPrinter:
    """Prints SymEngine expressions as Rust expressions on the scalar ``S`` over named
    locals."""

    def __init__(self, names: dict[se.Symbol, str]):
        self.names = names
        self.ops = OpCount()

    def __call__(self, e: se.Expr) -> str:
        return self._p(e)[0]

    def _at(self, e: se.Expr, level: int) -> str:
        text, prec = self._p(e)
        return text if prec >= level else f"({text})"

    def _p(self, e: se.Expr) -> tuple[str, int]:
        if isinstance(e, se.Symbol):
            try:
                return self.names[e], _ATOM
            except KeyError:
                raise ValueError(f"symbol '{e}' has no value in the emitted function") from None
        if _is_number(e) or not e.free_symbols:
            # Numbers, and constant subexpressions such as ln(15), become one literal.
            v = _number(e) if _is_number(e) else float(e.n(53))
            return constant(v), _ATOM
        if isinstance(e, se.Add):
            return self._add(e)
        if isinstance(e, se.Mul):
            return self._mul(e)
        if isinstance(e, se.Pow):
            return self._pow(e.args[0], e.args[1])
        fname = type(e).__name__
        if fname in _METHODS:
            self.ops.tally("compare" if fname == "Abs" else "elementary")
            return f"{self._at(e.args[0], _ATOM)}.{_METHODS[fname]}()", _ATOM
        if fname == "atan2":
            y, x = e.args
            self.ops.tally("elementary")
            return f"{self._at(y, _ATOM)}.atan2({self(x)})", _ATOM
        raise ValueError(f"cannot emit '{fname}' ({e}) as Rust")

    def _add(self, e: se.Expr) -> tuple[str, int]:
        # Sorted for a stable text whatever order SymEngine keeps terms in.
        terms = sorted(e.args, key=lambda t: (_is_number(t), str(t)))
        parts: list[str] = []
        for i, term in enumerate(terms):
            negated = _negated(term)
            if i == 0:
                parts.append(self._at(term, _ADD))
            elif negated is not None:
                parts.append(" - " + self._at(negated, _MUL))
            else:
                parts.append(" + " + self._at(term, _MUL if _is_negative(term) else _ADD))
        self.ops.tally("add", len(terms) - 1)
        return "".join(parts), _ADD

    def _mul(self, e: se.Expr) -> tuple[str, int]:
        coeff = 1.0
        num: list[se.Expr] = []
        den: list[se.Expr] = []
        for f in sorted(e.args, key=str):
            if _is_number(f):
                coeff *= _number(f)
            elif isinstance(f, se.Pow) and _is_number(f.args[1]) and _number(f.args[1]) < 0:
                den.append(se.Pow(f.args[0], -f.args[1]))
            else:
                num.append(f)
        negative = coeff < 0
        coeff = abs(coeff)
        factors = [self._at(f, _UNARY) for f in num]
        if coeff != 1.0 or not factors:
            factors.insert(0, constant(coeff))
        text = " * ".join(factors)
        self.ops.tally("mul", len(factors) - 1)
        if den:
            denominator = (self._at(den[0], _ATOM) if len(den) == 1
                           else "(" + " * ".join(self._at(f, _UNARY) for f in den) + ")")
            text = f"{text} / {denominator}"
            self.ops.tally("div")
            self.ops.tally("mul", len(den) - 1)
        if negative:
            self.ops.tally("neg")
            return "-" + (text if (len(factors) == 1 and not den) else f"({text})"), _UNARY
        return text, (_ATOM if len(factors) == 1 and not den and num else _MUL)

    def _pow(self, base: se.Expr, exp: se.Expr) -> tuple[str, int]:
        if base == se.E:
            self.ops.tally("elementary")
            return f"{self._at(exp, _ATOM)}.exp()", _ATOM
        if isinstance(exp, se.Integer):
            n = int(exp)
            if n < 0:
                self.ops.tally("div")
                return f"{constant(1.0)} / {self._at(se.Pow(base, -n), _ATOM)}", _MUL
            return self._integer_power(base, n)
        if isinstance(exp, se.Rational) and int(exp.q) == 2:
            n = int(exp.p)
            self.ops.tally("sqrt")
            root = f"{self._at(base, _ATOM)}.sqrt()"
            if n == 1:
                return root, _ATOM
            if n == -1:
                self.ops.tally("div")
                return f"{constant(1.0)} / {root}", _MUL
            rest = self._integer_power(base, (abs(n) - 1) // 2)[0]
            text = f"({rest} * {root})"
            self.ops.tally("mul")
            if n < 0:
                self.ops.tally("div")
            return (text, _ATOM) if n > 0 else (f"{constant(1.0)} / {text}", _MUL)
        self.ops.tally("elementary")
        return f"{self._at(base, _ATOM)}.powf({self(exp)})", _ATOM

    def _integer_power(self, base: se.Expr, n: int) -> tuple[str, int]:
        """b^n by repeated squaring; a compound base is bound once in a block."""
        if n == 0:
            return constant(1.0), _ATOM
        if n == 1:
            return self._p(base)
        simple = isinstance(base, se.Symbol)
        # A compound base is printed once, bound in the block below (a symbol costs nothing).
        b = self._at(base, _ATOM) if simple else "pw"
        # Squares as `sqr()`: `x * x` on f64, the square's true range on intervals.
        if n == 2 and simple:
            self.ops.tally("mul")
            return f"{b}.sqr()", _ATOM
        if n == 3 and simple:
            self.ops.tally("mul", 2)
            return f"{b}.sqr() * {b}", _MUL
        steps = [f"let pw = {self(base)};"] if not simple else []
        factors, square, k = [], b, 1
        while n:
            if n & 1:
                factors.append(square)
            n >>= 1
            if n:
                k *= 2
                steps.append(f"let pw{k} = {square}.sqr();")
                self.ops.tally("mul")
                square = f"pw{k}"
        self.ops.tally("mul", len(factors) - 1)
        if not steps:
            return " * ".join(factors), _MUL
        return "{ " + " ".join(steps) + " " + " * ".join(factors) + " }", _ATOM


def _negated(term: se.Expr):
    """-term if term carries a negative numeric coefficient, else None."""
    if _is_number(term) and _number(term) < 0:
        return -term
    if isinstance(term, se.Mul) and any(_is_number(f) and _number(f) < 0 for f in term.args):
        return -term
    return None


def _is_negative(term: se.Expr) -> bool:
    return _negated(term) is not None


# --------------------------------------------------------------------- kernels
def _rust_type(kind: str, dim: int, cols: int, scalar: str = "f64") -> str:
    t = scalar
    return {"scalar": t, "vector": f"[{t}; {dim}]",
            "symmetric": f"[[{t}; {dim}]; {dim}]", "matrix": f"[[{t}; {cols}]; {dim}]"}[kind]


def input_type(inp: Input, runtime_crate: str, scalar: str = "f64") -> str:
    """An argument's Rust type: ``f64``, ``&[f64; n]`` (the state), or a parameter's
    nalgebra vector or matrix, the type the generated ``Params`` hold it in — one
    representation of a rotation (row `i`, column `j` is `R[(i, j)]`) wherever a user
    meets it. ``scalar`` is the number type (``S`` in a generic kernel)."""
    if not inp.is_array:
        return scalar
    if inp.shape is None:
        return f"&[{scalar}; {len(inp.symbols)}]"
    return f"&{runtime_crate}::nalgebra::{nalgebra_type(inp)}<{scalar}, {', '.join(map(str, inp.shape))}>"


def nalgebra_type(inp: Input) -> str:
    """The nalgebra type a shaped parameter is passed as: ``SVector`` or ``SMatrix``."""
    return "SVector" if len(inp.shape) == 1 else "SMatrix"


def input_element(inp: Input, k: int) -> str:
    """Component ``k`` of an array argument (row by row for a matrix)."""
    if inp.shape is not None and len(inp.shape) == 2:
        return f"{inp.name}[({k // inp.shape[1]}, {k % inp.shape[1]})]"
    return f"{inp.name}[{k}]"


def kernel_signature(kernel: Kernel, runtime_crate: str, scalar: str = "f64") -> tuple[str, str]:
    """(argument list, return type) of the kernel's Rust function on ``scalar`` (``f64``:
    the filter's instance; ``S``: the generic function)."""
    args = ", ".join(f"{inp.name}: {input_type(inp, runtime_crate, scalar)}" for inp in kernel.inputs)
    types = [_rust_type(o.kind, o.dim, o.cols, scalar) for o in kernel.outputs]
    return args, types[0] if len(types) == 1 else "(" + ", ".join(types) + ")"


def generic(runtime_crate: str) -> str:
    """The generic parameter list of an emitted kernel."""
    return f"<{SCALAR}: {runtime_crate}::scalar::Scalar>"


def kernel_fn_type(kernel: Kernel, runtime_crate: str) -> str:
    """The kernel's Rust function-pointer type on ``f64``, e.g. ``fn(&[f64; 4]) -> [f64; 4]``."""
    args = ", ".join(input_type(i, runtime_crate) for i in kernel.inputs)
    return f"fn({args}) -> {kernel_signature(kernel, runtime_crate)[1]}"


def _doc_lines(kernel: Kernel) -> list[str]:
    """The kernel's rustdoc: its doc, then its arguments and results."""
    lines = [f"/// {rustdoc_text(line)}".rstrip() for line in kernel.doc.strip().splitlines()]
    lines += ["///", "/// # Arguments"]
    for inp in kernel.inputs:
        comps = ", ".join(str(s) for s in inp.symbols) if inp.is_array else ""
        suffix = f" (components {comps})" if comps else ""
        lines.append(f"/// * `{inp.name}` - {rustdoc_text(inp.doc)}{suffix}")
    lines += ["///", "/// # Returns"]
    lines += [f"/// * `{out.name}` - {rustdoc_text(out.doc)}" for out in kernel.outputs]
    return lines


def _local_names(kernel: Kernel, code: StraightLine) -> dict[se.Symbol, str]:
    """Inputs, lets and maxima keep their spec names; temporaries (batched calls' results
    among them) are t0, t1, ... in order."""
    names = {sym: str(sym) for inp in kernel.inputs for sym in inp.symbols}
    temporaries = 0
    for step in code.steps:
        if step.kind in ("tmp", "lanes"):
            for sym in step.symbols or (step.symbol,):
                names[sym] = f"t{temporaries}"
                temporaries += 1
        else:
            names[step.symbol] = str(step.symbol)
    return names


# The scalar's `lanes` functions, by SymEngine's name.
_LANES = {"exp": "exp", "tanh": "tanh", "log": "ln"}


def _lanes_statement(p: RustPrinter, names: dict[se.Symbol, str], step) -> str:
    """One batched call: an array in, an array out; a lone call takes the one-argument form."""
    f = f"{SCALAR}::{_LANES[step.function]}"
    p.ops.tally("lanes", len(step.rhs))
    if len(step.symbols) == 1:
        return f"    let {names[step.symbol]} = {f}_lane({p(step.rhs[0])});"
    targets = ", ".join(names[s] for s in step.symbols)
    return f"    let [{targets}] = {f}_lanes([{', '.join(p(a) for a in step.rhs)}]);"


def _value(p: RustPrinter, kind: str, rhs: Sequence[se.Expr]) -> str:
    if kind == "max":
        p.ops.tally("compare", len(rhs) - 1)
        return p(rhs[0]) if len(rhs) == 1 else (
            f"{SCALAR}::max({p(rhs[0])}, {p(rhs[1])})" + "".join(f".max({p(r)})" for r in rhs[2:]))
    return p(rhs[0])


def _is_constant(step) -> bool:
    return step.kind != "max" and not step.rhs[0].free_symbols


def _statement(p: RustPrinter, name: str, step) -> str:
    return f"    let {name} = {_value(p, step.kind, step.rhs)};"


def _results(kernel: Kernel, parts_of: Sequence[str], lines: list[str]) -> str:
    """The returned value: each output as its Rust shape (a symmetric matrix binds its upper
    triangle once, into ``lines``, and repeats it below the diagonal)."""
    results: list[str] = []
    pos = 0
    for out in kernel.outputs:
        parts = parts_of[pos:pos + len(out.exprs)]
        pos += len(out.exprs)
        if out.kind == "scalar":
            results.append(parts[0])
        elif out.kind == "vector":
            results.append("[" + ", ".join(parts) + "]")
        elif out.kind == "matrix":
            rows = [parts[r * out.cols:(r + 1) * out.cols] for r in range(out.dim)]
            results.append("[" + ", ".join("[" + ", ".join(r) + "]" for r in rows) + "]")
        else:
            n = out.dim
            upper = [(i, j) for i in range(n) for j in range(i, n)]
            for k, (i, j) in enumerate(upper):
                lines.append(f"    let {out.name}_{i}{j} = {parts[k]};")
            rows = ["[" + ", ".join(f"{out.name}_{min(i, j)}{max(i, j)}" for j in range(n)) + "]"
                    for i in range(n)]
            results.append("[" + ", ".join(rows) + "]")
    return results[0] if len(results) == 1 else "(" + ", ".join(results) + ")"


def _check_size(kernel: Kernel, code: StraightLine) -> None:
    depth = len(_levels(code.steps))
    if depth > MAX_KERNEL_LEVELS:
        raise SpecError(
            f"kernel {kernel.name!r} nests {depth} levels of temporaries, more than {MAX_KERNEL_LEVELS}: every level "
            "is a `let` that opens a scope in the last, and rustc's debug-info pass overflows its stack on one "
            "function with a few thousand of them. Split the family: rows that share little into members "
            "(over=[...]).")


def _levels(steps: Sequence) -> list[list]:
    """The steps by dependency level: level k's read only inputs and levels below k. Kept in
    their order within a level, so the text is deterministic."""
    level: dict[se.Symbol, int] = {}
    out: list[list] = []
    for step in steps:
        k = max((level[s] + 1 for r in step.rhs for s in r.free_symbols if s in level), default=0)
        for sym in step.symbols or (step.symbol,):
            level[sym] = k
        out.extend([] for _ in range(k + 1 - len(out)))
        out[k].append(step)
    return out


def _body(p: RustPrinter, names: dict[se.Symbol, str], steps: Sequence) -> list[str]:
    """The steps as `let` statements, one per dependency level: `let (a, b, ..) = (.., ..);`
    binds a level's temporaries together. Every `let` opens a scope nested in the last, and
    rustc recurses once per scope when it writes debug info, so a kernel's depth is its
    levels (tens to hundreds), not its temporaries (thousands). Batched calls and
    constants (which need their type spelled) keep a statement of their own."""
    lines: list[str] = []
    for level in _levels(steps):
        together = [s for s in level if s.kind != "lanes" and not _is_constant(s)]
        for step in level:
            if step.kind == "lanes":
                lines.append(_lanes_statement(p, names, step))
            elif _is_constant(step) or len(together) == 1:
                lines.append(_statement(p, names[step.symbol], step))
        if len(together) > 1:
            targets = ", ".join(names[s.symbol] for s in together)
            values = ", ".join(_value(p, s.kind, s.rhs) for s in together)
            lines.append(f"    let ({targets}) = ({values});")
    return lines


def emit_split_kernel(kernel: Kernel, runtime_crate: str, per_cycle: Sequence[str],
                      attributes: Sequence[str] = (), ops: dict[str, list[int]] | None = None) -> str:
    """A kernel of a family evaluated at many instances per state, as three functions:
    ``<name>_state`` (the inputs named in ``per_cycle``: the state, the time) computes once
    per cycle everything that does not depend on an instance and returns the values the
    rest reads; ``<name>_instance`` takes those and one instance's parameters; ``<name>``
    is the two in a row, with the kernel's own signature. The steps, and so the bits of
    every result, are the one-function kernel's. ``ops``, when given, receives the
    operations of ``<name>`` and of its two parts under their function names."""
    code = straight_line(kernel)
    _check_size(kernel, code)
    names = _local_names(kernel, code)
    p = RustPrinter(names)
    cycle_inputs = [i for i in kernel.inputs if i.name in per_cycle]
    instance_inputs = [i for i in kernel.inputs if i.name not in per_cycle]
    cut = split(code, [s for i in cycle_inputs for s in i.symbols])
    k = len(cut.interface)

    def unpack(inputs, used) -> list[str]:
        return [f"    let {names[sym]} = {input_element(inp, n)};" for inp in inputs if inp.is_array
                for n, sym in enumerate(inp.symbols) if sym in used]

    def params(inputs) -> str:
        return ", ".join(f"{i.name}: {input_type(i, runtime_crate, SCALAR)}" for i in inputs)

    _, ret = kernel_signature(kernel, runtime_crate, SCALAR)
    g = generic(runtime_crate)
    state_fn = [f"/// The part of [`{kernel.name}`] that reads only {', '.join(f'`{i.name}`' for i in cycle_inputs)}: "
                f"computed once per cycle for every instance, and handed to [`{kernel.name}_instance`].",
                *attributes, "#[inline]",
                f"pub fn {kernel.name}_state{g}({params(cycle_inputs)}) -> [{SCALAR}; {k}] {{"]
    state_fn += unpack(cycle_inputs, cut.state_inputs_used)
    state_fn += _body(p, names, cut.state_steps)
    state_fn += [f"    [{', '.join(names[s] for s in cut.interface)}]", "}"]
    state_ops = p.ops.as_list()
    instance_fn = [f"/// One instance of [`{kernel.name}`], from [`{kernel.name}_state`]'s values at the state.",
                   *attributes, "#[inline]",
                   f"pub fn {kernel.name}_instance{g}(state_part: &[{SCALAR}; {k}]"
                   + "".join(f", {a}" for a in [params(instance_inputs)] if a) + f") -> {ret} {{"]
    instance_fn += [f"    let {names[s]} = state_part[{n}];" for n, s in enumerate(cut.interface)]
    instance_fn += unpack(instance_inputs, cut.instance_inputs_used)
    instance_fn += _body(p, names, cut.instance_steps)
    instance_fn += [f"    {_results(kernel, [p(e) for e in cut.outputs], instance_fn)}", "}"]
    args, _ = kernel_signature(kernel, runtime_crate, SCALAR)
    call_state = ", ".join(i.name for i in cycle_inputs)
    call_rest = "".join(f", {i.name}" for i in instance_inputs)
    wrapper = _doc_lines(kernel) + list(attributes) + [
        "#[inline]", f"pub fn {kernel.name}{g}({args}) -> {ret} {{",
        f"    {kernel.name}_instance(&{kernel.name}_state({call_state}){call_rest})", "}"]
    if ops is not None:
        # The kernel's count (what its table line states) and its two parts' (what a barrier
        # set's `evaluate` calls: the state's once per cycle, the instance's per instance).
        ops[kernel.name] = p.ops.as_list()
        ops[f"{kernel.name}_state"] = state_ops
        ops[f"{kernel.name}_instance"] = [a - b for a, b in zip(ops[kernel.name], state_ops, strict=True)]
    consts: list[str] = []
    for c in kernel.constants:
        consts.append(f"/// {rustdoc_text(c.doc)}")
        consts.append(f"pub const {c.name}: {c.rust_type} = {c.value};")
    return "\n".join(consts + state_fn + instance_fn + wrapper) + "\n"


def emit_kernel(kernel: Kernel, runtime_crate: str, attributes: Sequence[str] = (), inline: str = "#[inline]",
                ops: dict[str, list[int]] | None = None) -> str:
    """The Rust text of one kernel: constants, then the function. ``runtime_crate`` is the
    path of cbfgen's core where the kernel is compiled (``crate`` inside it, ``cbfgen``
    elsewhere); ``attributes`` (outer attributes such as ``#[allow(...)]``) go on the
    function, before its ``#[inline]``. ``ops``, when given, receives the operations the
    function performs under its name (:class:`OpCount` order)."""
    code = straight_line(kernel)
    _check_size(kernel, code)
    names = _local_names(kernel, code)
    p = RustPrinter(names)
    args, ret = kernel_signature(kernel, runtime_crate, SCALAR)
    lines = _doc_lines(kernel) + list(attributes) + [
        inline, f"pub fn {kernel.name}{generic(runtime_crate)}({args}) -> {ret} {{"]
    # Scalar inputs are already locals under their own name; arrays are unpacked.
    for inp in filter(lambda i: i.is_array, kernel.inputs):
        for k, sym in enumerate(inp.symbols):
            if sym in code.used_inputs:
                lines.append(f"    let {names[sym]} = {input_element(inp, k)};")
    lines += _body(p, names, code.steps)
    body = _results(kernel, [p(e) for e in code.outputs], lines)
    lines += [f"    {body}", "}"]
    if ops is not None:
        ops[kernel.name] = p.ops.as_list()
    consts: list[str] = []
    for c in kernel.constants:
        consts.append(f"/// {rustdoc_text(c.doc)}")
        consts.append(f"pub const {c.name}: {c.rust_type} = {c.value};")
    return "\n".join(consts + lines) + "\n"
