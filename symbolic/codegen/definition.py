"""A :class:`~symbolic.spec.System` made concrete: kernels, degrees, layouts, defaults.

This is the language-neutral half of generation. Per family it builds one row kernel
(:func:`symbolic.families.rows.row_kernel`): outputs ``lie`` = per row
``[h, L_f h, ..., L_f^r h]`` and ``lg_lf`` = per row ``L_g L_f^(r-1) h`` on the family's
input columns, with the degree, columns and row names as constants. The dynamics become
two kernels, ``drift(x) -> f`` and ``input_matrix(x) -> g``. A backend prints the result;
nothing here knows a target language.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import symengine as se

from ..families.rows import RowKernel, build_row_kernel, rust_str_array
from ..kernel import Kernel, Let, RuntimeMax
from ..lie import MAX_RELATIVE_DEGREE, LieEngine
from ..spec import (
    DEFAULT_POLE,
    Constant,
    Domain,
    Family,
    FamilyContext,
    Limits,
    Output,
    Param,
    Real,
    SpecError,
    System,
    check_identifier,
)
from .composition import (
    LIBRARY,
    SLOTS,
    BoundPlan,
    FramePlan,
    Jets,
    MemberPlan,
    PosePlan,
    Recorder,
    Slot,
    Static,
    build_bound,
    build_chain,
    library,
    numeric_options,
    options_key,
    pose_entries,
    variant_suffix,
)
from .partial import partial_warnings


@dataclass(frozen=True)
class FamilyDefinition:
    name: str
    doc: str
    kernels: tuple[Kernel, ...]  # one per member (``over``), else one
    degree: int
    row_names: tuple[str, ...]
    columns: tuple[tuple[int, ...], ...]  # input columns, per kernel
    row_columns: tuple[tuple[tuple[int, ...], ...], ...]  # per kernel, per row: its own columns
    params: tuple[Param, ...]  # each with the domain its validation checks (never None)
    count: int | None  # fixed instances (per member); None for a capacity family
    capacity: bool
    max_capacity: int | None
    optional: bool
    members: tuple[str, ...]  # the ``over`` labels; empty for a family that is not indexed
    time: bool
    poles: tuple[float, ...]
    priority: int
    activation: float
    # Per member (as ``kernels``), the value kernel of the spec's ``lower_bound``; empty
    # when the family declares none.
    bounds: tuple[Kernel, ...] = ()
    # What the generator noticed about the family that a user should know (printed when
    # it generates, and in the module's docs).
    warnings: tuple[str, ...] = ()
    kind: str = "barrier"  # or "lyapunov": the rows are h = -V
    # The extended class-K function of the last term, ``<family>_class_k(s) -> alpha``,
    # and its formula in s; None for the linear one.
    class_k: Kernel | None = None
    class_k_text: str = ""
    # compose=True: how each member (as ``kernels``) is assembled, and the family's chain
    # kernels; ``kernels`` then hold each member's signature (its unrolled rows when
    # defined with ``unrolled=True``), not what is emitted.
    composed: tuple[MemberPlan, ...] = ()
    chains: tuple[Kernel, ...] = ()
    # Per member (as ``kernels``), when its rows read one moving frame and parameters only:
    # how it is assembled on that frame's jet (``chains`` then hold its kernels there), else
    # None; empty when no member is.
    framed: tuple[FramePlan | None, ...] = ()

    @property
    def indexed(self) -> bool:
        return bool(self.members)


@dataclass(frozen=True)
class SystemDefinition:
    name: str
    doc: str
    state_names: tuple[str, ...]
    state_docs: tuple[str, ...]
    input_names: tuple[str, ...]
    input_docs: tuple[str, ...]
    input_limits: tuple[Limits, ...]
    drift: Kernel
    input_matrix: Kernel
    input_pattern: tuple[tuple[int, int], ...]  # (state row, input column) of each non-zero of g
    input_nonzeros: Kernel
    families: tuple[FamilyDefinition, ...]
    outputs: tuple[Kernel, ...]
    constants: tuple[Constant, ...]
    source: Path | None
    # ``objective(x) -> (p, q)``: the spec's cost (``s.objective``); None for input weights.
    objective: Kernel | None = None
    # The pose kernels composed families share (symbolic.codegen.composition): every
    # node's kernel, the pose functions assembled from several nodes, and the name of every
    # pose function the rows call (a whole node's kernel is its own function).
    jets: tuple[Kernel, ...] = ()
    poses: tuple[PosePlan, ...] = ()
    pose_names: tuple[str, ...] = ()
    nodes: tuple[tuple[str, str | None], ...] = ()  # (node kernel, the node kernel it reads)
    # Outputs generated as a rigid-body tree walked at run time (System.rigid_body_output):
    # (output kernel name, its symbolic.dynamics.Tree, its degrees of freedom's order).
    rigid_bodies: tuple[tuple[str, object, tuple[int, ...]], ...] = ()

    @property
    def time_varying(self) -> bool:
        return any(f.time for f in self.families)

    def kernels(self) -> list[Kernel]:
        """Every kernel, in the order a backend emits them."""
        return ([self.drift, self.input_matrix, self.input_nonzeros, *self.jets]
                + [k for f in self.families
                   for k in (*f.chains, *f.kernels, *f.bounds, *([f.class_k] if f.class_k else []))]
                + list(self.outputs) + ([self.objective] if self.objective else []))


def _base_symbols(kernel: Kernel):
    """expr -> the inputs it reads, every let and runtime max expanded."""
    defs: dict[se.Symbol, tuple[se.Expr, ...]] = {}
    for d in kernel.definitions:
        defs[d.symbol] = d.exprs if isinstance(d, RuntimeMax) else (d.expr,)
    memo: dict[se.Symbol, frozenset] = {}

    def of_symbol(sym: se.Symbol) -> frozenset:
        if sym not in memo:
            if sym in defs:
                memo[sym] = frozenset().union(*(of_expr(e) for e in defs[sym]))
            else:
                memo[sym] = frozenset([sym])
        return memo[sym]

    def of_expr(e: se.Expr) -> frozenset:
        return frozenset().union(*(of_symbol(s) for s in e.free_symbols))

    return of_expr


def _rows(where: str, family: Family, result: object) -> list[tuple[str, se.Expr]]:
    if isinstance(result, (list, tuple)):
        if not result:
            raise SpecError(f"{where}: h returned no rows")
        rows = []
        for item in result:
            if not (isinstance(item, (list, tuple)) and len(item) == 2 and isinstance(item[0], str)):
                raise SpecError(f"{where}: h must return one expression or a list of (row_name, expr) "
                                f"pairs, got an item {item!r}")
            check_identifier(where, "row name", item[0], local=False)
            rows.append((item[0], item[1]))
        names = [r for r, _ in rows]
        if len(set(names)) != len(names):
            raise SpecError(f"{where}: row names {names} repeat a name")
    else:
        rows = [(family.name, result)]
    out = []
    for row, e in rows:
        try:
            out.append((row, se.sympify(e)))
        except Exception as exc:
            raise SpecError(f"{where}: row {row!r} is not a symbolic expression: {e!r}") from exc
    return out


def _declare_params(k: Kernel, family: Family) -> tuple[dict[str, object], dict[str, frozenset]]:
    values: dict[str, object] = {}
    symbols: dict[str, frozenset] = {}
    for p in family.params:
        doc = p.doc or f"parameter `{p.name}` of the {family.name} family"
        if p.shape == ():
            sym = k.scalar_input(p.name, doc)
            values[p.name] = sym
            symbols[p.name] = frozenset([sym])
            continue
        flat = k.array_input(p.name, p.components(), doc, shape=p.shape)
        symbols[p.name] = frozenset(flat)
        if len(p.shape) == 1:
            values[p.name] = flat
        else:
            cols = p.shape[1]
            values[p.name] = [flat[r * cols:(r + 1) * cols] for r in range(p.shape[0])]
    return values, symbols


def _family(system: System, family: Family, jets: Jets, unrolled: bool) -> FamilyDefinition:
    where = f"{system.where}, family {family.name!r}"
    required: dict[str, tuple[Domain, str]] = {}  # what the primitives asked, across members
    members = [(where, family.name, None, None)] if family.over is None else [
        (f"{where}, member {label!r}", f"{family.name}_{label}", i, label) for i, label in enumerate(family.over)]
    on_frame_kernels: dict[str, Kernel] = {}  # a framed member's kernel on its frame, by member
    framed: list = []
    if family.compose:
        built, plans, chains, bounds = _composed(system, family, where, members, required, jets, unrolled)
    else:
        built, framed, chains = [], [], []
        on_frames = _framed_members(system, family, members, required, jets)
        for w, name, i, label in members:
            on_frame = name in on_frames and _framed_member(system, family, w, name, i, label, required, jets,
                                                            unrolled, *on_frames[name])
            if not on_frame:
                built.append(_member(system, family, w, name, i, label, required))
                framed.append(None)
            else:
                built.append(on_frame[0])
                framed.append(on_frame[1])
                chains.append(on_frame[2])
                on_frame_kernels[name] = on_frame[2]
        plans, bounds = (), ()
        if not any(framed):
            framed = []
    degrees = {b.degree for b in built}
    if len(degrees) != 1:
        found = {label: b.degree for label, b in zip(family.over or [], built, strict=True)}
        raise SpecError(f"{where}: members differ in relative degree {found}; one family has one degree "
                        "(split it into families)")
    row_names = {b.row_names for b in built}
    if len(row_names) != 1:
        raise SpecError(f"{where}: members return different row names {sorted(row_names)}; every member "
                        "must return the same rows")
    degree = built[0].degree
    if family.kind == "lyapunov" and degree != 1:
        raise SpecError(f"{where}: V' does not depend on the input (relative degree {degree}), so no input can "
                        "make V decrease; a CLF needs V' to depend on u: a V of the states the inputs drive "
                        "(e.g. of velocities, not positions), or V backstepped through the chain")
    if family.poles is None:
        poles = (DEFAULT_POLE,) * degree
    elif len(family.poles) != degree:
        raise SpecError(f"{where}: poles has {len(family.poles)} entries but the relative degree found is "
                        f"{degree}; give {degree} poles (or omit poles for {degree} x {DEFAULT_POLE:g})")
    else:
        poles = tuple(family.poles)
    if family.lower_bound is not None and not family.compose:
        labels = family.over or [None]
        bound_list = []
        for i, (lb, b) in enumerate(zip(labels, built, strict=True)):
            bound_where = f"{where}, lower_bound" + (f", member {lb!r}" if lb else "")
            index = i if lb else None
            plan = framed[i] if framed else None
            on_frame = plan and _framed_bound(system, family, bound_where, b.kernel.name, index, lb, required, jets,
                                              unrolled)
            if on_frame:
                framed[i] = replace(plan, bound=on_frame[1])
                chains.append(on_frame[2])
                bound_list.append(on_frame[0])
            else:
                bound_list.append(_lower_bound(system, family, bound_where, b.kernel.name, index, lb, required))
        bounds = tuple(bound_list)
    params = _checked_params(family, required)
    labels = family.over or [None]
    # A member on its frame is checked on its kernel there (its signature has no rows).
    partial = () if family.compose else tuple(
        w for lb, b in zip(labels, built, strict=True)
        for w in partial_warnings(where + (f", member {lb!r}" if lb else ""),
                                  on_frame_kernels.get(b.kernel.name, b.kernel), params))
    return FamilyDefinition(family.name, family.doc, tuple(b.kernel for b in built), degree,
                            built[0].row_names, tuple(b.columns for b in built),
                            tuple(b.row_columns for b in built), params,
                            family.count, family.capacity, family.max_capacity, family.optional,
                            tuple(family.over or ()),
                            family.time, poles, family.priority, family.activation, bounds,
                            warnings=partial, kind=family.kind, composed=plans, chains=tuple(chains),
                            framed=tuple(framed),
                            **_class_k(where, family))


def _static(where: str, e: se.Expr, lets: dict, params: dict, what: str) -> Static:
    """An entry of a fixed box: a number, or a whole parameter entry (lets expanded)."""
    while e.free_symbols & lets.keys():
        e = e.xreplace(lets)
    if e in params:
        return params[e]
    if e.is_Number or not e.free_symbols:
        return float(e)
    raise SpecError(f"{where}: compose=True takes a fixed box's {what} as numbers or whole parameter entries, "
                    f"not {e}; declare the family without compose=True")


def _shared_kernel(jets: Jets, key: tuple, build: Callable[[], Kernel]) -> tuple[Kernel, str | None]:
    """A chain or bound kernel for ``key`` and the core's module that holds it: the core's
    (:data:`LIBRARY`) when it ships one, else the system's own, shared by its families."""
    core = library().get(key)
    return (core, LIBRARY) if core is not None else (jets.shared(key, build), None)


