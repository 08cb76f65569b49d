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

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

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
    # The bound kernel's numeric options (the primitive's sharpness), in its argument order.
    options: tuple[float, ...] = ()
    # The core's generated module that holds the bound kernel (see LIBRARY), else None.
    library: str | None = None


@dataclass(frozen=True)
class MemberPlan:
    """How one member's row function is assembled: its pose kernels, the family's chain."""

    kernel: str
    chain: str
    slots: tuple[Slot, ...]
    columns: tuple[int, ...]
    bound: BoundPlan | None = None
    # The chain's numeric options (the primitive's sharpness), in its argument order.
    options: tuple[float, ...] = ()
    # The core's generated module that holds the chain (see LIBRARY), else None.
    library: str | None = None


@dataclass(frozen=True)
class FramePlan:
    """A member (or, ``degree`` 0, its lower bound) computed on the one frame its rows read:
    the kernel ``on_frame`` on the jet (or pose) the pose function ``frame`` returns."""

    kernel: str
    on_frame: str
    frame: str
    degree: int
    columns: int = 0  # the jet's input columns
    bound: FramePlan | None = None


@dataclass(frozen=True)
class Jet:
    """A node of a pose's path: its kernel, the derivatives before the input appears, the
    input columns of its ``lg``, and the frame node its kernel reads (None: the state
    alone)."""

    kernel: Kernel
    degree: int
    columns: tuple[int, ...]
    parent: Jet | None = None

    def path(self) -> list[Jet]:
        """The nodes from the root down to this one."""
        return [*(self.parent.path() if self.parent else []), self]


@dataclass(frozen=True)
class Placed:
    """A placed box's jet as the rows read it: the pose function ``name`` returns it."""

    name: str
    degree: int
    columns: tuple[int, ...]


@dataclass(frozen=True)
class ValueNode:
    kernel: Kernel
    parent: ValueNode | None = None

    def path(self) -> list[ValueNode]:
        return [*(self.parent.path() if self.parent else []), self]


class _FrameCut(NamedTuple):
    """Rows cut at the link frames they read (``Jets._frame_cut``)."""

    prefix: str  # the one moving frame they read
    defs: list  # the source kernel's definitions
    frames: dict  # frame prefix -> its 12 pose symbols
    local: list  # the definitions between the frame and the rows
    exprs: list  # the rows' expressions


@dataclass(frozen=True)
class PosePlan:
    """A pose function the rows call, assembled from node kernels along the kinematic
    tree: ``steps`` from the root frame down to the box; each after the first reads the
    previous one's jet (or, ``value``, its pose)."""

    name: str
    steps: tuple[str, ...]
    value: bool
    degree: int = 0
    columns: int = 0
    # The box fixed in the last node's frame: its origin in the frame's axes (3), then its
    # axes in the frame (rotation row by row, 9); None when the last node is the box's own.
    placement: tuple[float, ...] | None = None


# A frame is a group of 12 named intermediates <prefix>_p0 .. <prefix>_p2, <prefix>_r00 ..
# <prefix>_r22 (the names urdf.Kinematics gives every link pose it builds): a place where a
# pose's path can be cut, in the pose layout's order.
_FRAME_SUFFIXES = ("_p0", "_p1", "_p2", *(f"_r{i}{j}" for i in range(3) for j in range(3)))


def _def_exprs(d: Let | RuntimeMax) -> Sequence[se.Expr]:
    return [d.expr] if isinstance(d, Let) else d.exprs


def _frames(defs: Sequence[Let | RuntimeMax]) -> dict[str, tuple[se.Symbol, ...]]:
    """Every complete frame among ``defs``: prefix -> its 12 symbols in pose order."""
    lets = {str(d.symbol): d.symbol for d in defs if isinstance(d, Let)}
    frames = {}
    for name in lets:
        if name.endswith("_r00"):
            group = [f"{name[:-4]}{suffix}" for suffix in _FRAME_SUFFIXES]
            if all(g in lets for g in group):
                frames[name[:-4]] = tuple(lets[g] for g in group)
    return frames


