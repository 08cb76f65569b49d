"""Composed rows: a pair row built from per-body pose kernels and one primitive kernel.

Unrolled, a collision row between two links differentiates both links' kinematics, the
primitive (the smooth SAT) and their product to the relative degree, once per pair: tens
of thousands of lines for an arm, most of them the same kinematics again. Composed, the
row h(x) = phi(y_A(x), y_B(x)) is cut where the bodies' poses enter:

* a **pose kernel** per distinct placed box, ``y`` = centre (3) and rotation (9, row
  major) with its drift derivatives ``L_f y ... L_f^r y`` and ``L_g L_f^(r-1) y`` on the
  inputs it depends on, shared by every member and family that places the box the same
  way (same expressions, same frame);
* a **chain kernel** per family: phi and its Lie derivatives along a pseudo-system whose
  states are the poses and their first r-1 derivatives and whose r-th derivatives are
  arguments. Along the real system the chain rule gives exactly the same functions:
  with d^k y/dt^k = L_f^k y (true while L_g L_f^k y = 0 for k < r-1, which the pose
  kernel checks by finding its degree), L_f^k h is the pseudo-system's L_f^k phi and
  L_g L_f^(r-1) h = grad phi . L_g L_f^(r-1) y. The boxes' sizes are arguments, so one
  chain serves every member;
* per member, a call of each and the gradient contracted with the poses' input columns
  (``cbfgen::compose::accumulate_columns``).

A box fixed by numbers or the family's parameters (an obstacle) enters the chain as a
pose argument with no derivatives. The unrolled rows stay the definition the tests hold
the composed ones to (``define(..., unrolled=True)``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import symengine as se

from ..kernel import Kernel, Let, RuntimeMax
from ..lie import MAX_RELATIVE_DEGREE, LieEngine
from ..spec import FamilyContext, SpecError

POSE_SIZE = 12  # centre (3), then the rotation row by row (9)
SLOTS = "ab"
_POSE_COMPONENTS = ["x", "y", "z"] + [f"r{i}{j}" for i in range(3) for j in range(3)]


@dataclass(frozen=True)
class Recorded:
    """One composable primitive call of a family's h: what it computes and on what."""

    primitive: str
    build: Callable[..., se.Expr]  # (ctx, *boxes, **options) -> the primitive's expression
    boxes: tuple
    options: dict
    placeholder: se.Symbol
    names: tuple[str | None, ...]  # the spec's names for the boxes' pose kernels


class Recorder:
    """Given to a ``compose=True`` family's context: composable primitives record their
    call here and return a placeholder instead of their expression."""

    def __init__(self) -> None:
        self.calls: list[Recorded] = []

    def record(self, primitive: str, build: Callable[..., se.Expr], boxes: Sequence, options: dict,
               names: Sequence[str | None]) -> se.Symbol:
        placeholder = se.Symbol(f"composed_{primitive}_{len(self.calls)}")
        if len(names) != len(boxes):
            raise SpecError(f"{primitive}: names has {len(names)} entries for {len(boxes)} boxes")
        self.calls.append(Recorded(primitive, build, tuple(boxes), dict(options), placeholder, tuple(names)))
        return placeholder


def pose_entries(box) -> list[se.Expr]:
    """A box's pose as the 12 entries a pose kernel returns."""
    center, rotation, _ = box
    return [se.sympify(e) for e in [*center, *(rotation[r][c] for r in range(3) for c in range(3))]]


# A static entry of a pose or of a size: a number, or component ``index`` of parameter ``name``.
Static = float | tuple[str, int]


@dataclass(frozen=True)
class Slot:
    """One box of a composed member: moving (``jet`` names its pose kernel, ``at`` where
    that kernel's input columns sit among the member's) or fixed (``pose``)."""

    jet: str | None
    at: tuple[int, ...]
    pose: tuple[Static, ...]
    half: tuple[Static, ...]

    @property
    def moving(self) -> bool:
        return self.jet is not None


@dataclass(frozen=True)
class BoundPlan:
    """How one member's lower bound is assembled: its boxes' value kernels (``Slot.jet``
    names them here), the family's bound kernel."""

    kernel: str
    chain: str
    slots: tuple[Slot, ...]


@dataclass(frozen=True)
class MemberPlan:
    """How one member's row function is assembled: its pose kernels, the family's chain."""

    kernel: str
    chain: str
    slots: tuple[Slot, ...]
    columns: tuple[int, ...]
    bound: BoundPlan | None = None


@dataclass(frozen=True)
class Jet:
    kernel: Kernel
    degree: int
    columns: tuple[int, ...]