def _recorded_call(where: str, value, recorder: Recorder, what: str):
    """The one primitive call a composed family's ``h`` (or ``lower_bound``) must be."""
    if not (len(recorder.calls) == 1 and value == recorder.calls[0].placeholder):
        raise SpecError(f"{where}: compose=True needs {what} to be one composable primitive call (prim.ssat, "
                        "prim.ssat_lower_bound) with nothing added to it; declare the family without compose=True "
                        "to differentiate any other h whole")
    return recorder.calls[0]


def _boxes(system: System, where: str, k: Kernel, call, row_kernel: str):
    """Per box of a recorded call: (its pose entries, the name of its pose kernel when it
    moves with the state, else its fixed pose) and its half extents (fixed)."""
    params = {sym: (inp.name, n) for inp in k.inputs if inp.name != "x" for n, sym in enumerate(inp.symbols)}
    lets = {d.symbol: d.expr for d in k.definitions if isinstance(d, Let)}
    base = _base_symbols(k)
    state_set = frozenset(system.x)
    out = []
    for slot_name, box, given in zip(SLOTS, call.boxes, call.names, strict=True):
        entries = pose_entries(box)
        reads = frozenset().union(*(base(e) for e in entries))
        half = tuple(_static(where, se.sympify(e), lets, params, "half extents") for e in box[2])
        if not reads & state_set:
            out.append((entries, None, tuple(_static(where, e, lets, params, "pose") for e in entries), half))
            continue
        if reads - state_set:
            raise SpecError(f"{where}: box {slot_name.upper()} moves with the state and depends on parameters "
                            f"{sorted(map(str, reads - state_set))}; compose=True needs a box that moves to be "
                            "placed by the state alone")
        name = f"pose_{given}" if given else f"{row_kernel}_pose_{slot_name}"
        try:
            check_identifier(where, "pose name", name, module_item=True)
        except SpecError as exc:
            raise SpecError(f"{where}: names: {exc}") from exc
        out.append((entries, name, (), half))
    return out