def _cut(defs: Sequence[Let | RuntimeMax], exprs: Sequence[se.Expr], stop: dict[se.Symbol, str]):
    """The definitions ``exprs`` read without passing a frame's symbols (``stop``), in
    declaration order, and the frames they read."""
    by_symbol = {d.symbol: d for d in defs}
    needed: set[se.Symbol] = set()
    frames: set[str] = set()
    stack = [s for e in exprs for s in e.free_symbols]
    while stack:
        sym = stack.pop()
        if sym in stop:
            frames.add(stop[sym])
        elif sym in by_symbol and sym not in needed:
            needed.add(sym)
            d = by_symbol[sym]
            stack.extend(s for e in _def_exprs(d) for s in e.free_symbols)
    return [d for d in defs if d.symbol in needed], frames


_PLACEMENT_ROUNDING = 1e-15


def _placement(entries: Sequence[se.Expr], local, frame: Sequence[se.Symbol]) -> tuple[float, ...] | None:
    """(c, B) when ``entries`` (through the definitions ``local``) are a box rigidly fixed in
    ``frame`` = (p, R): centre p + R c and rotation R B with numbers c and B; else None."""
    full: dict[se.Symbol, se.Expr] = {}
    for d in local:
        if not isinstance(d, Let):
            return None
        full[d.symbol] = d.expr.xreplace(full)
    pose = [se.sympify(e).xreplace(full) for e in entries]
    p, r = frame[:3], [frame[3 + 3 * i:6 + 3 * i] for i in range(3)]
    c = [se.diff(pose[0], r[0][j]) for j in range(3)]
    axes = [[se.diff(pose[3 + j], r[0][k]) for j in range(3)] for k in range(3)]
    if not all(v.is_Number for v in [*c, *(v for row in axes for v in row)]):
        return None
    residuals = [pose[i] - p[i] - sum(r[i][j] * c[j] for j in range(3)) for i in range(3)]
    residuals += [pose[3 + 3 * i + j] - sum(r[i][k] * axes[k][j] for k in range(3)) for i in range(3) for j in range(3)]
    for residual in map(se.expand, residuals):
        # Zero, or what the numbers' rounding leaves (the same products summed in another
        # order): linear in the frame with coefficients below 1e-12 of its unit entries.
        if residual != 0 and not (residual.free_symbols <= set(frame) and all(
                term.is_Number and abs(float(term)) <= _PLACEMENT_ROUNDING
                for term in [se.diff(residual, v) for v in frame] + [residual.xreplace(dict.fromkeys(frame, 0))])):
            return None
    return tuple(float(v) for v in [*c, *(v for row in axes for v in row)])


def _text(entries: Sequence[se.Expr], defs: Sequence[Let | RuntimeMax]) -> tuple:
    return (tuple(map(str, entries)),
            tuple((str(d.symbol), str(d.expr) if isinstance(d, Let) else tuple(map(str, d.exprs))) for d in defs))


