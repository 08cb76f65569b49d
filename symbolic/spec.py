"""The system spec users write: a control-affine model and its barrier families.

A spec is a Python file with a ``build()`` that returns a :class:`System`::

    import symengine as se
    from symbolic.spec import System

    def build() -> System:
        s = System("planar_robot", doc="A planar point robot.")
        px, py, vx, vy = s.states(["px", "py", "vx", "vy"])
        s.inputs(["ax", "ay"], limits=[(-4.0, 4.0), (-4.0, 4.0)])
        s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
        s.family("speed_limit", lambda p: p.vmax**2 - vx**2 - vy**2, params={"vmax": ()},
                 poles=[5.0], doc="Speed below vmax.")
        return s

Nothing here knows a target language: :mod:`symbolic.codegen` turns the system into
kernels (differentiating every family to its relative degree, which is *found*, never
given) and a backend prints them; the names a backend reserves come from the backends
(:mod:`symbolic.codegen.backends`).

**Families.** ``h`` is called once with a :class:`FamilyContext` ``p``: its parameters as
attributes (a scalar is a symbol, a vector a list of symbols, a matrix a list of rows),
``p.t`` the time symbol (``time=True`` only), and ``p.let`` / ``p.runtime_max`` to build
named intermediates the Lie engine differentiates through (what the helpers of
:mod:`symbolic.primitives` use). It returns one expression, or a list of
``(row_name, expr)`` pairs: several rows per instance, all of one relative degree.
A family has ``count=N`` fixed instances (all always active), or ``capacity=True``:
instances filled at run time up to a capacity fixed when the barrier set is built.

**Parameters and their domains.** ``params`` maps each name to a shape (``()``, ``(n,)``,
``(rows, cols)``), or to ``(shape, doc)``, ``(shape, domain)`` or ``(shape, doc, domain)``.
The domain is what the parameter may be at run time::

    params={"center": ((3,), "centre [m]"),                       # Real: the default
            "half": ((3,), "half extents [m]", Positive()),        # every entry > 0
            "margin": ((), NonNegative()),                         # >= 0
            "gain": ((), "doc", Interval(0.1, 10.0)),              # in [lo, hi]
            "normal": ((2,), UnitVector(1e-9)),                    # | |v| - 1 | <= tol
            "rotation": ((3, 3), Rotation(1e-9))}                  # orthonormal within tol, det > 0

Every domain also asks each entry finite with ``|entry| <= PARAM_LIMIT`` (all
:class:`Real` asks); tolerances default to ``DEFAULT_TOLERANCE`` (1e-9, the runtime's
rotation tolerance) and lie in ``TOLERANCE_RANGE``. ``UnitVector`` fits vectors only,
``Rotation`` 2x2 and 3x3 matrices; anything else is a SpecError naming system, family
and parameter. The generated ``validate()`` of each parameter struct checks the domain
(in Rust, and so in Python): ``Params.set``/``push`` refuse a value outside it with an
error naming family, member, instance and parameter, and change nothing, and a barrier
set re-checks every evaluation. A fixed instance's parameters start unset (the runtime's
``UNSET`` marker) unless the family gives ``defaults=``, and are refused, by name, until
they are set: never filtered against as zeros.

Primitives say what they need (:meth:`FamilyContext.require`): ``prim.Box`` a proper
rotation and half extents > 0, ``prim.sphere_box`` a radius > 0, ``prim.superellipsoid``
an inflation >= 0, ``prim.half_space`` a unit normal. Where those inputs are a family's
parameters, the parameters get the domain with no declaration; a declared domain must lie
within it (``Interval(0.01, 1.0)`` for half extents is, ``NonNegative`` is not: a
SpecError).

Every mistake is a :class:`SpecError` naming the system, the family and the key.
"""

from __future__ import annotations

import contextlib
import importlib.util
import keyword
import math
import os
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import symengine as se

from .codegen.backends import MODULE_ITEMS, RESERVED_LOCALS, RESERVED_WORDS

# Bounds the runtime enforces too (src/system.rs, src/filter): checked here so a spec fails
# when it is generated, not when the filter is built. python/tests/test_runtime_domains.py
# checks them against the built module, which exports the runtime's own.
MAX_INPUT = 1e6
MAX_INSTANCES = 10_000
POLE_RANGE = (1e-6, 1e4)
MAX_PRIORITY = 15
DEFAULT_POLE = 10.0
# Largest |runtime parameter| (src/system.rs PARAM_LIMIT): every domain lies within it.
PARAM_LIMIT = 1e6
# More of the runtime's documented domains (src/ssat.rs ALPHA_MIN/ALPHA_MAX, which
# src/sphere_box.rs shares for smoothing sharpness, src/geometry.rs MIN/MAX_HALF_EXTENT): a
# model outside them would bake numbers into the kernels that the safe API refuses at run
# time. python/tests/test_runtime_domains.py
# checks every one against the built module.
SSAT_ALPHA_RANGE = (1e-6, 1e9)
HALF_EXTENT_RANGE = (1e-6, 1e4)
INPUT_LIMIT_RANGE = (0.0, MAX_INPUT)
# Tolerance of UnitVector and Rotation unless given: the runtime's geometry::ROTATION_TOLERANCE,
# which OrientedBox (and so Tachyon 3's Environment.push_edge) accepts.
DEFAULT_TOLERANCE = 1e-9
# Tolerances a spec may give: from a few rounding errors above f64's (a rotation built from
# angles is orthonormal to ~1e-15) to where a reflection could pass for a rotation.
TOLERANCE_RANGE = (1e-12, 1e-2)

_IDENT = re.compile(r"^[a-z][a-z0-9_]*$")
class SpecError(ValueError):
    """A system spec that cannot be generated; the message names system, family and key.
    ``origin`` is the spec's ``(file, line)`` it concerns where known (the family's
    declaration, for a problem found while differentiating it)."""

    origin: tuple[str, int] | None = None


# Keywords a spec may still pass from an older release: what replaced each.
REMOVED_KEYWORDS = {
    "slack_weight": "priorities replaced slack weights: give the family priority=N instead (0, the default, "
                    "is met first; a higher tier gives way when rows conflict)",
}


def _refuse_keywords(where: str, given: dict[str, object]) -> None:
    """A keyword the declaration does not take: what replaced it, if it was removed, else
    that it is unknown (a SpecError, so the spec's file and line are named)."""
    for key in given:
        if key in REMOVED_KEYWORDS:
            raise SpecError(f"{where}: {key}= was removed; {REMOVED_KEYWORDS[key]}")
        raise SpecError(f"{where}: no keyword {key}=")


def caller_origin() -> tuple[str, int] | None:
    """``(file, line)`` of the innermost caller outside this package: the spec's line that
    declared something."""
    package = Path(__file__).resolve().parent
    internal, specs = str(package) + os.sep, str(package / "tests") + os.sep  # test specs are specs
    frame = sys._getframe(1)
    while frame is not None:
        name = frame.f_code.co_filename
        path = str(Path(name).resolve())
        if not path.startswith(internal) or path.startswith(specs):
            return name, frame.f_lineno
        frame = frame.f_back
    return None


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def check_identifier(where: str, key: str, name: object, *, module_item: bool = False,
                     local: bool = True) -> str:
    """``name`` as a snake_case identifier usable in every generated language. ``local``:
    the name becomes a variable or function of generated code (parameters, intermediates,
    families), so the generator's own locals and the target's keywords are excluded;
    state and input names only ever appear prefixed or upper-cased."""
    if not isinstance(name, str) or not _IDENT.match(name) or "__" in name or name.endswith("_"):
        raise SpecError(f"{where}: {key} {name!r} is not a snake_case identifier "
                        "(lower-case letters, digits and single underscores, starting with a letter)")
    if local and (name in RESERVED_WORDS or keyword.iskeyword(name) or any(p.match(name) for p in RESERVED_LOCALS)):
        raise SpecError(f"{where}: {key} {name!r} is reserved in generated code; choose another name")
    if module_item and name in MODULE_ITEMS:
        raise SpecError(f"{where}: {key} {name!r} is the name of an item every generated module "
                        "defines; choose another name")
    return name