def _composed_bound(system: System, family: Family, where: str, row_kernel: str, index, label, required,
                    jets: Jets, unrolled: bool, chains: dict):
    """One member's lower bound, composed: the boxes' value kernels and the family's bound
    kernel (or, ``unrolled``, the bound's whole definition)."""
    name = f"{row_kernel}_lower_bound"
    k, values, _ = _member_kernel(system, family, where, name)
    recorder = Recorder()
    ctx = FamilyContext(where, k, k, values, None, index, label, family.params, required, composer=recorder)
    with ctx.active():
        value = family.lower_bound(ctx)
    call = _recorded_call(where, value, recorder, "lower_bound")
    slots = [Slot(jets.value(where, name, entries, k) if name else None, (), pose, half)
             for entries, name, pose, half in _boxes(system, where, k, call, row_kernel)]
    moving = tuple(s.moving for s in slots)
    if moving not in chains:
        chains[moving] = _shared_kernel(jets, ("bound", options_key(call), moving), functools.partial(
            build_bound, where, f"{family.name}_bound{variant_suffix(moving)}", call))
    bound, module = chains[moving]
    plan = BoundPlan(name, bound.name, tuple(slots), tuple(v for _, v in numeric_options(call)), module)
    if unrolled:
        return _lower_bound(system, family, where, row_kernel, index, label, required), plan
    sig = Kernel(name, f"A lower bound on every row's h of one instance of `{row_kernel}` (the spec's "
                       "`lower_bound`): where it is above the family's activation threshold, the rows are not "
                       f"evaluated. Composed: its boxes' value kernels and the family's `{bound.name}`.")
    sig.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    _declare_params(sig, family)
    sig.output_scalar("bound", se.Integer(0), "never above any row's h of the instance")
    return sig, plan