class Jets:
    """The system's pose functions, one per distinct placed box (key: its entries and every
    definition they read, as text: the same kinematics in the same frame gives the same).

    A box placed in a frame of a kinematic tree (a link pose from ``urdf.Kinematics``) is
    not differentiated whole: its path is cut at every frame, and each node's kernel takes
    its parent frame's jet (pose, its drift derivatives, input columns) as pseudo-states,
    as the chain kernels take the boxes' (module doc). A link then costs one joint's
    arithmetic, shared by every box below it, instead of the whole chain's derivatives
    again. A box whose pose reads no frame, or two, gets one whole kernel."""

    def __init__(self, system) -> None:
        self.system = system
        self._boxes: dict[tuple, Placed] = {}
        self._values: dict[tuple, str] = {}
        self._nodes: dict[tuple, Jet | ValueNode] = {}
        self.kernels: list[Kernel] = []
        self.poses: list[PosePlan] = []  # the pose functions assembled from several nodes
        self.pose_names: list[str] = []  # every pose function rows call, in first-use order
        self._shared: dict[tuple, Kernel] = {}
        self._emitted: set[str] = set()

    def nodes(self) -> list[tuple[str, str | None]]:
        """Every node kernel with the node kernel it reads (None: the state alone)."""
        return [(n.kernel.name, n.parent.kernel.name if n.parent else None) for n in self._nodes.values()]

    def shared(self, key: tuple, build: Callable[[], Kernel]) -> Kernel:
        """A chain or bound kernel, shared by every family of the system that calls the same
        primitive with the same options on the same moving boxes (key): the same function,
        emitted once under the first family's name."""
        if key not in self._shared:
            self._shared[key] = build()
        return self._shared[key]

    def first_use(self, kernel: Kernel) -> bool:
        """True the first time a family claims ``kernel`` for its own (to emit it)."""
        if kernel.name in self._emitted:
            return False
        self._emitted.add(kernel.name)
        return True

    def _checked_key(self, where: str, name: str, entries: Sequence[se.Expr], source: Kernel, known: dict):
        """(the placement's key, the definitions it reads); a new placement under a name
        already taken is an error."""
        defs, _ = _cut(source.definitions, entries, {})
        key = _text(entries, defs)
        if key not in known and name in self.pose_names:
            raise SpecError(f"{where}: pose kernel {name!r} already places another box (or the same box in "
                            "another frame); give each its own name")
        return key, defs

    def get(self, where: str, name: str, entries: Sequence[se.Expr], source: Kernel) -> Placed:
        """The jet of a placed box: the pose function that returns it, its degree and columns."""
        key, defs = self._checked_key(where, name, entries, source, self._boxes)
        if key not in self._boxes:
            jet, placement = self._box(where, name, list(entries), defs, value=False)
            self._boxes[key] = Placed(name, jet.degree, jet.columns)
            self._publish(name, jet, placement, value=False)
        return self._boxes[key]

    def value(self, where: str, name: str, entries: Sequence[se.Expr], source: Kernel) -> str:
        """The value-only pose function ``<name>_value`` of a placed box (for lower bounds:
        the pose without its derivatives), shared as the jets are."""
        value_name = f"{name}_value"
        key, defs = self._checked_key(where, value_name, entries, source, self._values)
        if key not in self._values:
            node, placement = self._box(where, value_name, list(entries), defs, value=True)
            self._values[key] = value_name
            self._publish(value_name, node, placement, value=True)
        return self._values[key]

    def _frames(self, defs) -> dict[str, tuple[se.Symbol, ...]]:
        """The frames among ``defs`` with a joint of their own: whose pose reads the state
        other than through another frame. A frame fixed to its parent is the parent's pose
        and numbers: no place to cut (its definitions join the next node's)."""
        states = frozenset(self.system.x)
        candidates = _frames(defs)
        by_symbol = {d.symbol: d for d in defs}
        moving = {}
        for prefix, syms in candidates.items():
            stop = {sym: other for other, others in candidates.items() if other != prefix for sym in others}
            exprs = [by_symbol[sym].expr for sym in syms]
            local, _ = _cut(defs, exprs, stop)
            read = frozenset().union(*(e.free_symbols for e in exprs),
                                     *(e.free_symbols for d in local
                                       for e in _def_exprs(d)))
            if read & states:
                moving[prefix] = syms
        return moving

    def _box(self, where: str, name: str, entries: list[se.Expr], defs, value: bool):
        """A placed box: (its frame's node, the box's fixed placement in that frame) when the
        box is rigidly fixed in one frame, else (the box's own node, None)."""
        frames = self._frames(defs)
        stop = {sym: prefix for prefix, syms in frames.items() for sym in syms}
        local, read = _cut(defs, entries, stop)
        if len(read) == 1:
            (prefix,) = read
            placement = _placement(entries, local, frames[prefix])
            if placement is not None:
                return self._frame(where, prefix, defs, frames, value), placement
        return self._node(where, name, f"{name}_in_frame", entries, defs, frames, value), None

    def _frame(self, where: str, prefix: str, defs, frames, value: bool):
        by_symbol = {d.symbol: d for d in defs}
        name = f"frame_{prefix}" + ("_value" if value else "")
        return self._node(where, name, name, [by_symbol[sym].expr for sym in frames[prefix]], defs, frames, value,
                          own=prefix)

    def _publish(self, name: str, node, placement, value: bool) -> None:
        self.pose_names.append(name)
        path = node.path()
        if len(path) > 1 or placement is not None:
            self.poses.append(PosePlan(name, tuple(n.kernel.name for n in path), value,
                                       0 if value else node.degree, 0 if value else len(node.columns), placement))

    def _node(self, where: str, name: str, cut_name: str, entries: list[se.Expr], defs, frames, value: bool,
              own: str | None = None):
        """The node whose kernel computes ``entries``: cut at the one frame they read (that
        frame's node first, recursively; this kernel is then ``cut_name``), or whole
        (``name``) when they read none or several. ``own`` is the frame a frame node is."""
        stop = {sym: prefix for prefix, syms in frames.items() if prefix != own for sym in syms}
        local, read = _cut(defs, entries, stop)
        if len(read) == 1:
            (prefix,) = read
            parent = self._frame(where, prefix, defs, frames, value)
            node = self._cached(where, cut_name, entries, local, parent, frames[prefix], value)
            if node is not None:
                return node
        whole, _ = _cut(defs, entries, {})
        return self._cached(where, name, entries, whole, None, (), value)

    def _cached(self, where, name, entries, defs, parent, parent_symbols, value):
        key = (_text(entries, defs), parent.kernel.name if parent else None, value)
        if key not in self._nodes:
            taken = {n.kernel.name for n in self._nodes.values()}
            unique, count = name, 1
            while unique in taken:  # the same frame name over other kinematics
                count += 1
                unique = f"{name}_{count}"
            if value:
                node = ValueNode(self._value_kernel(unique, entries, defs, parent, parent_symbols), parent)
            else:
                node = self._build(where, unique, entries, defs, parent, parent_symbols)
                if node is None:
                    return None
            self._nodes[key] = node
            self.kernels.append(node.kernel)
        return self._nodes[key]

    def _value_kernel(self, name, entries, defs, parent, parent_symbols) -> Kernel:
        k = Kernel(name, "A pose, value only (what lower bounds read): centre, then rotation row by row"
                         + (f"; from its frame's pose ([`{parent.kernel.name}`])." if parent else "."))
        k.array_input("x", self.system.state_names, "state, laid out as `STATE_NAMES`")
        subs = {}
        if parent is not None:
            subs = dict(zip(parent_symbols, k.array_input("frame", _POSE_COMPONENTS, "the frame's pose"),
                            strict=True))
        for d in defs:
            if isinstance(d, Let):
                subs[d.symbol] = k.let_(str(d.symbol), d.expr.xreplace(subs))
            else:
                subs[d.symbol] = k.runtime_max(str(d.symbol), [e.xreplace(subs) for e in d.exprs])
        k.output_vector("pose", [se.sympify(e).xreplace(subs) for e in entries],
                        "centre [m], then rotation row by row (columns = the axes)")
        return k

    def _on_jet(self, k: Kernel, parent: Jet, parent_symbols, with_state: bool):
        """``k``'s inputs for the parent frame's jet and the Lie engine of the pseudo-system
        whose states are that jet's levels (and, ``with_state``, the state): the frame's
        last level driven by its input columns. Returns (engine, frame symbol -> input)."""
        s = self.system
        r, cols = parent.degree, parent.columns
        pose = k.array_input("frame", _POSE_COMPONENTS, "the frame's pose: centre [m], rotation row by row")
        rates = k.array_input("frame_rates", [f"d{d}_{c}" for d in range(1, r + 1) for c in _POSE_COMPONENTS],
                              "the frame's L_f y ... L_f^r y")
        lg = k.array_input("frame_lg", [f"{c}_u{u}" for c in _POSE_COMPONENTS for u in cols],
                           "the frame's L_g L_f^(r-1) y, row by row")
        levels = [pose] + [rates[POSE_SIZE * d:POSE_SIZE * (d + 1)] for d in range(r)]
        zero = se.Integer(0)
        nu = len(s.g[0])
        g = [[zero] * nu for _ in range(POSE_SIZE * r)] + ([list(row) for row in s.g] if with_state else [])
        for i in range(POSE_SIZE):
            for j, u in enumerate(cols):
                g[POSE_SIZE * (r - 1) + i][u] = lg[i * len(cols) + j]
        states = [v for d in range(r) for v in levels[d]] + (list(s.x) if with_state else [])
        drift = [v for d in range(r) for v in levels[d + 1]] + (list(s.f) if with_state else [])
        return LieEngine(k, states, drift, g), dict(zip(parent_symbols, pose, strict=True))

    def frame_read(self, rows: Sequence[tuple[str, se.Expr]], source: Kernel) -> str | None:
        """The one moving frame ``rows`` read when they read nothing else of the state."""
        cut = self._frame_cut(rows, source)
        return None if cut is None else cut.prefix

    def _frame_cut(self, rows: Sequence[tuple[str, se.Expr]], source: Kernel) -> _FrameCut | None:
        """``rows`` cut at the moving frames of ``source``'s definitions, when they read one
        frame and nothing else of the state; else None."""
        defs = list(source.definitions)
        frames = self._frames(defs)
        stop = {sym: prefix for prefix, syms in frames.items() for sym in syms}
        exprs = [se.sympify(e) for _, e in rows]
        local, read = _cut(defs, exprs, stop)
        states = frozenset(self.system.x)
        if len(read) != 1 or any(e.free_symbols & states for e in exprs) or any(
                e.free_symbols & states for d in local for e in _def_exprs(d)):
            return None
        return _FrameCut(next(iter(read)), defs, frames, local, exprs)

    def on_frame(self, where: str, name: str, rows: Sequence[tuple[str, se.Expr]], source: Kernel,
                 declare_params: Callable[[Kernel], object], value: bool):
        """A member's rows (or, ``value``, its bound: one row) on the one moving frame they
        read, when they read nothing else of the state: ``(its kernel, the pose function of
        the frame's jet or pose)`` with the kernel ``<name>_on_frame`` taking that jet and the
        parameters (``declare_params`` declares them). None when the rows read no frame,
        several, or the state besides, or differ in degree from the frame."""
        cut = self._frame_cut(rows, source)
        if cut is None:
            return None
        prefix, defs, frames, local, exprs = cut
        frame = self._frame(where, prefix, defs, frames, value)
        k = Kernel(f"{name}_on_frame", "")
        if value:
            subs = dict(zip(frames[prefix], k.array_input("frame", _POSE_COMPONENTS, "the frame's pose"),
                            strict=True))
            define = k
        else:
            eng, subs = self._on_jet(k, frame, frames[prefix], with_state=False)
            define = eng
        declare_params(k)
        for d in local:
            if isinstance(d, Let):
                subs[d.symbol] = define.let_(str(d.symbol), d.expr.xreplace(subs))
            else:
                subs[d.symbol] = k.runtime_max(str(d.symbol), [e.xreplace(subs) for e in d.exprs])
        exprs = [e.xreplace(subs) for e in exprs]
        if value:
            k.doc = f"The bound `{name}` on its frame's pose ([`{frame.kernel.name}`])."
            k.output_scalar("bound", exprs[0], "never above any row's h of the instance")
        else:
            k.doc = (f"The rows of `{name}` on its frame's jet ([`{frame.kernel.name}`] and the nodes above it): "
                     "lie = h, L_f h, ..., L_f^r h per row; lg_lf = L_g L_f^(r-1) h.")
            from ..families.rows import finish_row_kernel
            built = finish_row_kernel(k, eng, [(row, e) for (row, _), e in zip(rows, exprs, strict=True)],
                                      self._columns_possible(rows, defs, frame.degree))
            if built.degree != frame.degree:
                return None
        function = self._publish_frame(frame, value)
        return (k if value else built), function

    def _columns_possible(self, rows, defs, degree: int) -> set[int]:
        """The input columns that can reach the rows within ``degree`` derivatives along the
        real system: those acting on a state the rows read, or that the drift carries into
        one. The frame's jet has a column for every joint above it, but a point on a
        joint's axis does not move with that joint: its column is zero to rounding there,
        and exactly zero here."""
        s = self.system
        exprs = [se.sympify(e) for _, e in rows]
        full, _ = _cut(defs, exprs, {})
        states = frozenset(s.x)
        reads = frozenset().union(*(e.free_symbols for e in exprs),
                                  *(e.free_symbols for d in full for e in _def_exprs(d)))
        reads &= states
        for _ in range(degree - 1):
            carried = (fx.free_symbols for x, fx in zip(s.x, s.f, strict=True) if x in reads)
            reads |= frozenset().union(*carried) & states
        return {u for x, row in zip(s.x, s.g, strict=True) if x in reads for u, e in enumerate(row) if e != 0}

    def _publish_frame(self, frame, value: bool) -> str:
        """The pose function of a frame's jet (or pose) from the state, published once."""
        path = frame.path()
        name = frame.kernel.name if len(path) == 1 else f"{frame.kernel.name}_from_state"
        if name not in self.pose_names:
            self.pose_names.append(name)
            if len(path) > 1:
                self.poses.append(PosePlan(name, tuple(n.kernel.name for n in path), value,
                                           0 if value else frame.degree, 0 if value else len(frame.columns)))
        return name

    def _build(self, where: str, name: str, entries: Sequence[se.Expr], defs, parent: Jet | None,
               parent_symbols) -> Jet | None:
        """The node's kernel: its pose, drift derivatives and the input part of the last,
        along the system (``parent`` None) or along the pseudo-system of the parent frame's
        jet and the state. None when a parent's degree is not the node's (cut elsewhere)."""
        s = self.system
        doc = ("A pose the composed rows read (and every row that places it the same way): centre and rotation "
               "(row by row), their drift derivatives and the input part of the last")
        k = Kernel(name, doc + (f"; from its frame's jet ([`{parent.kernel.name}`])." if parent else "."))
        k.array_input("x", s.state_names, "state, laid out as `STATE_NAMES`")
        if parent is None:
            eng, subs = LieEngine(k, s.x, s.f, s.g), {}
        else:
            eng, subs = self._on_jet(k, parent, parent_symbols, with_state=True)
        for d in defs:
            if isinstance(d, Let):
                subs[d.symbol] = eng.let_(str(d.symbol), d.expr.xreplace(subs))
            else:
                subs[d.symbol] = k.runtime_max(str(d.symbol), [e.xreplace(subs) for e in d.exprs])
        lf = [[se.sympify(e).xreplace(subs) for e in entries]]
        for level in range(MAX_RELATIVE_DEGREE):
            lg_out = {(i, u): e for i, y in enumerate(lf[-1]) for u in range(eng.nu) if (e := eng.along(y, u)) != 0}
            lf.append([eng.along(y, None) for y in lf[-1]])
            if lg_out:
                degree = level + 1
                break
        else:
            raise SpecError(f"{where}: a moving box's pose does not depend on the input within "
                            f"{MAX_RELATIVE_DEGREE} derivatives; no row on it can be enforced")
        if parent is not None and degree != parent.degree:
            return None
        columns = tuple(sorted({u for _, u in lg_out}))
        upper = name.upper()
        k.constant(f"{upper}_RELATIVE_DEGREE", "usize", str(degree),
                   f"Derivatives of the pose in [`{name}`] before the input appears (found symbolically).")
        k.constant(f"{upper}_INPUT_COLUMNS", f"[usize; {len(columns)}]", str(list(columns)),
                   f"Input columns of `lg` in [`{name}`].")
        k.output_vector("pose", lf[0], "centre [m], then rotation row by row (columns = the axes)")
        k.output_vector("rates", [e for level in lf[1:] for e in level],
                        "L_f y, ..., L_f^r y of the pose y, one after the other")
        k.output_matrix("lg", [[lg_out.get((i, u), se.Integer(0)) for u in columns] for i in range(POSE_SIZE)],
                        "L_g L_f^(r-1) y: one row per pose entry, one column per input column")
        return Jet(k, degree, columns, parent)