def _number(where: str, key: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SpecError(f"{where}: {key} must be a number, got {value!r}")
    return float(value)


def _expr(where: str, key: str, value: object) -> se.Expr:
    try:
        return se.sympify(value)
    except Exception as exc:  # SymEngine raises several types for junk
        raise SpecError(f"{where}: {key} is not a symbolic expression: {value!r}") from exc


# ------------------------------------------------------------------ parameters
Shape = tuple[()] | tuple[int] | tuple[int, int]


def _num(v: float) -> str:
    """A number as the runtime's messages print it: ``1e-6``, ``10000``, ``0.5``."""
    v = float(v)
    if v == 0 or not math.isfinite(v) or 1e-3 <= abs(v) < 1e6:
        return f"{v:.15g}"
    mantissa, exponent = f"{v:.14e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def _is_number(e: object) -> bool:
    return (isinstance(e, (int, float)) and not isinstance(e, bool)) or (
        isinstance(e, se.Basic) and e.is_Number)


class Domain:
    """The set of values a runtime parameter may take, checked by the generated
    ``validate()`` in every language before a kernel reads the parameter. Every domain
    also requires each entry finite with ``|entry| <= PARAM_LIMIT`` (what :class:`Real`
    alone requires). A backend prints each kind as its runtime's counterpart."""

    #: Whether the domain constrains each entry alone (so it applies to any shape).
    elementwise = True

    def applies_to(self, shape: Shape) -> str | None:
        """Why a parameter of ``shape`` cannot have this domain (None: it can)."""
        return None

    def check(self) -> str | None:
        """Why the domain's own numbers are invalid (None: they are valid)."""
        return None

    def within(self, other: Domain) -> bool:
        """Whether every value of this domain is in ``other`` (self is a subset)."""
        raise NotImplementedError

    def violation(self, values: Sequence[float]) -> str | None:
        """Why numbers ``values`` (a flat list; a matrix row by row) are outside the
        domain, or None: what generation checks of constants handed to a primitive."""
        raise NotImplementedError


def _bounds(d: Domain) -> tuple[float, bool, float] | None:
    """An elementwise domain as ``(lower, lower_open, upper)`` within +-PARAM_LIMIT."""
    if isinstance(d, Real):
        return (-PARAM_LIMIT, False, PARAM_LIMIT)
    if isinstance(d, Positive):
        return (0.0, True, PARAM_LIMIT)
    if isinstance(d, NonNegative):
        return (0.0, False, PARAM_LIMIT)
    if isinstance(d, Interval):
        return (d.lo, False, d.hi)
    return None


class _Elementwise(Domain):
    def within(self, other: Domain) -> bool:
        a, b = _bounds(self), _bounds(other)
        if b is None:
            return False
        lo, lo_open, hi = a
        other_lo, other_open, other_hi = b
        return hi <= other_hi and (lo > other_lo or (lo == other_lo and (lo_open or not other_open)))

    def violation(self, values: Sequence[float]) -> str | None:
        lo, lo_open, hi = _bounds(self)
        for i, v in enumerate(values):
            if not (math.isfinite(v) and (v > lo if lo_open else v >= lo) and v <= hi):
                return f"entry {i} is {v:g}, not {self}"
        return None


@dataclass(frozen=True)
class Real(_Elementwise):
    """Any finite number within +-PARAM_LIMIT (the default)."""

    def __str__(self) -> str:
        return f"finite, within +-{_num(PARAM_LIMIT)}"


@dataclass(frozen=True)
class Positive(_Elementwise):
    """Every entry > 0: a length, a radius, a half extent."""

    def __str__(self) -> str:
        return "> 0"


@dataclass(frozen=True)
class NonNegative(_Elementwise):
    """Every entry >= 0: an inflation, a margin."""

    def __str__(self) -> str:
        return ">= 0"


@dataclass(frozen=True)
class Interval(_Elementwise):
    """Every entry in ``[lo, hi]`` (finite, lo < hi, both within +-PARAM_LIMIT)."""

    lo: float
    hi: float

    def check(self) -> str | None:
        if not all(_is_number(v) and math.isfinite(v) and abs(v) <= PARAM_LIMIT for v in (self.lo, self.hi)) \
                or not self.lo < self.hi:
            return f"Interval({self.lo!r}, {self.hi!r}) needs finite lo < hi within +-{_num(PARAM_LIMIT)}"
        return None

    def __str__(self) -> str:
        return f"in [{_num(self.lo)}, {_num(self.hi)}]"


def _tolerance_problem(kind: str, tol: object) -> str | None:
    lo, hi = TOLERANCE_RANGE
    if not (_is_number(tol) and lo <= tol <= hi):
        return f"{kind}(tol={tol!r}): the tolerance must be a number in [{lo:g}, {hi:g}]"
    return None


@dataclass(frozen=True)
class UnitVector(Domain):
    """A vector of length 1: ``| |v| - 1 | <= tol`` (a plane's normal, an axis)."""

    tol: float = DEFAULT_TOLERANCE
    elementwise = False

    def applies_to(self, shape: Shape) -> str | None:
        return None if len(shape) == 1 else f"a unit vector is a vector, shape (n,), not {shape}"

    def check(self) -> str | None:
        return _tolerance_problem("UnitVector", self.tol)

    def within(self, other: Domain) -> bool:
        return isinstance(other, Real) or (isinstance(other, UnitVector) and self.tol <= other.tol)

    def violation(self, values: Sequence[float]) -> str | None:
        norm = math.hypot(*values)
        return None if abs(norm - 1) <= self.tol else f"its length is {norm:g}, not {self}"

    def __str__(self) -> str:
        return f"a unit vector (| |v| - 1 | <= {_num(self.tol)})"


@dataclass(frozen=True)
class Rotation(Domain):
    """A proper rotation matrix, 2x2 or 3x3: orthonormal (every entry of ``R^T R - I``
    within ``tol``) with ``det R > 0`` (no reflection)."""

    tol: float = DEFAULT_TOLERANCE
    elementwise = False

    def applies_to(self, shape: Shape) -> str | None:
        return None if shape in ((2, 2), (3, 3)) else f"a rotation is a 2x2 or 3x3 matrix, not shape {shape}"

    def check(self) -> str | None:
        return _tolerance_problem("Rotation", self.tol)

    def within(self, other: Domain) -> bool:
        return isinstance(other, Real) or (isinstance(other, Rotation) and self.tol <= other.tol)

    def violation(self, values: Sequence[float]) -> str | None:
        n = math.isqrt(len(values))
        cols = [[values[r * n + c] for r in range(n)] for c in range(n)]
        deviation = max(abs(sum(a * b for a, b in zip(cols[i], cols[j], strict=True)) - (i == j))
                        for i in range(n) for j in range(n))
        if not deviation <= self.tol:
            return f"max |R^T R - I| is {deviation:g}, not {self}"
        det = (values[0] * values[3] - values[1] * values[2] if n == 2 else
               values[0] * (values[4] * values[8] - values[5] * values[7])
               - values[1] * (values[3] * values[8] - values[5] * values[6])
               + values[2] * (values[3] * values[7] - values[4] * values[6]))
        return None if det > 0 else f"det R is {det:g}, not {self}"

    def __str__(self) -> str:
        return f"a proper rotation (max |R^T R - I| <= {_num(self.tol)}, det R > 0)"


def _domain(where: str, name: str, value: object) -> Domain:
    """``value`` as a domain instance (a domain class without arguments is its default)."""
    if isinstance(value, type) and issubclass(value, Domain) and value not in (Domain, _Elementwise):
        try:
            value = value()
        except TypeError:
            raise SpecError(f"{where}: parameter {name!r}: {value.__name__} needs its bounds, "
                            f"e.g. {value.__name__}(lo, hi)") from None
    if not isinstance(value, Domain) or type(value) in (Domain, _Elementwise):
        raise SpecError(f"{where}: parameter {name!r}: {value!r} is not a domain (Real, Positive, NonNegative, "
                        "Interval(lo, hi), UnitVector(tol), Rotation(tol))")
    problem = value.check()
    if problem:
        raise SpecError(f"{where}: parameter {name!r}: {problem}")
    return value


@dataclass(frozen=True)
class Param:
    """A runtime parameter of a family: ``shape`` is ``()`` (scalar), ``(n,)`` (vector)
    or ``(rows, cols)`` (matrix, flattened row-major for the kernel). ``domain`` is the
    one declared in the spec (None: not declared; :class:`Real` unless a primitive
    requires more), and in a generated definition the one checked."""

    name: str
    shape: Shape
    doc: str
    domain: Domain | None = None
    # What a fixed instance holds before it is set (row-major for a matrix); None: it is
    # unset and the filter refuses to run until it is set.
    default: tuple[float, ...] | None = None

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def components(self) -> list[str]:
        """Component suffixes of the flattened parameter, in kernel argument order."""
        if self.shape == ():
            return []
        if len(self.shape) == 1:
            return [str(i) for i in range(self.shape[0])]
        rows, cols = self.shape
        sep = "" if rows <= 10 and cols <= 10 else "_"
        return [f"{i}{sep}{j}" for i in range(rows) for j in range(cols)]


def _with_defaults(where: str, params: list[Param], defaults: object, capacity: bool) -> list[Param]:
    """``params`` with the spec's ``defaults`` (name -> value shaped as the parameter)."""
    if not isinstance(defaults, dict):
        raise SpecError(f"{where}: defaults must be a dict of parameter name -> value")
    if capacity:
        raise SpecError(f"{where}: defaults are for fixed instances; a capacity family's instances are pushed whole")
    by_name = {p.name: p for p in params}
    unknown = [n for n in defaults if n not in by_name]
    if unknown:
        raise SpecError(f"{where}: defaults name {unknown}, not parameters of the family ({list(by_name)})")
    out = []
    for p in params:
        if p.name not in defaults:
            out.append(p)
            continue
        value = defaults[p.name]
        numbers = _shaped_numbers(value, p.shape)
        if numbers is None:
            raise SpecError(f"{where}: default of {p.name!r} must be {'a number' if p.shape == () else 'numbers'} "
                            f"of shape {p.shape}, got {value!r}")
        if not all(math.isfinite(v) and abs(v) <= PARAM_LIMIT for v in numbers):
            raise SpecError(f"{where}: default of {p.name!r} must be finite and within +-{_num(PARAM_LIMIT)}, "
                            f"got {value!r}")
        out.append(replace(p, default=numbers))
    return out


def _shaped_numbers(value: object, shape: Shape) -> tuple[float, ...] | None:
    """``value``'s numbers, row-major, if it is a number (shape ``()``) or nested lists of
    exactly ``shape``; None otherwise."""
    if shape == ():
        return (float(value),) if _is_number(value) else None
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != shape[0]:
        return None
    parts = [_shaped_numbers(v, shape[1:]) for v in value]
    return None if any(part is None for part in parts) else tuple(v for part in parts for v in part)


def _param(where: str, name: object, spec: object) -> Param:
    """``spec`` is a shape, or ``(shape, doc)``, ``(shape, domain)`` or ``(shape, doc, domain)``."""
    check_identifier(where, "parameter", name)
    if name in ("let", "runtime_max", "require"):
        raise SpecError(f"{where}: parameter {name!r} is a method of the family context; choose another name")
    doc, domain = "", None
    if isinstance(spec, tuple) and spec and isinstance(spec[0], tuple) and 2 <= len(spec) <= 3:
        shape, *rest = spec
        if len(rest) == 2 or isinstance(rest[0], str):
            doc = rest[0]
            rest = rest[1:]
        if not isinstance(doc, str):
            raise SpecError(f"{where}: parameter {name!r}: the doc must be a string, got {doc!r}")
        if rest:
            domain = rest[0]
        spec = shape
    if not isinstance(spec, tuple) or len(spec) > 2 or any(
            isinstance(n, bool) or not isinstance(n, int) or n < 1 for n in spec):
        raise SpecError(f"{where}: parameter {name!r} has shape {spec!r}; use () for a scalar, (n,) "
                        "for a vector or (rows, cols) for a matrix, sizes >= 1 (optionally "
                        "(shape, 'doc'), (shape, domain) or (shape, 'doc', domain))")
    if math.prod(spec) > 1024:
        raise SpecError(f"{where}: parameter {name!r} has {math.prod(spec)} entries; at most 1024")
    if domain is not None:
        domain = _domain(where, name, domain)
        problem = domain.applies_to(spec)
        if problem:
            raise SpecError(f"{where}: parameter {name!r} is declared {type(domain).__name__}, but {problem}")
    return Param(name, spec, doc, domain)


class FamilyContext:
    """What ``h`` receives: the family's parameters as attributes, the time symbol, and
    named intermediates the Lie engine differentiates through.

    ``let`` and ``runtime_max`` make a name unique by appending ``_2``, ``_3``, ... when it
    is taken, so a helper may be used twice in one family.
    """

    def __init__(self, where: str, kernel, engine, params: dict[str, object], time: se.Symbol | None,
                 index: int | None = None, label: str | None = None, declared: Sequence[Param] = (),
                 required: dict[str, tuple[Domain, str]] | None = None, composer=None):
        self._where = where
        # In a family declared compose=True: what records the composable primitives h
        # calls (symbolic.codegen.composition.Recorder) instead of expanding them.
        self._composer = composer
        self._kernel = kernel
        self._engine = engine
        self._params = params
        self._time = time
        self._index = index
        self._label = label
        self._declared = {p.name: p for p in declared}
        # Domains primitives asked of the family's parameters, with who asked: shared by
        # every member of an indexed family.
        self._required = {} if required is None else required

    def __getattr__(self, name: str):
        params = self.__dict__.get("_params", {})
        if name in params:
            return params[name]
        raise SpecError(f"{self.__dict__.get('_where', 'family')}: no parameter {name!r} "
                        f"(declared: {sorted(params) or 'none'})")

    def __getitem__(self, name: str):
        return self.__getattr__(name)

    @property
    def t(self) -> se.Symbol:
        if self._time is None:
            raise SpecError(f"{self._where}: uses time, but the family was declared without time=True")
        return self._time

    @property
    def composer(self):
        """The recorder of a ``compose=True`` family's primitives, else None."""
        return self.__dict__.get("_composer")

    @property
    def index(self) -> int:
        """Position of the member being built in the family's ``over`` list."""
        if self._index is None:
            raise SpecError(f"{self._where}: uses p.index, but the family was declared without over=[...]")
        return self._index

    @property
    def label(self) -> str:
        """Name of the member being built (an entry of the family's ``over`` list)."""
        if self._label is None:
            raise SpecError(f"{self._where}: uses p.label, but the family was declared without over=[...]")
        return self._label

    def _fresh(self, name: str) -> str:
        check_identifier(self._where, "intermediate", name)
        taken = self._kernel._names
        if name not in taken:
            return name
        n = 2
        while f"{name}_{n}" in taken:
            n += 1
        return f"{name}_{n}"

    def let(self, name: str, expr: se.Expr) -> se.Symbol:
        """A named intermediate (a relative pose, a smooth max's sum): computed once, and
        differentiated by the chain rule through its own rate."""
        return self._engine.let_(self._fresh(name), expr)

    # The name the library's helpers (symbolic.families.ssat) expect of a let factory.
    let_ = let

    def runtime_max(self, name: str, exprs: Sequence[se.Expr]) -> se.Symbol:
        """max() over ``exprs`` evaluated at run time; a constant for differentiation, so
        only for shifts the result does not depend on (a log-sum-exp's overflow guard)."""
        return self._kernel.runtime_max(self._fresh(name), exprs)

    def require(self, exprs: object, domain: Domain | type[Domain], what: str) -> None:
        """Declare that ``exprs`` must lie in ``domain`` for ``h`` to mean what it says: what
        the primitives call for a box's rotation and half extents or a sphere's radius
        (``what`` names the use, for messages: "prim.ssat's box half extents").

        When ``exprs`` is exactly one parameter (``p.radius``, ``p.half``, ``p.rotation``;
        a rotation may also be its transpose), or, for a per-entry domain (Positive,
        NonNegative, Interval), a list whose entries are whole scalar parameters or
        together every entry of one, the domain is attached to those parameters: the
        generated ``validate()`` checks it. A parameter declared with a domain that is not
        within ``domain`` is a SpecError, as are two uses asking incompatible domains, and
        a domain asked of some entries of a parameter only (declare the parameter's domain,
        or split it). Numbers among ``exprs`` are checked at once. Expressions (a centre
        moving with the state, a rotation built from an angle) are left alone: they are
        what they are by construction, or the spec's responsibility."""
        domain = _domain(self._where, what, domain)
        flat, shape = _flatten(exprs)
        targets = [p for p in self._declared.values() if _is_whole(exprs, self._params[p.name], domain)]
        if not targets:
            entries: dict[str, set[int]] = {}
            for e in flat:
                for p in self._declared.values():
                    index = _entry_index(self._params[p.name], e)
                    if index is not None:
                        entries.setdefault(p.name, set()).add(index)
            for name, indices in entries.items():
                p = self._declared[name]
                if domain.elementwise and len(indices) == p.size:
                    targets.append(p)
                elif p.domain is None or not p.domain.within(domain):
                    use = "some entries" if domain.elementwise else "entries"
                    raise SpecError(f"{self._where}: {what} uses {use} of parameter {name!r} but not the parameter "
                                    f"as a whole, and needs {domain}; pass p.{name} itself, or declare {name!r} "
                                    f"with a domain within {domain} (or make those entries their own parameter)")
        _check_numbers(self._where, what, exprs, flat, shape, domain)
        for p in targets:
            self._attach(p, domain, what)

    def _attach(self, p: Param, domain: Domain, what: str) -> None:
        if p.domain is not None and not p.domain.within(domain):
            raise SpecError(f"{self._where}: parameter {p.name!r} is declared {type(p.domain).__name__} ({p.domain}), "
                            f"but {what} needs {domain}; declare a domain within that, or none to take it from "
                            f"{what}")
        earlier = self._required.get(p.name)
        if earlier is None or domain.within(earlier[0]):
            self._required[p.name] = (domain, what)
        elif not earlier[0].within(domain):
            raise SpecError(f"{self._where}: parameter {p.name!r}: {what} needs {domain}, but {earlier[1]} needs "
                            f"{earlier[0]}; no one domain satisfies both")

    @contextlib.contextmanager
    def active(self):
        """Make this the context :func:`require` (and so the primitives that take no
        context, ``prim.Box``, ``prim.half_space``) attaches domains through, while ``h``
        runs."""
        _ACTIVE.append(self)
        try:
            yield self
        finally:
            _ACTIVE.pop()


# The family contexts whose h is running, innermost last.
_ACTIVE: list[FamilyContext] = []


def require(exprs: object, domain: Domain | type[Domain], what: str) -> None:
    """:meth:`FamilyContext.require` on the family whose ``h`` is running; outside one,
    only the numbers among ``exprs`` are checked (a constant box's half extents)."""
    if _ACTIVE:
        _ACTIVE[-1].require(exprs, domain, what)
        return
    domain = _domain(what, what, domain)
    flat, shape = _flatten(exprs)
    _check_numbers(what, what, exprs, flat, shape, domain)


def _flatten(exprs: object) -> tuple[list[object], tuple[int, ...]]:
    """Entries row by row, and the shape: () scalar, (n,) list, (r, c) list of lists."""
    if isinstance(exprs, (list, tuple)):
        if exprs and all(isinstance(r, (list, tuple)) for r in exprs):
            return [e for r in exprs for e in r], (len(exprs), len(exprs[0]))
        return list(exprs), (len(exprs),)
    return [exprs], ()


def _same(a: object, b: object) -> bool:
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (list, tuple)) or isinstance(b, (list, tuple)):
        return False
    return isinstance(a, se.Basic) and isinstance(b, se.Basic) and a == b