def _composed(system: System, family: Family, where: str, members, required, jets: Jets, unrolled: bool):
    """A ``compose=True`` family's members (signatures, or their unrolled rows), how each is
    assembled and the family's chain kernels (:mod:`symbolic.codegen.composition`)."""
    plans: list[MemberPlan] = []
    built: list[RowKernel] = []
    # Moving boxes -> (the chain or bound kernel, the core's module that holds it or None).
    chains: dict[tuple[bool, ...], tuple[Kernel, str | None]] = {}
    bound_chains: dict[tuple[bool, ...], tuple[Kernel, str | None]] = {}
    bounds: list[Kernel] = []
    first = None
    for member_where, name, index, label in members:
        k, values, _ = _member_kernel(system, family, member_where, name)
        eng = LieEngine(k, system.x, system.f, system.g)
        recorder = Recorder()
        ctx = FamilyContext(member_where, k, eng, values, None, index, label, family.params, required,
                            composer=recorder)
        with ctx.active():
            rows = _rows(member_where, family, family.h(ctx))
        if len(rows) != 1:
            raise SpecError(f"{member_where}: compose=True needs h to return one row, got {len(rows)}")
        call = _recorded_call(member_where, rows[0][1], recorder, "h")
        slots, jet_list = [], []
        for entries, jet_name, pose, half in _boxes(system, member_where, k, call, name):
            jet = jets.get(member_where, jet_name, entries, k) if jet_name else None
            if jet:
                jet_list.append(jet)
            slots.append((jet, pose, half))
        if not jet_list:
            raise SpecError(f"{member_where}: neither box moves with the state; no input can change the row")
        degrees = {j.degree for j in jet_list}
        if len(degrees) != 1:
            raise SpecError(f"{member_where}: its boxes' poses reach the input at different derivatives "
                            f"{sorted(degrees)}; declare the family without compose=True")
        degree = degrees.pop()
        columns = tuple(sorted({c for j in jet_list for c in j.columns}))
        plan_slots = tuple(Slot(j.name if j else None, tuple(columns.index(c) for c in j.columns) if j else (),
                                pose, half) for j, pose, half in slots)
        moving = tuple(s.moving for s in plan_slots)
        options = (options_key(call), numeric_options(call))
        if first is None:
            first = options
        elif options != first:
            raise SpecError(f"{member_where}: compose=True needs every member to call the same primitive with the "
                            f"same options (one chain kernel serves them all): {options} against {first}")
        if moving not in chains:
            chains[moving] = _shared_kernel(jets, ("chain", options[0], moving, degree), functools.partial(
                build_chain, where, f"{family.name}_chain{variant_suffix(moving)}", call, moving, degree))
        chain, module = chains[moving]
        bound_plan = None
        if family.lower_bound is not None:
            bound_where = f"{where}, lower_bound" + (f", member {label!r}" if label else "")
            bound_kernel, bound_plan = _composed_bound(system, family, bound_where, name, index, label, required,
                                                       jets, unrolled, bound_chains)
            bounds.append(bound_kernel)
        plans.append(MemberPlan(name, chain.name, plan_slots, columns, bound_plan, tuple(v for _, v in options[1]),
                                module))
        row_name = rows[0][0]
        if unrolled:
            whole = _member(system, family, member_where, name, index, label, required)
            if (whole.degree, whole.columns) != (degree, columns):
                raise SpecError(f"{member_where}: composed rows have degree {degree} on columns {columns}, but "
                                f"unrolled {whole.degree} on {whole.columns}")
            built.append(whole)
            continue
        doc = family.doc or f"The {family.name} family of {system.name}."
        if label is not None:
            doc = f"{doc}\n\nMember `{label}` of the family."
        sig = Kernel(name, doc + "\n\nComposed: its pose kernels and the family's chain kernel "
                                 f"`{chain.name}`.")
        sig.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
        _declare_params(sig, family)
        upper = name.upper()
        sig.constant(f"{upper}_RELATIVE_DEGREE", "usize", str(degree),
                     f"Relative degree of every row of [`{name}`] (found symbolically).")
        sig.constant(f"{upper}_INPUT_COLUMNS", f"[usize; {len(columns)}]", str(list(columns)),
                     f"Input columns of `lg_lf` in [`{name}`]: the only inputs its rows depend on.")
        sig.constant(f"{upper}_ROW_NAMES", "[&str; 1]", rust_str_array([row_name]),
                     f"What each row of [`{name}`] constrains.")
        zero = se.Integer(0)
        sig.output_matrix("lie", [[zero] * (degree + 1)], "per row: h, L_f h, ..., L_f^r h")
        sig.output_matrix("lg_lf", [[zero] * len(columns)],
                          f"per row: L_g L_f^(r-1) h on the columns `{upper}_INPUT_COLUMNS`")
        built.append(RowKernel(sig, degree, columns, (row_name,), (columns,)))
    # A chain another family built first is that family's to emit.
    own = [k for k, module in (*chains.values(), *bound_chains.values()) if module is None and jets.first_use(k)]
    return built, tuple(plans), tuple(own), tuple(bounds)