def numeric_options(call: Recorded) -> tuple[tuple[str, float], ...]:
    """The call's options that are numbers (the primitive's sharpness), in call order: the
    chain and bound kernels take them as arguments, so one kernel serves every value."""
    return tuple((key, float(v)) for key, v in call.options.items() if isinstance(v, se.Basic) and v.is_Number)


def options_key(call: Recorded) -> tuple:
    """What a chain or bound kernel depends on of a call: its primitive and its options,
    numbers only by name (they are the kernel's arguments)."""
    numeric = dict(numeric_options(call))
    return call.primitive, tuple((key, "<argument>" if key in numeric else str(v) if isinstance(v, se.Basic) else v)
                                 for key, v in sorted(call.options.items()))


def _build_options(k: Kernel, call: Recorded) -> dict:
    """``call.options`` with every number replaced by a scalar argument of ``k``."""
    options = dict(call.options)
    for key, _ in numeric_options(call):
        options[key] = k.scalar_input(key, f"the primitive's `{key}` (as the spec passes it)")
    return options


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
    options = _build_options(k, call)
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
        h = call.build(ctx, *placed, **options)
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
    options = _build_options(k, call)
    ctx = FamilyContext(where, k, k, {}, None)
    with ctx.active():
        from ..primitives import Box
        placed = [Box(pose[:3], [pose[3 + 3 * r:6 + 3 * r] for r in range(3)], half)
                  for pose, half in zip(poses, halves, strict=True)]
        k.output_scalar("bound", call.build(ctx, *placed, **options), "the bound [m]")
    return k