def _is_whole(exprs: object, value: object, domain: Domain) -> bool:
    """``exprs`` is the parameter ``value`` itself (or, for a rotation, its transpose)."""
    if _same(exprs, value):
        return True
    if isinstance(domain, Rotation) and isinstance(value, list) and value and isinstance(value[0], list):
        return _same(exprs, [list(col) for col in zip(*value, strict=True)])
    return False


def _entry_index(value: object, e: object) -> int | None:
    """The position of symbol ``e`` among the parameter ``value``'s entries (row by row)."""
    if not isinstance(e, se.Symbol):
        return None
    flat, _ = _flatten(value)
    for i, sym in enumerate(flat):
        if sym == e:
            return i
    return None


def _check_numbers(where: str, what: str, exprs: object, flat: list[object], shape: tuple[int, ...],
                   domain: Domain) -> None:
    """Numbers handed where ``domain`` is needed: each one for a per-entry domain, the
    whole when every entry of a unit vector or rotation is a number."""
    if domain.elementwise:
        numbers = [float(e) for e in flat if _is_number(e)]
    elif all(_is_number(e) for e in flat) and domain.applies_to(shape) is None:
        numbers = [float(e) for e in flat]
    else:
        return
    problem = domain.violation(numbers) if numbers else None
    if problem:
        raise SpecError(f"{where}: {what} is {exprs!r}: {problem}")