# |s| at which a spec's class-K function is checked odd, increasing and through 0.
_CLASS_K_SAMPLES = [10.0 ** (e / 4.0) for e in range(-24, 13)]


def _class_k(where: str, family: Family) -> dict[str, object]:
    """The family's extended class-K function as a kernel ``<family>_class_k(s) -> alpha``,
    checked: a function of s alone, finite, through 0, odd and strictly increasing at
    |s| in [1e-6, 1e3] (sampled: a check of the function the spec meant, not a proof)."""
    if family.class_k is None:
        return {}
    where = f"{where}, class_k"
    s = se.Symbol("s")
    try:
        alpha = se.sympify(family.class_k(s))
    except Exception as exc:
        raise SpecError(f"{where}: alpha(s) is not a symbolic expression of s ({exc})") from exc
    stray = sorted(map(str, alpha.free_symbols - {s}))
    if stray:
        raise SpecError(f"{where}: alpha(s) = {alpha} uses {stray}; it is a function of s alone (its gain is "
                        "the family's last pole)")
    if s not in alpha.free_symbols:
        raise SpecError(f"{where}: alpha(s) = {alpha} does not depend on s")
    slope = se.diff(alpha, s)

    def at(e: se.Expr, v: float) -> float:
        try:
            return float(e.subs({s: se.RealDouble(v)}))
        except (RuntimeError, TypeError, ValueError):
            return math.nan

    zero = at(alpha, 0.0)
    if zero != 0.0:
        raise SpecError(f"{where}: alpha(0) = {zero:g}, not 0: alpha(s) = {alpha} must pass through 0")
    for v in _CLASS_K_SAMPLES:
        a, b, da, db = at(alpha, v), at(alpha, -v), at(slope, v), at(slope, -v)
        if not all(math.isfinite(x) for x in (a, b, da, db)):
            raise SpecError(f"{where}: alpha(s) = {alpha} is not finite at s = ±{v:g}")
        if abs(a + b) > 1e-12 * max(abs(a), abs(b)):
            raise SpecError(f"{where}: alpha(s) = {alpha} is not odd: alpha({v:g}) = {a:g} but alpha(-{v:g}) = "
                            f"{b:g}; use an odd function (s**3, tanh(s), s*sqrt(1 + s**2))")
        # alpha' >= 0, not > 0: a saturating alpha (tanh) is flat to rounding far out.
        if not (a > 0.0 and da >= 0.0 and db >= 0.0) or (v <= 1.0 and da <= 0.0):
            raise SpecError(f"{where}: alpha(s) = {alpha} is not increasing with alpha > 0 for s > 0: at "
                            f"s = {v:g} alpha = {a:g}, alpha' = {da:g}")
    kernel = Kernel(f"{family.name}_class_k",
                    f"The extended class-K function of `{family.name}`'s last ECBF term: alpha(s) = {alpha}.")
    kernel.output_scalar("alpha", alpha.xreplace({s: kernel.scalar_input("s", "the last term's psi")}),
                         "alpha(s)")
    return {"class_k": kernel, "class_k_text": str(alpha)}


def _one_sided_authority(system: System, families: tuple[FamilyDefinition, ...]) -> tuple[FamilyDefinition, ...]:
    """Each family with a warning when every row of it acts through one input whose limits
    let it push one way only (thrust >= 0): wherever a row needs the other way, no input
    helps and the row is relaxed; and a family sharing that input can take it to its limit
    against the others (a speed limit cutting a drone's thrust to zero while it falls
    through its floor). Priorities settle who yields."""
    def inputs(f: FamilyDefinition) -> set[int]:
        return {j for columns in f.columns for j in columns}

    out = []
    for f in families:
        used = inputs(f)
        j = next(iter(used)) if len(used) == 1 else None
        limits = system.input_limits[j] if j is not None else None
        if limits is None or limits.lower < 0.0 < limits.upper:
            out.append(f)
            continue
        name = system.input_names[j]
        sharing = [g for g in families if g is not f and j in inputs(g)]
        text = (f"{system.where}, family {f.name!r}: every row acts only through input {name!r}, whose limits "
                f"[{limits.lower:g}, {limits.upper:g}] let it push one way only: where a row needs the other way "
                "it is relaxed (cause: input at its limit).")
        if sharing:
            same = [g.name for g in sharing if g.priority == f.priority]
            text += (f" It shares {name!r} with {[g.name for g in sharing]}, and may take it to its limit against "
                     "them; the lower priority number holds, the higher yields")
            text += (f" ({same} share its priority {f.priority}, so neither yields to the other: give the one "
                     "that must hold the lower number)." if same else ".")
        out.append(dataclasses.replace(f, warnings=(*f.warnings, text)))
    return tuple(out)