def _closure(source: Kernel, exprs: Sequence[se.Expr]) -> list[Let | RuntimeMax]:
    """The definitions of ``source`` that ``exprs`` read, directly or through others, in
    declaration (evaluation) order."""
    defs = {d.symbol: d for d in source.definitions}
    needed: set[se.Symbol] = set()
    stack = [s for e in exprs for s in e.free_symbols if s in defs]
    while stack:
        sym = stack.pop()
        if sym in needed:
            continue
        needed.add(sym)
        d = defs[sym]
        for e in ([d.expr] if isinstance(d, Let) else d.exprs):
            stack.extend(s for s in e.free_symbols if s in defs and s not in needed)
    return [d for d in source.definitions if d.symbol in needed]


class Jets:
    """The system's pose kernels, one per distinct placed box (key: its entries and every
    definition they read, as text: the same kinematics in the same frame gives the same)."""

    def __init__(self, system) -> None:
        self.system = system
        self._by_key: dict[tuple, Jet] = {}
        self._values: dict[tuple, Kernel] = {}
        self.kernels: list[Kernel] = []

    def _key(self, where: str, name: str, entries: Sequence[se.Expr], source: Kernel, known: dict):
        """(the placement's key, the definitions it reads); a new placement under a name
        already taken is an error."""
        defs = _closure(source, entries)
        key = (tuple(map(str, entries)),
               tuple((str(d.symbol), str(d.expr) if isinstance(d, Let) else tuple(map(str, d.exprs)))
                     for d in defs))
        if key not in known and any(k.name == name for k in self.kernels):
            raise SpecError(f"{where}: pose kernel {name!r} already places another box (or the same box in "
                            "another frame); give each its own name")
        return key, defs

    def get(self, where: str, name: str, entries: Sequence[se.Expr], source: Kernel) -> Jet:
        key, defs = self._key(where, name, entries, source, self._by_key)
        if key not in self._by_key:
            self._by_key[key] = jet = self._build(where, name, entries, defs)
            self.kernels.append(jet.kernel)
        return self._by_key[key]

    def value(self, where: str, name: str, entries: Sequence[se.Expr], source: Kernel) -> Kernel:
        """The value-only kernel ``<name>_value`` of a placed box (for lower bounds: the pose
        without its derivatives), shared as the pose kernels are."""
        value_name = f"{name}_value"
        key, defs = self._key(where, value_name, entries, source, self._values)
        if key not in self._values:
            k = Kernel(value_name, "The pose of a box, value only (what lower bounds read): centre, then rotation "
                                   "row by row.")
            k.array_input("x", self.system.state_names, "state, laid out as `STATE_NAMES`")
            for d in defs:
                if isinstance(d, Let):
                    k.let_(str(d.symbol), d.expr)
                else:
                    k.runtime_max(str(d.symbol), d.exprs)
            k.output_vector("pose", list(entries), "centre [m], then rotation row by row (columns = the box's axes)")
            self._values[key] = k
            self.kernels.append(k)
        return self._values[key]

    def _build(self, where: str, name: str, entries: Sequence[se.Expr], defs) -> Jet:
        s = self.system
        k = Kernel(name, f"The pose of a box the rows of {where.split(', ', 1)[-1]} compose (and every row that "
                         "places the same box the same way): centre and rotation (row by row), their drift "
                         "derivatives and the input part of the last.")
        k.array_input("x", s.state_names, "state, laid out as `STATE_NAMES`")
        eng = LieEngine(k, s.x, s.f, s.g)
        for d in defs:
            if isinstance(d, Let):
                eng.let_(str(d.symbol), d.expr)
            else:
                k.runtime_max(str(d.symbol), d.exprs)
        lf = [list(entries)]
        for level in range(MAX_RELATIVE_DEGREE):
            lg = {(i, u): e for i, y in enumerate(lf[-1]) for u in range(eng.nu) if (e := eng.along(y, u)) != 0}
            lf.append([eng.along(y, None) for y in lf[-1]])
            if lg:
                degree = level + 1
                break
        else:
            raise SpecError(f"{where}: a moving box's pose does not depend on the input within "
                            f"{MAX_RELATIVE_DEGREE} derivatives; no row on it can be enforced")
        columns = tuple(sorted({u for _, u in lg}))
        upper = name.upper()
        k.constant(f"{upper}_RELATIVE_DEGREE", "usize", str(degree),
                   f"Derivatives of the pose in [`{name}`] before the input appears (found symbolically).")
        k.constant(f"{upper}_INPUT_COLUMNS", f"[usize; {len(columns)}]", str(list(columns)),
                   f"Input columns of `lg` in [`{name}`].")
        k.output_vector("pose", lf[0], "centre [m], then rotation row by row (columns = the box's axes)")
        k.output_vector("rates", [e for level in lf[1:] for e in level],
                        "L_f y, ..., L_f^r y of the pose y, one after the other")
        k.output_matrix("lg", [[lg.get((i, u), se.Integer(0)) for u in columns] for i in range(POSE_SIZE)],
                        "L_g L_f^(r-1) y: one row per pose entry, one column per input column")
        return Jet(k, degree, columns)