# The chain and bound kernels the core ships in its generated module `ssat`: the smooth SAT
# with its defaults (LSE, x tanh, certified) at relative degree 2 (an arm or a legged
# robot on acceleration or torque inputs), both boxes moving or box A fixed (an obstacle).
# A family whose call matches one calls the core's and emits none of its own: an edit of
# its sharpness then regenerates a number, not the chain, and every robot shares one copy.
LIBRARY = "ssat"
_LIBRARY_DEGREE = 2
_LIBRARY_MOVING = ((True, True), (False, True))


def _library_calls() -> tuple[Recorded, Recorded]:
    """The calls the core's kernels stand for: ``prim.ssat`` (the chains) and
    ``prim.ssat_lower_bound`` (the bounds) with their default smoothing, as a family
    records them (the numbers are arguments, so their values do not matter)."""
    from ..primitives import ssat_lower_bound_value, ssat_value
    from ..smoothing import LSE, XTANH
    sharpness = dict(alpha=se.Integer(1), alpha_rot=se.Integer(1))
    return (Recorded("ssat", ssat_value, (), dict(**sharpness, smax=LSE, sabs=XTANH, certified=True),
                     se.Symbol("library"), ()),
            Recorded("ssat_lower_bound", ssat_lower_bound_value, (), dict(**sharpness, sabs=XTANH, certified=True),
                     se.Symbol("library"), ()))