def _checked_params(family: Family, required: dict[str, tuple[Domain, str]]) -> tuple[Param, ...]:
    """The family's parameters, each with the domain its validation checks: the one
    declared (already found within what the primitives asked), else the primitives'
    (:meth:`FamilyContext.require`), else Real."""
    return tuple(replace(p, domain=p.domain or required.get(p.name, (Real(), ""))[0]) for p in family.params)


def _signature(system: System, family: Family, name: str, doc: str, built, rows) -> RowKernel:
    """A member assembled from other kernels: its name, inputs and constants, no rows."""
    sig = Kernel(name, doc)
    sig.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    _declare_params(sig, family)
    upper = name.upper()
    sig.constant(f"{upper}_RELATIVE_DEGREE", "usize", str(built.degree),
                 f"Relative degree of every row of [`{name}`] (found symbolically).")
    sig.constant(f"{upper}_INPUT_COLUMNS", f"[usize; {len(built.columns)}]", str(list(built.columns)),
                 f"Input columns of `lg_lf` in [`{name}`]: the only inputs its rows depend on.")
    sig.constant(f"{upper}_ROW_NAMES", f"[&str; {len(rows)}]", rust_str_array(built.row_names),
                 f"What each row of [`{name}`] constrains.")
    zero = se.Integer(0)
    sig.output_matrix("lie", [[zero] * (built.degree + 1) for _ in rows], "per row: h, L_f h, ..., L_f^r h")
    sig.output_matrix("lg_lf", [[zero] * len(built.columns) for _ in rows],
                      f"per row: L_g L_f^(r-1) h on the columns `{upper}_INPUT_COLUMNS`")
    return RowKernel(sig, built.degree, built.columns, built.row_names, built.row_columns)


def _member_kernel(system: System, family: Family, where: str, name: str):
    """A member's kernel with its inputs (the state, then the family's parameters): the
    kernel, the parameters' values for ``p.<name>`` and their symbols."""
    k = Kernel(name, "")
    k.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    try:
        values, param_symbols = _declare_params(k, family)
    except ValueError as exc:
        raise SpecError(f"{where}: {exc}") from exc
    return k, values, param_symbols


def _member_rows(system: System, family: Family, where: str, name: str, index, label, required):
    """A member's rows (checked) and the kernel holding their definitions, undifferentiated."""
    k, values, param_symbols = _member_kernel(system, family, where, name)
    ctx = FamilyContext(where, k, k, values, None, index, label, family.params, required)
    with ctx.active():
        rows = _checked_rows(system, family, where, k, _rows(where, family, family.h(ctx)), param_symbols, None)
    return rows, k


def _framed_members(system: System, family: Family, members, required, jets: Jets) -> dict[str, tuple]:
    """The members of a family with parameters that are computed on a frame's jet: those
    whose rows read one moving frame and the parameters only, on a frame at least one other
    member reads (a member alone on its frame is smaller differentiated whole: the jet
    carries the frame's whole rotation, a row often a point). Member name -> (rows, kernel)."""
    if not family.params or family.time or family.kind != "barrier":
        return {}
    probed = {}
    for where, name, index, label in members:
        rows, k = _member_rows(system, family, where, name, index, label, required)
        frame = jets.frame_read(rows, k)
        if frame is not None:
            probed[name] = (frame, rows, k)
    shared = [frame for frame, _, _ in probed.values()]
    return {name: (rows, k) for name, (frame, rows, k) in probed.items() if shared.count(frame) > 1}