# -------------------------------------------------------------------- families
@dataclass
class Family:
    """One barrier family as declared; :mod:`symbolic.codegen` differentiates it."""

    name: str
    h: Callable[[FamilyContext], object]
    params: list[Param]
    count: int | None
    capacity: bool
    max_capacity: int | None  # the largest capacity a capacity family accepts
    optional: bool
    over: list[str] | None
    time: bool
    poles: list[float] | None
    priority: int
    activation: float
    doc: str
    lower_bound: Callable[[FamilyContext], se.Expr] | None = None
    origin: tuple[str, int] | None = None  # the spec's (file, line) that declared it
    # alpha(s) of the last ECBF term (None: linear); see System.family.
    class_k: Callable[[se.Symbol], object] | None = None
    # "barrier" (h >= 0 kept) or "lyapunov" (h = -V: the decrease V' + rate V <= 0).
    kind: str = "barrier"
    # Rows built from per-body pose kernels and one shared primitive kernel instead of
    # unrolled per member (symbolic.codegen.composition); see System.family.
    compose: bool = False

    @property
    def instances_doc(self) -> str:
        if self.capacity:
            return "up to a capacity chosen at run time"
        return f"{self.count} {'optional' if self.optional else 'fixed'}"


@dataclass(frozen=True)
class Constant:
    """A named constant of the generated module: ``value`` is a float, an int (>= 0), a
    string or a rectangular nested list of one of them."""

    name: str
    value: object
    doc: str


@dataclass(frozen=True)
class Objective:
    """The filter's cost ``1/2 u^T P(x) u + q(x)^T u`` (see :meth:`System.objective`)."""

    P: list[list[se.Expr]]
    q: list[se.Expr]
    doc: str


@dataclass(frozen=True)
class Output:
    """A state function the module exposes: ``values`` are ``(name, value, doc)``, each
    value an expression, a vector (list) or a matrix (list of rows)."""

    name: str
    values: list[tuple[str, object, str]]
    doc: str
    inputs: bool = False
    # A rigid-body dynamics output (:meth:`System.rigid_body_output`): the tree the
    # generated function walks at run time (``symbolic.dynamics.Tree``) and the order of
    # its degrees of freedom in the values; the values are then the definition it is
    # tested against.
    tree: object = None
    order: tuple[int, ...] = ()