@functools.cache
def library() -> dict[tuple, Kernel]:
    """Key (as ``_composed`` keys the chains and bounds it shares) -> the core's kernel for it."""
    chain_call, bound_call = _library_calls()
    where = "cbfgen, every composed family that calls prim.{} with its default smoothing"
    out: dict[tuple, Kernel] = {}
    for moving in _LIBRARY_MOVING:
        suffix = variant_suffix(moving)
        out[("chain", options_key(chain_call), moving, _LIBRARY_DEGREE)] = build_chain(
            where.format("ssat"), f"ssat_chain{_LIBRARY_DEGREE}{suffix}", chain_call, moving, _LIBRARY_DEGREE)
        out[("bound", options_key(bound_call), moving)] = build_bound(
            where.format("ssat_lower_bound"), f"ssat_bound{suffix}", bound_call)
    return out


def library_kernels() -> list[Kernel]:
    """The core's chain and bound kernels, for its generated module ``LIBRARY``."""
    return list(library().values())


def variant_suffix(moving: tuple[bool, ...]) -> str:
    """A chain or bound kernel's name suffix: which boxes are fixed (``_fixed_a``), if any."""
    return "" if all(moving) else "_fixed_" + "".join(s for s, m in zip(SLOTS, moving, strict=True) if not m)