def build_chain(where: str, name: str, call: Recorded, moving: Sequence[bool], degree: int) -> Kernel:
    """The family's chain kernel: ``call``'s primitive of boxes posed by arguments, with
    its Lie derivatives along the pseudo-system of the moving poses (see the module)."""
    k = Kernel(name, f"The `{call.primitive}` rows of {where.split(', ', 1)[-1]} from their boxes' poses: "
                     "lie = h, L_f h, ..., L_f^r h and, per moving box, the gradient of h in its pose.")
    states: list[se.Symbol] = []
    drift: list[se.Expr] = []
    boxes = []
    for slot, is_moving in zip(SLOTS, moving, strict=True):
        pose = k.array_input(f"pose_{slot}", _POSE_COMPONENTS, f"box {slot.upper()}'s pose: centre [m], rotation "
                                                                 "row by row")
        if is_moving:
            rates = k.array_input(f"rates_{slot}",
                                  [f"d{d}_{c}" for d in range(1, degree + 1) for c in _POSE_COMPONENTS],
                                  f"box {slot.upper()}'s pose derivatives L_f y ... L_f^r y")
            levels = [pose] + [rates[POSE_SIZE * d:POSE_SIZE * (d + 1)] for d in range(degree)]
            for d in range(degree):
                states += levels[d]
                drift += levels[d + 1]
        boxes.append(pose)
    halves = [k.array_input(f"half_{slot}", ["x", "y", "z"], f"box {slot.upper()}'s half extents [m]")
              for slot in SLOTS]
    n_moving = sum(moving)
    # The input acts on each moving pose's highest derivative below r: one column per entry.
    g = [[se.Integer(0)] * (POSE_SIZE * n_moving) for _ in states]
    for m in range(n_moving):
        for i in range(POSE_SIZE):
            g[m * degree * POSE_SIZE + (degree - 1) * POSE_SIZE + i][m * POSE_SIZE + i] = se.Integer(1)
    eng = LieEngine(k, states, drift, g)
    ctx = FamilyContext(where, k, eng, {}, None)
    with ctx.active():
        from ..primitives import Box
        placed = [Box(pose[:3], [pose[3 + 3 * r:6 + 3 * r] for r in range(3)], half)
                  for pose, half in zip(boxes, halves, strict=True)]
        h = call.build(ctx, *placed, **call.options)
    row = eng.row(h, name)
    if row.degree != degree:
        raise SpecError(f"{where}: the composed {call.primitive} has relative degree {row.degree} in its boxes' "
                        f"poses, not the poses' {degree}; declare the family without compose=True")
    k.output_vector("lie", list(row.lf), "h, L_f h, ..., L_f^r h")
    for m, slot in enumerate(s for s, is_moving in zip(SLOTS, moving, strict=True) if is_moving):
        k.output_vector(f"grad_{slot}", [row.lg.get(m * POSE_SIZE + i, se.Integer(0)) for i in range(POSE_SIZE)],
                        f"dh / d(box {slot.upper()}'s pose)")
    return k


def build_bound(where: str, name: str, call: Recorded) -> Kernel:
    """The family's bound kernel: ``call``'s (value-only) primitive of boxes posed by
    arguments: what a composed family's ``lower_bound`` is per member."""
    k = Kernel(name, f"The `{call.primitive}` of {where.split(', ', 1)[-1]} from its boxes' poses.")
    poses = [k.array_input(f"pose_{slot}", _POSE_COMPONENTS, f"box {slot.upper()}'s pose: centre [m], rotation "
                                                             "row by row") for slot in SLOTS]
    halves = [k.array_input(f"half_{slot}", ["x", "y", "z"], f"box {slot.upper()}'s half extents [m]")
              for slot in SLOTS]
    ctx = FamilyContext(where, k, k, {}, None)
    with ctx.active():
        from ..primitives import Box
        placed = [Box(pose[:3], [pose[3 + 3 * r:6 + 3 * r] for r in range(3)], half)
                  for pose, half in zip(poses, halves, strict=True)]
        k.output_scalar("bound", call.build(ctx, *placed, **call.options), "the bound [m]")
    return k