def _constant_value(where: str, value: object) -> object:
    """``value`` checked and normalised: a string, a finite number, or a non-empty
    rectangular nested list whose leaves are all strings or all numbers. Numbers stay
    ints only when every leaf is a non-negative int (they become ``usize``); otherwise
    every leaf becomes a float."""
    leaves: list[object] = []

    def shape(v: object) -> tuple[int, ...]:
        if isinstance(v, (list, tuple)):
            if not v:
                raise SpecError(f"{where}: empty list")
            inner = {shape(x) for x in v}
            if len(inner) != 1:
                raise SpecError(f"{where}: nested lists must be rectangular")
            return (len(v), *inner.pop())
        if isinstance(v, bool) or not isinstance(v, (int, float, str)):
            raise SpecError(f"{where}: unsupported value {v!r} (numbers, strings and lists of them)")
        if isinstance(v, float) and not math.isfinite(v):
            raise SpecError(f"{where}: {v} is not finite")
        leaves.append(v)
        return ()

    shape(value)
    if all(isinstance(v, str) for v in leaves):
        as_leaf = str
    elif any(isinstance(v, str) for v in leaves):
        raise SpecError(f"{where}: mixes strings and numbers")
    elif all(isinstance(v, int) and v >= 0 for v in leaves):
        as_leaf = int
    else:
        as_leaf = float

    def convert(v: object) -> object:
        return [convert(x) for x in v] if isinstance(v, (list, tuple)) else as_leaf(v)

    return convert(value)


def _output_value(where: str, value: object, allowed: set, inputs: bool) -> object:
    """An expression, a list of them or a rectangular list of lists, of the ``allowed``
    symbols (the states, and the inputs when ``inputs``)."""
    if isinstance(value, (list, tuple)):
        if not value:
            raise SpecError(f"{where}: empty")
        if all(isinstance(v, (list, tuple)) for v in value):
            cols = {len(v) for v in value}
            if len(cols) != 1 or 0 in cols:
                raise SpecError(f"{where}: a matrix must be a list of equal-length, non-empty rows")
            return [[_output_expr(where, e, allowed, inputs) for e in row] for row in value]
        return [_output_expr(where, e, allowed, inputs) for e in value]
    return _output_expr(where, value, allowed, inputs)


def _output_expr(where: str, e: object, allowed: set, inputs: bool) -> se.Expr:
    if not inputs:
        return _state_expr(where, e, allowed)
    expr = _expr(where, "value", e)
    stray = expr.free_symbols - allowed
    if stray:
        raise SpecError(f"{where}: uses {sorted(map(str, stray))}; it depends on the states and inputs only")
    return expr


def _state_expr(where: str, e: object, states: set) -> se.Expr:
    expr = _expr(where, "value", e)
    stray = expr.free_symbols - states
    if stray:
        raise SpecError(f"{where}: uses {sorted(map(str, stray))}; it depends on the states only")
    return expr


@dataclass
class Limits:
    lower: float
    upper: float