def _framed_member(system: System, family: Family, where: str, name: str, index, label, required, jets: Jets,
                   unrolled: bool, rows, k: Kernel):
    """A member on its frame's jet (``_framed_members``): (its signature, or its unrolled
    rows; how it is assembled; its kernel on the frame's jet), else None."""
    try:
        on_frame = jets.on_frame(where, name, rows, k, lambda kernel: _declare_params(kernel, family), value=False)
    except ValueError:  # mixed degrees: the whole member says so
        return None
    if on_frame is None:
        return None
    built, function = on_frame
    _require_differentiable(where, built.kernel)
    frame_lg = next(i for i in built.kernel.inputs if i.name == "frame_lg")
    plan = FramePlan(name, built.kernel.name, function, built.degree, len(frame_lg.symbols) // 12)
    if unrolled:
        whole = _member(system, family, where, name, index, label, required)
        if (whole.degree, whole.columns) != (built.degree, built.columns):
            raise SpecError(f"{where}: rows on the frame have degree {built.degree} on columns {built.columns}, "
                            f"but unrolled {whole.degree} on {whole.columns}")
        return whole, plan, built.kernel
    doc = family.doc or f"The {family.name} family of {system.name}."
    if label is not None:
        doc = f"{doc}\n\nMember `{label}` of the family."
    doc += f"\n\nOn its frame: [`{function}`] and [`{built.kernel.name}`]."
    return _signature(system, family, name, doc, built, rows), plan, built.kernel


def _framed_bound(system: System, family: Family, where: str, row_kernel: str, index, label, required, jets: Jets,
                  unrolled: bool):
    """A framed member's lower bound on its frame's pose: (its signature, or the whole
    bound; how it is assembled; its kernel on the frame), else None."""
    name = f"{row_kernel}_lower_bound"
    k, values, _ = _member_kernel(system, family, where, name)
    ctx = FamilyContext(where, k, k, values, None, index, label, family.params, required)
    with ctx.active():
        bound = family.lower_bound(ctx)
    if isinstance(bound, (list, tuple)):
        return None  # the whole bound's builder says what is wrong
    on_frame = jets.on_frame(where, name, [("bound", se.sympify(bound))], k,
                             lambda kernel: _declare_params(kernel, family), value=True)
    if on_frame is None:
        return None
    kernel, function = on_frame
    plan = FramePlan(name, kernel.name, function, 0)
    if unrolled:
        return _lower_bound(system, family, where, row_kernel, index, label, required), plan, kernel
    sig = Kernel(name, f"A lower bound on every row's h of one instance of `{row_kernel}` (the spec's "
                       f"`lower_bound`): where it is above the family's activation threshold, the rows are not "
                       f"evaluated. On its frame: [`{function}`] and [`{kernel.name}`].")
    sig.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    _declare_params(sig, family)
    sig.output_scalar("bound", se.Integer(0), "never above any row's h of the instance")
    return sig, plan, kernel


def _checked_rows(system: System, family: Family, where: str, k: Kernel, rows, param_symbols, time_sym):
    """``rows`` of one member, checked: states, declared parameters (and t with time=True)
    only, each row on a state, every parameter used."""
    state_set = frozenset(system.x)
    base = _base_symbols(k)
    allowed = state_set | frozenset().union(*param_symbols.values())
    if family.time:
        allowed |= {time_sym}
    used: frozenset = frozenset()
    for row, e in rows:
        syms = base(e)
        used |= syms
        stray = syms - allowed
        if stray:
            names = sorted(map(str, stray))
            hint = ""
            if time_sym in stray:
                hint = " (declare the family with time=True to use t)"
            elif any(s in system.u for s in stray):
                hint = " (barriers depend on states, parameters and time, never on inputs)"
            raise SpecError(f"{where}: row {row!r} uses {names}, which are not states or declared "
                            f"parameters{hint}")
        if not syms & state_set:
            raise SpecError(f"{where}: row {row!r} depends on no state; no input can change it")
    if family.time and time_sym not in used:
        raise SpecError(f"{where}: declared time=True but h does not depend on t")
    unused = [p.name for p in family.params if not used & param_symbols[p.name]]
    if unused:
        raise SpecError(f"{where}: parameters {unused} are declared but h does not use them")
    return rows


def _member(system: System, family: Family, where: str, kernel_name: str, index: int | None,
            label: str | None, required: dict[str, tuple[Domain, str]]):
    """One row kernel of ``family`` (of member ``label`` of an indexed family)."""
    time_sym = system.time

    def build(k: Kernel, eng: LieEngine):
        try:
            values, param_symbols = _declare_params(k, family)
        except ValueError as exc:
            raise SpecError(f"{where}: {exc}") from exc
        ctx = FamilyContext(where, k, eng, values, eng.time, index, label, family.params, required)
        with ctx.active():
            rows = _rows(where, family, family.h(ctx))
        if family.kind == "lyapunov":
            rows = [(row, -e) for row, e in rows]  # V' + rate V <= 0 is the barrier row of h = -V
        return _checked_rows(system, family, where, k, rows, param_symbols, time_sym)

    time_input = ("t", "time t [s]") if family.time else None
    doc = family.doc or f"The {family.name} family of {system.name}."
    if label is not None:
        doc = f"{doc}\n\nMember `{label}` of the family."
    try:
        kernel = build_row_kernel(kernel_name, doc, system.state_names, system.x, system.f, system.g, build,
                                  time_input=time_input)
    except SpecError:
        raise
    except ValueError as exc:  # the Lie engine's: degree > MAX_RELATIVE_DEGREE, mixed degrees
        text = str(exc)
        if "identically zero" in text:
            text = (f"relative degree > {MAX_RELATIVE_DEGREE}: L_g L_f^k h is identically zero for every "
                    f"k < {MAX_RELATIVE_DEGREE}, so no input can enforce it ({text})")
        elif "share a relative degree" in text:
            text = f"its rows have different relative degrees; split them into families ({text})"
        raise SpecError(f"{where}: {text}") from exc
    _require_differentiable(where, kernel.kernel)
    return kernel


# What to write instead of a function SymEngine cannot differentiate (eps: a small length
# of the spec's choosing, the error it accepts).
_SMOOTH_FORMS = {
    "Abs": "sqrt(e**2 + eps**2), within eps of |e| and smooth",
    "sign": "e / sqrt(e**2 + eps**2)",
    "Max": "a smooth maximum: log-sum-exp, or symbolic.smoothing's",
    "Min": "a smooth minimum: minus log-sum-exp of the negatives, or symbolic.smoothing's",
    "floor": "a smooth function: h must have continuous derivatives up to its relative degree",
    "ceiling": "a smooth function: h must have continuous derivatives up to its relative degree",
}


def _located(system: System, family: Family, jets: Jets, unrolled: bool):
    """``_family``, with a SpecError about the family pointing at its declaration."""
    try:
        return _family(system, family, jets, unrolled)
    except SpecError as exc:
        if exc.origin is None:
            exc.origin = family.origin
        raise


def _require_differentiable(where: str, kernel: Kernel) -> None:
    """A SpecError when differentiating h left a derivative SymEngine could not take
    (|e|, sign, max, ...): the Lie derivatives do not exist where the function has its
    kink, and the generated code could not be emitted. Names the function and a smooth
    form to use instead."""
    for d in kernel.definitions:
        for e in ([d.expr] if isinstance(d, Let) else list(d.exprs)):
            _check_derivatives(where, e)
    for out in kernel.outputs:
        for e in out.exprs:
            _check_derivatives(where, e)


def _check_derivatives(where: str, e: se.Expr) -> None:
    stuck = e.atoms(se.Derivative)
    if not stuck:
        return
    inner = sorted(stuck, key=str)[0].args[0]
    instead = _SMOOTH_FORMS.get(type(inner).__name__, "a smooth function of the state")
    raise SpecError(f"{where}: h uses {inner}, which is not differentiable everywhere, and its Lie derivatives "
                    f"cannot be taken; write it as {instead}")


def _lower_bound(system: System, family: Family, where: str, row_kernel: str, index: int | None,
                 label: str | None, required: dict[str, tuple[Domain, str]]) -> Kernel:
    """The value kernel of ``family.lower_bound`` for one member: the row kernel's inputs,
    one scalar out, no derivatives."""
    k = Kernel(f"{row_kernel}_lower_bound",
               f"A lower bound on every row's h of one instance of `{row_kernel}` (the spec's `lower_bound`): "
               "where it is above the family's activation threshold, the rows are not evaluated.")
    k.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    time = k.scalar_input("t", "time t [s]") if family.time else None
    try:
        values, param_symbols = _declare_params(k, family)
    except ValueError as exc:
        raise SpecError(f"{where}: {exc}") from exc
    # The kernel itself lets and takes maxima: nothing here is differentiated.
    ctx = FamilyContext(where, k, k, values, time, index, label, family.params, required)
    with ctx.active():
        bound = family.lower_bound(ctx)
    if isinstance(bound, (list, tuple)):
        raise SpecError(f"{where}: returns one expression (a bound for every row of the instance), got a list")
    try:
        bound = se.sympify(bound)
    except (TypeError, ValueError, se.SympifyError) as exc:
        raise SpecError(f"{where}: returns {bound!r}, not an expression") from exc
    allowed = frozenset(system.x) | frozenset().union(*param_symbols.values())
    if time is not None:
        allowed |= {time}
    stray = _base_symbols(k)(bound) - allowed
    if stray:
        raise SpecError(f"{where}: uses {sorted(map(str, stray))}, which are not states, time or declared "
                        "parameters")
    k.output_scalar("bound", bound, "never above any row's h of the instance")
    return k


def _output(system: System, output: Output) -> Kernel:
    k = Kernel(output.name, output.doc)
    k.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    if output.inputs:
        k.array_input("u", system.input_names, "input, laid out as `INPUT_NAMES`")
    for name, value, doc in output.values:
        if isinstance(value, list) and value and isinstance(value[0], list):
            k.output_matrix(name, value, doc)
        elif isinstance(value, list):
            k.output_vector(name, value, doc)
        else:
            k.output_scalar(name, value, doc)
    return k


def _objective(system: System) -> Kernel | None:
    cost = system.cost
    if cost is None:
        return None
    doc = cost.doc.strip() or f"The cost of {system.name}'s filter."
    k = Kernel("objective", f"{doc} The filter minimises 1/2 (u - u_ref)^T P(x) (u - u_ref) + q(x)^T u.")
    k.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    k.output_matrix("p", cost.P, "P(x), symmetric, one row per input")
    k.output_vector("q", cost.q, "q(x), one entry per input")
    return k


def define(system: System, unrolled: bool = False) -> SystemDefinition:
    """Differentiate every family of ``system`` and build its dynamics kernels. With
    ``unrolled``, a composed family's member kernels are also differentiated whole (the
    definition the tests hold the composed rows to; slower)."""
    system.check_complete()
    drift = Kernel("drift", f"The drift f(x) of {system.name}: x' = f(x) + g(x) u.")
    drift.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    drift.output_vector("f", system.f, "f(x), one entry per state")
    g = Kernel("input_matrix", f"The input matrix g(x) of {system.name}: x' = f(x) + g(x) u.")
    g.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    g.output_matrix("g", system.g, "g(x), one row per state, one column per input")
    pattern = tuple((r, c) for r, row in enumerate(system.g) for c, e in enumerate(row) if e != 0)
    nonzeros = Kernel("input_matrix_nonzeros",
                      f"The non-zeros of g(x) of {system.name}, in `INPUT_MATRIX_PATTERN` order: what "
                      "`xdot` multiplies, without the zeros.")
    nonzeros.array_input("x", system.state_names, "state, laid out as `STATE_NAMES`")
    nonzeros.output_vector("g", [system.g[r][c] for r, c in pattern], "g(x) at `INPUT_MATRIX_PATTERN`")
    jets = Jets(system)
    families = _one_sided_authority(system, tuple(_located(system, f, jets, unrolled) for f in system.families))
    outputs = tuple(_output(system, o) for o in system.outputs)
    return SystemDefinition(system.name, system.doc, tuple(system.state_names), tuple(system.state_docs),
                            tuple(system.input_names), tuple(system.input_docs), tuple(system.input_limits),
                            drift, g, pattern, nonzeros, families, outputs, tuple(system.constants),
                            system.source, _objective(system), jets=tuple(jets.kernels), poses=tuple(jets.poses),
                            pose_names=tuple(jets.pose_names), nodes=tuple(jets.nodes()),
                            rigid_bodies=tuple((o.name, o.tree, o.order) for o in system.outputs if o.tree is not None))