@dataclass
class System:
    """A control-affine system x' = f(x) + g(x) u and its barrier families."""

    name: str
    doc: str = ""
    state_names: list[str] = field(default_factory=list)
    state_docs: list[str] = field(default_factory=list)
    input_names: list[str] = field(default_factory=list)
    input_docs: list[str] = field(default_factory=list)
    input_limits: list[Limits] = field(default_factory=list)
    x: list[se.Symbol] = field(default_factory=list)
    u: list[se.Symbol] = field(default_factory=list)
    f: list[se.Expr] | None = None
    g: list[list[se.Expr]] | None = None
    families: list[Family] = field(default_factory=list)
    constants: list[Constant] = field(default_factory=list)
    outputs: list[Output] = field(default_factory=list)
    cost: Objective | None = None
    source: Path | None = None

    def __post_init__(self):
        check_identifier("system", "name", self.name, module_item=True)
        if _camel(self.name) in ("Params", "Barriers", "Capacity", "Filter"):
            raise SpecError(f"system {self.name!r}: name clashes with a generated item ({_camel(self.name)})")
        if not isinstance(self.doc, str):
            raise SpecError(f"system {self.name!r}: doc must be a string")

    @property
    def where(self) -> str:
        return f"system {self.name!r}"

    @property
    def time(self) -> se.Symbol:
        """The time symbol t [s], usable in families declared with ``time=True``."""
        return se.Symbol("t")

    # ----------------------------------------------------------------- layout
    def _names(self, key: str, names: object, docs: object) -> tuple[list[str], list[str]]:
        if isinstance(names, str) or not isinstance(names, Sequence) or not names:
            raise SpecError(f"{self.where}: {key} must be a non-empty list of names, got {names!r}")
        for n in names:
            check_identifier(self.where, key[:-1], n, local=False)
        if len(set(names)) != len(names):
            raise SpecError(f"{self.where}: {key} {list(names)} repeat a name")
        docs = list(docs) if docs is not None else [""] * len(names)
        if len(docs) != len(names) or not all(isinstance(d, str) for d in docs):
            raise SpecError(f"{self.where}: {key} docs must be {len(names)} strings")
        return list(names), docs

    def states(self, names: Sequence[str], docs: Sequence[str] | None = None) -> list[se.Symbol]:
        """Declare the states, in order; returns their symbols."""
        if self.state_names:
            raise SpecError(f"{self.where}: states declared twice")
        self.state_names, self.state_docs = self._names("states", names, docs)
        clash = set(self.state_names) & set(self.input_names)
        if clash:
            raise SpecError(f"{self.where}: {sorted(clash)} named both state and input")
        self.x = [se.Symbol(f"x_{n}") for n in self.state_names]
        return list(self.x)

    def inputs(self, names: Sequence[str], limits: Sequence[tuple[float, float]],
               docs: Sequence[str] | None = None) -> list[se.Symbol]:
        """Declare the inputs, in order, each with its (lower, upper) limit: finite, lower <
        upper, within +-MAX_INPUT. The symbols are returned for symmetry; f, g and h must
        not use them (the system is control-affine through g)."""
        if self.input_names:
            raise SpecError(f"{self.where}: inputs declared twice")
        names, docs = self._names("inputs", names, docs)
        if isinstance(limits, str) or not isinstance(limits, Sequence) or len(limits) != len(names):
            raise SpecError(f"{self.where}: limits must hold one (lower, upper) pair per input "
                            f"({len(names)}), got {limits!r}")
        parsed = []
        for n, lim in zip(names, limits, strict=True):
            key = f"limits of input {n!r}"
            if not isinstance(lim, Sequence) or len(lim) != 2:
                raise SpecError(f"{self.where}: {key} must be a (lower, upper) pair, got {lim!r}")
            lo, hi = (_number(self.where, key, v) for v in lim)
            if not all(math.isfinite(v) and abs(v) <= MAX_INPUT for v in (lo, hi)) or not lo < hi:
                raise SpecError(f"{self.where}: {key} are ({lo}, {hi}); they must be finite, within "
                                f"+-{MAX_INPUT:g} and lower < upper")
            parsed.append(Limits(lo, hi))
        clash = set(names) & set(self.state_names)
        if clash:
            raise SpecError(f"{self.where}: {sorted(clash)} named both state and input")
        self.input_names, self.input_docs, self.input_limits = names, docs, parsed
        self.u = [se.Symbol(f"u_{n}") for n in names]
        return list(self.u)

    def dynamics(self, f: Sequence[object], g: Sequence[Sequence[object]]) -> None:
        """x' = f(x) + g(x) u: ``f`` one entry per state, ``g`` one row per state with one
        entry per input. Both may depend on the states only."""
        if not self.state_names or not self.input_names:
            raise SpecError(f"{self.where}: declare states and inputs before dynamics")
        nx, nu = len(self.state_names), len(self.input_names)
        if isinstance(f, str) or not isinstance(f, Sequence) or len(f) != nx:
            raise SpecError(f"{self.where}: dynamics f must have one entry per state ({nx}), got "
                            f"{len(f) if isinstance(f, Sequence) else f!r}")
        if (isinstance(g, str) or not isinstance(g, Sequence) or len(g) != nx
                or any(isinstance(r, str) or not isinstance(r, Sequence) or len(r) != nu for r in g)):
            raise SpecError(f"{self.where}: dynamics g must be {nx} rows (states) of {nu} entries "
                            "(inputs)")
        fx = [_expr(self.where, f"dynamics f[{i}]", e) for i, e in enumerate(f)]
        gx = [[_expr(self.where, f"dynamics g[{i}][{j}]", e) for j, e in enumerate(r)]
              for i, r in enumerate(g)]
        allowed = set(self.x)
        for key, e in [(f"f[{i}]", e) for i, e in enumerate(fx)] + [
                (f"g[{i}][{j}]", e) for i, r in enumerate(gx) for j, e in enumerate(r)]:
            stray = e.free_symbols - allowed
            if stray:
                raise SpecError(f"{self.where}: dynamics {key} = {e} uses {sorted(map(str, stray))}; "
                                "f and g may depend on the states only")
        if all(e == 0 for r in gx for e in r):
            raise SpecError(f"{self.where}: dynamics g is identically zero; no input acts on the system")
        self.f, self.g = fx, gx

    # --------------------------------------------------------------- families
    def family(self, name: str, h: Callable[[FamilyContext], object], *,
               params: dict[str, object] | None = None, count: int | None = None,
               capacity: bool | int = False, optional: bool = False, over: Sequence[str] | None = None,
               time: bool = False, poles: Sequence[float] | None = None,
               priority: int = 0, activation: float = math.inf,
               lower_bound: Callable[[FamilyContext], se.Expr] | None = None,
               defaults: dict[str, object] | None = None,
               class_k: Callable[[se.Symbol], object] | None = None,
               compose: bool = False,
               doc: str = "", **removed: object) -> None:
        """Declare a barrier family h(x, params[, t]) >= 0.

        A fixed instance's parameters start *unset*: the filter refuses to run (an error
        naming family, instance and parameter) until each is set, so a forgotten room
        size is never a zero-size room. ``defaults={"vmax": 1.0}`` gives parameters a
        value to start from instead (a number, or a list shaped as the parameter, matrices
        row by row); it is for fixed instances, not capacity families.

        ``params`` maps names to shapes (``()``, ``(n,)``, ``(rows, cols)``), or to
        ``(shape, doc)``, ``(shape, domain)`` or ``(shape, doc, domain)`` (see the
        module's "Parameters and their domains"). ``count`` (default 1) fixes the number of instances; ``capacity=True``
        instead fills them at run time, up to a capacity chosen when the barrier set is
        built and at most MAX_INSTANCES (``capacity=N``: at most N, the largest count that
        makes sense for the system). ``optional=True`` (with ``count``) lets each fixed
        instance be switched off at run time (its parameters are an ``Option``).
        ``poles`` must have one entry per derivative (the relative degree the Lie engine
        finds); omitted, they default to DEFAULT_POLE. ``activation``: the row takes part
        only while h is below it (inf = always). ``priority`` (0 to MAX_PRIORITY, default
        0) says who yields when rows conflict: the filter meets every row exactly when the
        input limits allow it; when they do not, priority 0 is met first (relaxed as little
        as possible only where the limits leave no way), then 1 in the room 0 leaves, and
        so on. Put the mechanism and the environment at 0 and preferences after them.

        ``over=["lf", "rf", ...]`` makes the family *indexed*: ``h`` is called once per
        member, with ``p.index`` / ``p.label`` saying which (a robot's legs, an arm's
        links), and each member gets its own kernel, its own instances (``count`` or a
        capacity per member) and rows, members in ``over`` order. All members share the
        parameters, row names, relative degree and defaults.

        ``lower_bound=lambda p: ...`` (with a finite ``activation`` threshold) gives one
        cheap expression of the same ``p`` that is **never above any row's h** of the
        instance (of the member, for a family without parameters), at any state and
        parameter value (bounding spheres, face axes:
        ``symbolic.families.ssat.lower_bound``, ``sphere_box.lower_bound``). Where it
        exceeds the activation threshold the instance's rows are not evaluated that cycle:
        they could not take part. It changes the cost of an update, never its input, as
        long as it is a true bound: the generated ``<family>_lower_bound`` kernel is in the
        module's kernel table, so test it against the rows (a property test over states).

        ``class_k=lambda s: s**3`` gives the last ECBF term an *extended* class-K function
        alpha: with poles p_1 ... p_r the row becomes psi' + p_r alpha(psi) >= 0, where
        psi = (d/dt + p_1)...(d/dt + p_(r-1)) h (psi = h for relative degree 1); linear
        alpha(s) = s (the default) is the plain ECBF. alpha must be odd, strictly
        increasing and through 0 (checked at generation over |s| in [1e-6, 1e3]), of s
        alone; it is generated as ``<family>_class_k(s)`` and evaluated each cycle.
        s**3 lets the boundary be approached later and damps it harder near it; tanh(s)
        caps the approach rate at p_r far from it (cbfgen::system::ClassK).

        ``compose=True`` builds the rows from parts instead of unrolling each member: h
        must be one composable primitive (``prim.ssat``) of boxes that each either move
        with the state (a link's box) or are fixed by numbers and parameters (an
        obstacle). Each moving box's pose becomes a *pose kernel* with its Lie
        derivatives (shared by every member and family that places the same box the same
        way), the primitive one *chain kernel* per family with the boxes' sizes as
        arguments, and each member a few lines that call them and contract the chain's
        gradient with the poses' input columns. The rows are the same functions as
        unrolled (the SymEngine cross-check compares them), in a fraction of the code:
        what makes an arm's or a legged robot's collision pairs cheap to regenerate and
        compile. Not for time-varying families.
        """
        _refuse_keywords(f"family {name!r}", removed)
        where = f"{self.where}, family {name!r}"
        check_identifier(self.where, "family name", name, module_item=True)
        if any(fam.name == name for fam in self.families):
            raise SpecError(f"{where}: declared twice")
        if not callable(h):
            raise SpecError(f"{where}: h must be a function of the parameters (lambda p: ...)")
        params = {} if params is None else params
        if not isinstance(params, dict):
            raise SpecError(f"{where}: params must be a dict of name -> shape")
        parsed = [_param(where, n, shape) for n, shape in params.items()]
        if defaults is not None:
            parsed = _with_defaults(where, parsed, defaults, capacity is not False)
        if not all(isinstance(v, bool) for v in (optional, time)):
            raise SpecError(f"{where}: optional and time are True or False")
        max_capacity = None
        if capacity is not False:
            max_capacity = MAX_INSTANCES if capacity is True else capacity
            if isinstance(max_capacity, bool) or not isinstance(max_capacity, int) or not (
                    1 <= max_capacity <= MAX_INSTANCES):
                raise SpecError(f"{where}: capacity is True or the largest capacity allowed, an integer in "
                                f"[1, {MAX_INSTANCES}]; got {capacity!r}")
            capacity = True
        labels = None
        if over is not None:
            if isinstance(over, str) or not isinstance(over, Sequence) or not 1 <= len(over) <= 256:
                raise SpecError(f"{where}: over must be a list of 1 to 256 member names, got {over!r}")
            labels = [check_identifier(where, "member name in over", m) for m in over]
            if len(set(labels)) != len(labels):
                raise SpecError(f"{where}: over {labels} repeats a name")
        if optional and (capacity or not parsed):
            raise SpecError(f"{where}: optional=True is for fixed instances (count) with params; a "
                            "capacity family is switched per instance by filling it")
        if capacity:
            if count is not None:
                raise SpecError(f"{where}: give count or capacity=True, not both")
            if not parsed:
                raise SpecError(f"{where}: capacity=True needs params (instances differ only in them)")
        else:
            count = 1 if count is None else count
            if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_INSTANCES:
                raise SpecError(f"{where}: count must be an integer in [1, {MAX_INSTANCES}], got {count!r}")
            if count > 1 and not parsed:
                raise SpecError(f"{where}: count={count} without params gives {count} identical rows")
        pole_list = None
        if poles is not None:
            if isinstance(poles, str) or not isinstance(poles, Sequence) or not poles:
                raise SpecError(f"{where}: poles must be a non-empty list of numbers, got {poles!r}")
            pole_list = [_number(where, "poles", p) for p in poles]
            lo, hi = POLE_RANGE
            bad = [p for p in pole_list if not lo <= p <= hi]
            if bad:
                raise SpecError(f"{where}: poles {bad} outside [{lo:g}, {hi:g}] 1/s")
        if isinstance(priority, bool) or not isinstance(priority, int) or not 0 <= priority <= MAX_PRIORITY:
            raise SpecError(f"{where}: priority must be an integer in [0, {MAX_PRIORITY}] (0 is met first), "
                            f"got {priority!r}")
        activation = _number(where, "activation", activation)
        if not activation > 0:
            raise SpecError(f"{where}: activation {activation} must be > 0 (inf = always active)")
        if not isinstance(doc, str):
            raise SpecError(f"{where}: doc must be a string")
        if lower_bound is not None:
            if not callable(lower_bound):
                raise SpecError(f"{where}: lower_bound must be a function of the parameters (lambda p: ...)")
            if math.isinf(activation):
                raise SpecError(f"{where}: lower_bound skips instances above the activation threshold; it needs "
                                "a finite activation")
        if class_k is not None and not callable(class_k):
            raise SpecError(f"{where}: class_k must be a function of one symbol (lambda s: ...), got {class_k!r}")
        if not isinstance(compose, bool):
            raise SpecError(f"{where}: compose is True or False, got {compose!r}")
        if compose and time:
            raise SpecError(f"{where}: compose=True is for time-invariant rows; declare time=True families "
                            "without it")
        self.families.append(Family(name, h, parsed, None if capacity else count, capacity, max_capacity,
                                    optional, labels,
                                    time, pole_list, priority, activation, doc, lower_bound, caller_origin(),
                                    class_k, compose=compose))

    def lyapunov(self, name: str, V: Callable[[FamilyContext], object], *, rate: float,
                 params: dict[str, object] | None = None, count: int | None = None,
                 capacity: bool | int = False, optional: bool = False, over: Sequence[str] | None = None,
                 time: bool = False, priority: int = MAX_PRIORITY,
                 defaults: dict[str, object] | None = None,
                 class_k: Callable[[se.Symbol], object] | None = None, doc: str = "",
                 **removed: object) -> None:
        """Declare a control Lyapunov function V(x, params[, t]) >= 0: its rows ask for
        the decrease V' + rate * V <= 0 (exponential convergence at ``rate`` 1/s), relaxed
        by as little as the rows above it leave room for.

        A Lyapunov family is a barrier family on h = -V with the one pole ``rate`` (V' must
        depend on the input: relative degree 1), marked so that the filter reports its
        relaxation as convergence given up (``Output::convergence``), never as a safety
        verdict. ``priority`` (1 to MAX_PRIORITY, default MAX_PRIORITY: below every
        barrier) is never 0, so safety rows never yield to it. The other arguments are as
        :meth:`family`'s; ``class_k`` replaces rate * V by rate * alpha(V) (alpha odd,
        increasing, through 0).
        """
        _refuse_keywords(f"lyapunov {name!r}", removed)
        where = f"{self.where}, lyapunov {name!r}"
        if not callable(V):
            raise SpecError(f"{where}: V must be a function of the parameters (lambda p: ...)")
        if isinstance(priority, bool) or not isinstance(priority, int) or not 1 <= priority <= MAX_PRIORITY:
            raise SpecError(f"{where}: priority must be an integer in [1, {MAX_PRIORITY}] (a Lyapunov family "
                            f"never shares tier 0 with the safety rows), got {priority!r}")
        self.family(name, V, params=params, count=count, capacity=capacity, optional=optional, over=over,
                    time=time, poles=[rate], priority=priority, defaults=defaults, class_k=class_k, doc=doc)
        self.families[-1].kind = "lyapunov"

    # -------------------------------------------------- constants and outputs
    def constant(self, name: str, value: object, doc: str) -> None:
        """A named constant of the generated module (``UPPER_SNAKE`` in it): a number, a
        string, or a (nested, rectangular) list of them: a robot's dimensions that its
        scenario code needs, from the same file the kernels are built from. Integers
        stay integers (``usize`` in Rust; non-negative only); mixed lists are floats."""
        where = f"{self.where}, constant {name!r}"
        check_identifier(self.where, "constant name", name, local=False)
        if any(c.name == name for c in self.constants):
            raise SpecError(f"{where}: declared twice")
        if not isinstance(doc, str) or not doc.strip():
            raise SpecError(f"{where}: give a doc string (what it is, with its unit)")
        self.constants.append(Constant(name, _constant_value(where, value), doc))

    def output(self, name: str, outputs: Sequence[tuple[str, object, str]], doc: str, *,
               inputs: bool = False) -> None:
        """A function of the state the generated module exposes besides the barriers: forward
        kinematics, a contact point, an energy. ``outputs`` are ``(name, value, doc)`` with
        ``value`` an expression, a list of them (vector) or a list of equal-length lists
        (matrix, returned row by row). Depends on the states only; with ``inputs=True`` on
        the states and the inputs (the generated function then takes ``u`` after ``x``):
        what an MPC linearises, such as x' = f(x) + g(x) u and its Jacobians."""
        where = f"{self.where}, output {name!r}"
        check_identifier(self.where, "output name", name, module_item=True)
        if any(o.name == name for o in self.outputs):
            raise SpecError(f"{where}: declared twice")
        if isinstance(outputs, str) or not isinstance(outputs, Sequence) or not outputs:
            raise SpecError(f"{where}: outputs must be a non-empty list of (name, value, doc)")
        parsed = []
        for item in outputs:
            if not (isinstance(item, (list, tuple)) and len(item) == 3 and isinstance(item[2], str)):
                raise SpecError(f"{where}: each output is (name, value, doc), got {item!r}")
            oname, value, odoc = item
            check_identifier(where, "output value name", oname)
            allowed = set(self.x) | (set(self.u) if inputs else set())
            parsed.append((oname, _output_value(f"{where}, value {oname!r}", value, allowed, inputs), odoc))
        names = [n for n, _, _ in parsed]
        if len(set(names)) != len(names):
            raise SpecError(f"{where}: value names {names} repeat a name")
        self.outputs.append(Output(name, parsed, doc, inputs))

    def rigid_body_output(self, name: str, dynamics, velocity: Sequence[se.Expr], doc: str, *,
                          order: Sequence[int] | None = None,
                          mass_doc: str = "joint-space mass matrix M(q)",
                          bias_doc: str = "C(q, v) v + g(q): the generalized forces at zero acceleration") -> None:
        """The output ``name`` of two values, ``mass_matrix`` M(q) and ``bias``
        C(q, v) v + g(q), of ``dynamics`` (a ``symbolic.dynamics.RigidBodyDynamics``) at the
        velocities ``velocity`` (one per degree of freedom, in its ``dofs`` order; each a
        state), rows and columns in ``order`` (indices into ``dofs``; default as they are).
        Generated as the tree in numbers and the run time's composite-rigid-body and
        Newton–Euler algorithms (``cbfgen::rigid_body``), not as unrolled expressions: a
        floating quadruped's M and bias unrolled are ten thousand lines. The expressions
        remain the definition the generated function is tested against."""
        where = f"{self.where}, output {name!r}"
        tree = dynamics.tree(self.x, velocity)
        n = len(dynamics.dofs)
        order = tuple(range(n)) if order is None else tuple(order)
        if sorted(order) != list(range(n)):
            raise SpecError(f"{where}: order must list each of the {n} degrees of freedom once, got {order}")
        mass, bias = dynamics.mass_matrix(), dynamics.bias(velocity)
        self.output(name, [("mass_matrix", [[mass[i][j] for j in order] for i in order], mass_doc),
                           ("bias", [bias[i] for i in order], bias_doc)], doc)
        self.outputs[-1] = replace(self.outputs[-1], tree=tree, order=order)

    def objective(self, P: object, q: object = None, *, doc: str = "") -> None:
        """The filter's cost, a quadratic in the input with coefficients of the state:
        the filter minimises ``1/2 (u - u_ref)^T P(x) (u - u_ref) + q(x)^T u`` (pass
        ``u_ref = 0`` for ``1/2 u^T P u + q^T u`` alone) instead of the input weights'
        ``sum_j w_j (u_j - u_ref_j)^2``; priorities still come first. ``P`` is an
        ``NU x NU`` list of rows, symmetric (checked here, symbolically) and positive
        definite wherever the filter runs (checked every cycle: an update at a state where
        it is not is a typed error, ``NotPositiveDefinite``); ``q`` a list of ``NU``
        (default zeros). Both depend on the states only. The filter's input weights must
        then stay at 1."""
        where = f"{self.where}, objective"
        if self.cost is not None:
            raise SpecError(f"{where}: declared twice")
        if not self.input_names:
            raise SpecError(f"{where}: declare the inputs first (P is NU x NU)")
        nu = len(self.input_names)
        states = set(self.x)
        if (isinstance(P, str) or not isinstance(P, Sequence) or len(P) != nu
                or not all(isinstance(r, Sequence) and not isinstance(r, str) and len(r) == nu for r in P)):
            raise SpecError(f"{where}: P must be {nu} x {nu}: a list of {nu} rows of {nu} entries (one per "
                            f"input), got {P!r}")
        matrix = [[_state_expr(f"{where}, P[{i}][{j}]", e, states) for j, e in enumerate(row)]
                  for i, row in enumerate(P)]
        for i in range(nu):
            for j in range(i + 1, nu):
                if se.expand(matrix[i][j] - matrix[j][i]) != 0:
                    raise SpecError(f"{where}: P is not symmetric: P[{i}][{j}] = {matrix[i][j]} but P[{j}][{i}] = "
                                    f"{matrix[j][i]}")
        if q is None:
            q = [0] * nu
        if isinstance(q, str) or not isinstance(q, Sequence) or len(q) != nu:
            raise SpecError(f"{where}: q must be a list of {nu} entr{'y' if nu == 1 else 'ies'} (one per input), "
                            f"got {q!r}")
        linear = [_state_expr(f"{where}, q[{j}]", e, states) for j, e in enumerate(q)]
        for i in range(nu):
            if matrix[i][i].is_number and not float(matrix[i][i]) > 0:
                raise SpecError(f"{where}: P[{i}][{i}] = {matrix[i][i]}: a positive definite P has a positive "
                                "diagonal")
        if not isinstance(doc, str):
            raise SpecError(f"{where}: doc must be a string")
        self.cost = Objective(matrix, linear, doc)

    def check_complete(self) -> None:
        if not self.state_names:
            raise SpecError(f"{self.where}: no states declared")
        if not self.input_names:
            raise SpecError(f"{self.where}: no inputs declared")
        if self.f is None:
            raise SpecError(f"{self.where}: no dynamics declared")
        if not self.families:
            raise SpecError(f"{self.where}: no barrier families declared")

    # ----------------------------------------------------------- dependencies
    def depends_on(self, *paths: str | Path) -> list[Path]:
        """Name data files the spec reads (a TOML with the robot's numbers, a table, ...):
        each becomes part of the generated file's inputs hash, and of the build script's
        rerun list, so editing one regenerates the system. A relative path is relative to
        the spec file's folder, an absolute one is taken as it is. Modules the spec imports
        from its own folder tree are tracked without this (see :func:`load`).

        Each path must name an existing file; that is checked once the spec's location is
        known (by :func:`load`, after ``build()``, or at once on a loaded system). Returns
        every data file named so far, resolved, once the location is known ([] before)."""
        named: list[Path] = self.__dict__.setdefault("_depends_on", [])
        for p in paths:
            try:
                path = Path(p)
            except TypeError:
                raise SpecError(f"{self.where}: depends_on takes file paths (str or Path), got {p!r}") from None
            if "\n" in str(path) or "\r" in str(path):
                raise SpecError(f"{self.where}: depends_on({str(path)!r}): a path may not contain a line break")
            named.append(path)
        if self.source is None:
            return []
        folder = Path(self.source).resolve().parent
        files = []
        for path in named:
            file = (folder / path).resolve()
            if not file.is_file():
                raise SpecError(f"{self.where}: depends_on({str(path)!r}): {file} is not a file (a relative "
                                f"path is relative to the spec's folder, {folder})")
            files.append(file)
        return files


def load(path: str | Path) -> System:
    """Import the spec file at ``path`` and call its ``build()``.

    The spec's folder is first on ``sys.path`` meanwhile, so the spec can import modules
    kept beside it (``from my_robot_model import ...``, or a package folder there). The
    files of the modules it imports from its own folder tree, and the data files it names
    with :meth:`System.depends_on`, become ``system.dependencies``: resolved paths, sorted,
    without the spec itself. Files the package hash covers (``symbolic/``) and installed
    or standard-library modules are not dependencies. Each load imports the folder's
    modules afresh and takes them out of ``sys.modules`` again afterwards, so an edited
    module, or a second spec in the same folder, is seen as it is; no bytecode is written
    beside the spec."""
    import sysconfig

    from .inputs_hash import HASHED_SUFFIXES, SKIPPED_DIRS

    path = Path(path)
    if not path.is_file():
        raise SpecError(f"spec {path}: no such file")
    spec_file = path.resolve()
    folder = spec_file.parent
    package = Path(__file__).resolve().parent
    installed = [Path(p).resolve() for key, p in sysconfig.get_paths().items()
                 if key in ("stdlib", "platstdlib", "purelib", "platlib")]

    def local_file(module: object) -> Path | None:
        """The module's file when it is one of the spec's dependencies."""
        name = getattr(module, "__file__", None)
        if not isinstance(name, str) or not name:
            return None
        file = Path(os.path.abspath(name)).resolve()
        if file == spec_file or not file.is_relative_to(folder) or not file.is_file():
            return None
        if {"site-packages", "dist-packages"} & set(file.parts) or any(file.is_relative_to(d) for d in installed):
            return None
        if file.is_relative_to(package):
            dirs = file.relative_to(package.parent).parts[:-1]
            if file.name.endswith(HASHED_SUFFIXES) and not any(d in SKIPPED_DIRS or d.startswith(".") for d in dirs):
                return None  # hashed with the package
        return file

    # Modules of the folder imported earlier (a previous load, the caller) are set aside,
    # so the spec's imports run again and are seen.
    set_aside = {name: module for name, module in list(sys.modules.items())
                 if name != "__main__" and local_file(module) is not None}
    for name in set_aside:
        del sys.modules[name]
    before = set(sys.modules)
    module_name = f"cbfgen_spec_{re.sub(r'[^0-9a-zA-Z_]', '_', path.stem)}"
    loader_spec = importlib.util.spec_from_file_location(module_name, path)
    if loader_spec is None or loader_spec.loader is None:
        sys.modules.update(set_aside)
        raise SpecError(f"spec {path}: cannot be imported as a Python file")
    module = importlib.util.module_from_spec(loader_spec)
    imported: set[Path] = set()
    sys.path.insert(0, str(folder))
    write_bytecode, sys.dont_write_bytecode = sys.dont_write_bytecode, True
    importlib.invalidate_caches()
    try:
        loader_spec.loader.exec_module(module)
        build = getattr(module, "build", None)
        if not callable(build):
            raise SpecError(f"spec {path}: defines no build() function")
        system = build()
    finally:
        sys.dont_write_bytecode = write_bytecode
        if str(folder) in sys.path:
            sys.path.remove(str(folder))
        for name in [n for n in sys.modules if n not in before]:
            file = local_file(sys.modules[name])
            if file is not None:
                imported.add(file)
                del sys.modules[name]
        sys.modules.update(set_aside)
    if not isinstance(system, System):
        raise SpecError(f"spec {path}: build() returned {type(system).__name__}, not a System")
    system.source = path
    system.dependencies = sorted(imported | set(system.depends_on()))
    return system
