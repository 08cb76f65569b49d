"""The Rust module of one system: the kernels wrapped in the runtime's traits.

Given a :class:`~symbolic.codegen.definition.SystemDefinition`, this writes (for a
system ``planar_robot``, runtime path ``rt``):

* ``DOC``, ``NX``, ``NU``, ``mod state`` / ``mod input`` / ``mod family`` (named indices);
* ``struct PlanarRobot`` implementing ``rt::system::ControlAffine<NX, NU>``;
* the kernels: ``drift``, ``input_matrix`` and one row kernel per family with its
  ``<FAMILY>_RELATIVE_DEGREE`` / ``_INPUT_COLUMNS`` / ``_ROW_NAMES`` constants;
* per family with parameters ``struct <Family>Params`` (named nalgebra fields);
* ``FAMILIES``, ``struct Capacity``, ``struct Params``, ``struct Barriers`` implementing
  ``rt::system::BarrierSet<NU>``;
* ``default_settings()`` and ``type Filter`` for the generic ECBF filter;
* the flat-access traits of ``rt::dynamic`` and ``SYSTEM``, the system behind
  ``rt::dynamic::DynSystem`` (what bindings and tools pick by name);
* ``KERNELS``, the uniform kernel table.

The text must work under ``include!`` inside a ``mod`` block, so it has no inner
attributes or inner doc comments: lint allows sit on the items that need them and the
module's documentation is the ``DOC`` constant (and the system struct's doc).
"""

from __future__ import annotations

import functools
import json

from ....spec import Domain, Interval, NonNegative, Positive, Real, Rotation, UnitVector
from ...composition import library_kernels
from ...definition import FamilyDefinition, SystemDefinition
from .composed import (
    emit_composed_bound,
    emit_composed_member,
    emit_framed_member,
    emit_placements,
    emit_pose_cache,
    emit_pose_function,
)
from .emitter import emit_kernel, emit_split_kernel, float_literal, kernel_fn_type, rustdoc_text
from .kernel_table import emit_kernel_table, kernel_argument, kernel_result
from .rigid_body import emit_rigid_body_output

KERNEL_ALLOWS = ("#[allow(clippy::all, clippy::pedantic, clippy::nursery, unused_parens, unused_variables, "
                 "non_snake_case)]")


def camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def _doc(text: str, indent: str = "") -> list[str]:
    out = []
    for line in text.strip().splitlines() or [""]:
        out.append(f"{indent}/// {rustdoc_text(line)}".rstrip())
    return out


def _str(text: str) -> str:
    """A Rust string literal (JSON escapes are valid Rust escapes for these texts)."""
    return json.dumps(text, ensure_ascii=False)


def _param_type(shape: tuple[int, ...], rt: str) -> str:
    """Through the runtime's re-export of nalgebra, so a user crate needs no nalgebra
    dependency of its own (and cannot pick a mismatched version)."""
    if shape == ():
        return "f64"
    if len(shape) == 1:
        return f"{rt}::nalgebra::SVector<f64, {shape[0]}>"
    return f"{rt}::nalgebra::SMatrix<f64, {shape[0]}, {shape[1]}>"


def _domain(d: Domain, rt: str) -> str:
    """The runtime's ``param_domain::Domain`` for spec domain ``d``."""
    ty = f"{rt}::param_domain::Domain"
    if isinstance(d, Interval):
        return f"{ty}::Interval {{ lo: {float_literal(d.lo)}, hi: {float_literal(d.hi)} }}"
    if isinstance(d, UnitVector):
        return f"{ty}::UnitVector {{ tolerance: {float_literal(d.tol)} }}"
    if isinstance(d, Rotation):
        return f"{ty}::Rotation {{ tolerance: {float_literal(d.tol)} }}"
    names = {Real: "Real", Positive: "Positive", NonNegative: "NonNegative"}
    return f"{ty}::{names[type(d)]}"


def _param_arg(var: str, name: str, shape: tuple[int, ...]) -> str:
    """The kernel argument for field ``name`` of ``var``: a scalar, or a reference to the
    vector or matrix itself (kernels take parameters in the type ``Params`` holds them)."""
    return f"{var}.{name}" if shape == () else f"&{var}.{name}"


def _flat_len(shape: tuple[int, ...]) -> int:
    n = 1
    for d in shape:
        n *= d
    return n


def _flat_instance(w, f: FamilyDefinition, ty: str, rt: str) -> None:
    """``FlatInstance`` for a parameter struct: its numbers in declaration order, vectors
    in order and matrices row by row (the layout Python and ``KERNELS`` use)."""
    total = sum(_flat_len(p.shape) for p in f.params)
    w(f"impl {rt}::dynamic::FlatInstance for {ty} {{")
    w(f"    const LEN: usize = {total};")
    w(f"    const DOMAINS: &'static [(&'static str, {rt}::param_domain::Domain)] = &Self::DOMAINS;")
    w("")
    w("    fn from_flat(values: &[f64]) -> Self {")
    fields, o = [], 0
    for p in f.params:
        n = _flat_len(p.shape)
        if p.shape == ():
            fields.append(f"{p.name}: values[{o}]")
        elif len(p.shape) == 1:
            fields.append(f"{p.name}: {rt}::nalgebra::SVector::from_column_slice(&values[{o}..{o + n}])")
        else:
            fields.append(f"{p.name}: {rt}::nalgebra::SMatrix::from_row_slice(&values[{o}..{o + n}])")
        o += n
    w(f"        Self {{ {', '.join(fields)} }}")
    w("    }")
    w("")
    w("    fn to_flat(&self, out: &mut [f64]) {")
    o = 0
    for p in f.params:
        n = _flat_len(p.shape)
        if p.shape == ():
            w(f"        out[{o}] = self.{p.name};")
        elif len(p.shape) == 1:
            w(f"        out[{o}..{o + n}].copy_from_slice(self.{p.name}.as_slice());")
        else:
            w(f"        out[{o}..{o + n}].copy_from_slice(self.{p.name}.transpose().as_slice());")
        o += n
    w("    }")
    w("")
    w(f"    fn check(&self) -> Result<(), {rt}::error::CbfError> {{")
    w("        self.validate()")
    w("    }")
    w("}")
    w("")


def _match(w, arms: list[str]) -> None:
    """``match (family, member)`` over ``arms``, else ``None`` (just ``None`` without arms)."""
    if not arms:
        w("        let _ = (family, member);")
        w("        None")
        return
    w("        match (family, member) {")
    for arm in arms:
        w(f"            {arm}")
    w("            _ => None,")
    w("        }")


def _poles(f: FamilyDefinition, rt: str) -> str:
    if len(set(f.poles)) == 1:
        return f"{rt}::system::Poles::repeated({float_literal(f.poles[0])}, {f.degree})"
    return f"{rt}::system::Poles::from_array([{', '.join(float_literal(p) for p in f.poles)}])"


def _class_k(f: FamilyDefinition, rt: str) -> str:
    if f.class_k is None:
        return f"{rt}::system::ClassK::LINEAR"
    return f"{rt}::system::ClassK::extended({_str(f.class_k_text)}, {f.class_k.name})"


def _activation(value: float) -> str:
    return "f64::INFINITY" if value == float("inf") else float_literal(value)


def _uniform(f: FamilyDefinition) -> bool:
    """Every member kernel has one Rust type, so they fit in one table of fn pointers.
    (The types differ, if at all, by their argument shapes: any runtime crate path
    compares them alike.)"""
    return len({kernel_fn_type(k, "runtime") for k in f.kernels}) == 1


def _member_tables(w, f: FamilyDefinition, rt: str) -> None:
    """The family-level names of an indexed family: its degree, row names, members, each
    member's input columns and (when their signatures agree) its kernels."""
    u, first = f.name.upper(), f.kernels[0].name.upper()
    n = len(f.members)
    w(f"/// Relative degree of every member of `{f.name}` (found symbolically; the same for all).")
    w(f"pub const {u}_RELATIVE_DEGREE: usize = {first}_RELATIVE_DEGREE;")
    w(f"/// What each row of one `{f.name}` instance constrains (the same for every member).")
    w(f"pub const {u}_ROW_NAMES: [&str; {len(f.row_names)}] = {first}_ROW_NAMES;")
    w(f"/// The members of `{f.name}`, in order.")
    w(f"pub const {u}_MEMBERS: [&str; {n}] = [{', '.join(_str(m) for m in f.members)}];")
    w(f"/// Input columns of each member's kernel, in [`{u}_MEMBERS`] order.")
    w(f"pub const {u}_INPUT_COLUMNS: [&[usize]; {n}] = "
      f"[{', '.join(f'&{k.name.upper()}_INPUT_COLUMNS' for k in f.kernels)}];")
    w(f"/// Input columns of each row of each member, in [`{u}_MEMBERS`] order.")
    w(f"pub const {u}_ROW_COLUMNS: [&[&[usize]]; {n}] = "
      f"[{', '.join(f'&{k.name.upper()}_ROW_COLUMNS' for k in f.kernels)}];")
    if _uniform(f):
        w(f"/// The kernels of `{f.name}`, in [`{u}_MEMBERS`] order.")
        w("#[allow(clippy::type_complexity)] // the kernels' own signature")
        w(f"pub const {u}: [{kernel_fn_type(f.kernels[0], rt)}; {n}] = [{', '.join(k.name for k in f.kernels)}];")
    w("")


def _const_type(value: object) -> str:
    if isinstance(value, list):
        return f"[{_const_type(value[0])}; {len(value)}]"
    return {str: "&str", int: "usize", float: "f64"}[type(value)]


def _const_value(value: object) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(_const_value(v) for v in value) + "]"
    if isinstance(value, str):
        return _str(value)
    return str(value) if isinstance(value, int) else float_literal(value)


def _params_field_type(f: FamilyDefinition, rt: str) -> str:
    p = f"{camel(f.name)}Params"
    if f.capacity:
        elem = f"{rt}::system::Instances<{p}>"
    elif f.optional:
        elem = f"[Option<{p}>; {f.count}]"
    else:
        elem = f"[{p}; {f.count}]"
    return f"[{elem}; {len(f.members)}]" if f.indexed else elem


def _params_field_init(f: FamilyDefinition, rt: str) -> str:
    p = f"{camel(f.name)}Params"
    if f.capacity:
        def make(cap: str) -> str:
            return f'{rt}::system::Instances::with_capacity("{f.name}", {cap})?'
        if f.indexed:
            return "[" + ", ".join(make(f"capacity.{f.name}[{m}]") for m in range(len(f.members))) + "]"
        return make(f"capacity.{f.name}")
    elem = f"[None; {f.count}]" if f.optional else f"[{p}::initial(); {f.count}]"
    return f"[{elem}; {len(f.members)}]" if f.indexed else elem


def _initial_value(p, rt: str) -> str:
    """A parameter's value before it is set: the spec's default, else UNSET throughout."""
    unset = f"{rt}::param_domain::UNSET"
    if p.shape == ():
        return unset if p.default is None else float_literal(p.default[0])
    if p.default is None:
        return f"<{_param_type(p.shape, rt)}>::repeat({unset})"
    values = ", ".join(float_literal(v) for v in p.default)
    # Row-major in the spec, as from_row_slice reads it (a vector is one column either way).
    make = "from_column_slice" if len(p.shape) == 1 else "from_row_slice"
    return f"<{_param_type(p.shape, rt)}>::{make}(&[{values}])"


def _validate_family(w, f: FamilyDefinition) -> None:
    """Every parameter the rows will read this cycle, checked before any row changes; an
    error names the member and instance (a fixed instance never set is still at its zero
    default, which a domain such as Positive refuses here)."""
    if not f.params:
        return
    src = f"params.{f.name}"
    u = f.name.upper()
    if f.indexed:
        w(f"        for (member, instances) in {src}.iter().enumerate() {{")
        w(f"            let member = {u}_MEMBERS.get(member).copied();")
    else:
        w("        {")
        w("            let member = None;")
        w(f"            let instances = &{src};")
    if f.capacity:
        w("            let filled = if instances.is_enabled() { instances.as_slice() } else { &[] };")
        w("            for (instance, p) in filled.iter().enumerate() {")
    else:
        w("            for (instance, p) in instances.iter().enumerate() {")
        if f.optional:
            w("                let Some(p) = p else { continue };")
    w("                p.validate().map_err(|e| e.in_instance(instance).in_member(member))?;")
    w("            }")
    w("        }")


def _evaluate_family(w, f: FamilyDefinition) -> None:
    """Rows of ``f`` into ``self.rows[i..]``, advancing ``i``; members unrolled, so each
    calls its own kernel with its own fixed-size outputs."""
    u = f.name.upper()
    how = "capacity" if f.capacity else f"{f.count} {'optional' if f.optional else 'fixed'} instance(s)"
    members = f" per member ({len(f.members)} members)" if f.indexed else ""
    w(f"        // {f.name}: relative degree {f.degree}, {len(f.row_names)} row(s) per instance, {how}{members}")
    w(f"        let n = {u}_ROW_NAMES.len();")
    for m, k in enumerate(f.kernels):
        src = f"params.{f.name}[{m}]" if f.indexed else f"params.{f.name}"
        cap = f"self.capacity.{f.name}[{m}]" if f.indexed else f"self.capacity.{f.name}"
        per_cycle = ["x"] + (["t"] if f.time else [])
        param_args = [_param_arg("p", p.name, p.shape) for p in f.params]
        args = per_cycle + param_args
        call = f"self::{k.name}({', '.join(args)})"
        framed = f.framed[m] if f.framed else None
        if f.composed:
            poses = [f"&poses.{slot.jet}(x)" for slot in f.composed[m].slots if slot.moving]
            call = f"self::{k.name}_from_poses({', '.join(poses + param_args)})"
        elif framed:
            # The frame's jet once per cycle, for every member on that frame.
            frame = f"&poses.{framed.frame}(x)"
            call = f"self::{k.name}_from_frame({', '.join([frame] + param_args)})"
        elif f.params:
            # The state's part of the kernel once per member and cycle, when an instance
            # first needs it (a member whose instances are all culled or absent never does).
            w("        let mut state_part = None;")
            state = f"state_part.get_or_insert_with(|| self::{k.name}_state({', '.join(per_cycle)}))"
            call = f"self::{k.name}_instance({', '.join([state] + param_args)})"
        cols = f"{k.name.upper()}_INPUT_COLUMNS"
        store = (f"for ((row, lie), lg) in self.rows[i..i + n].iter_mut().zip(&lie).zip(&lg) {{ "
                 f"row.store(lie, lg, &{cols}); }}")
        if f.bounds:
            # A NaN bound fails the comparison: the rows are evaluated and show the NaN. Debug
            # builds evaluate a culled instance too and check the spec's promise, so a wrong
            # bound fails the user's tests, never a release build's control path.
            if f.composed:
                bound_plan = f.composed[m].bound
                poses = [f"&poses.{slot.jet}(x)" for slot in bound_plan.slots if slot.moving]
                bound = f"self::{bound_plan.kernel}_from_poses({', '.join(poses + param_args)})"
            elif framed and framed.bound:
                frame = f"&poses.{framed.bound.frame}(x)"
                bound = f"self::{framed.bound.kernel}_from_frame({', '.join([frame] + param_args)})"
            elif f.params:
                w("        let mut bound_part = None;")
                bound_state = (f"bound_part.get_or_insert_with(|| "
                               f"self::{f.bounds[m].name}_state({', '.join(per_cycle)}))")
                bound = f"self::{f.bounds[m].name}_instance({', '.join([bound_state] + param_args)})"
            else:
                bound = f"self::{f.bounds[m].name}({', '.join(args)})"
            full = f"self::{k.name}({', '.join(args)})"
            check = (f"#[cfg(debug_assertions)] {{ let (lie, _) = {full}; for row in &lie {{ "
                     f"debug_assert!(!(bound > row[0]), \"{f.bounds[m].name} is {{bound}}, above a row's h "
                     f"{{}}: not a lower bound\", row[0]); }} }} ")
            store = (f"let bound = {bound}; if bound > self.cull_above[family::{u}] {{ {check}"
                     f"for row in &mut self.rows[i..i + n] {{ row.cull(bound); }} }} else {{ "
                     f"let (lie, lg) = {call}; {store} }}")
            call = None
        if f.capacity or f.optional:
            # An instance that may be absent: an unfilled slot, or an optional one set to None.
            if f.capacity:
                w(f"        let slots = &{src};")
                w("        let filled = if slots.is_enabled() { slots.as_slice() } else { &[] };")
                w(f"        for slot in 0..{cap} {{")
                w("            let p = filled.get(slot);")
            else:
                w(f"        for p in &{src} {{")
                w("            let p = p.as_ref();")
            w("            if let Some(p) = p {")
            if call:
                w(f"                let (lie, lg) = {call};")
            w(f"                {store}")
            w("            } else {")
            w("                for row in &mut self.rows[i..i + n] { row.active = false; }")
            w("            }")
            w("            i += n;")
            w("        }")
        elif f.params:
            w(f"        for p in &{src} {{")
            if call:
                w(f"            let (lie, lg) = {call};")
            w(f"            {store}")
            w("            i += n;")
            w("        }")
        else:
            if call:
                w(f"        let (lie, lg) = {call};")
            w(f"        {store}")
            w("        i += n;")


class _Cost:
    """An operation count as the generated Rust states it: the numbers this generator
    counted as it printed kernels (``OpCount`` fields in order), plus calls of the core's
    hand-written functions, which state their own (``compose::place_jet_ops``), each with
    how many times it runs."""

    def __init__(self, numbers: list[int] | None = None, terms: dict[str, int] | None = None):
        self.numbers = list(numbers) if numbers is not None else [0] * 8
        self.terms = dict(terms or {})

    @staticmethod
    def call(term: str) -> _Cost:
        return _Cost(terms={term: 1})

    def __add__(self, other: _Cost | list[int]) -> _Cost:
        other = other if isinstance(other, _Cost) else _Cost(other)
        terms = dict(self.terms)
        for t, k in other.terms.items():
            terms[t] = terms.get(t, 0) + k
        return _Cost([a + b for a, b in zip(self.numbers, other.numbers, strict=True)], terms)

    def times(self, n: int) -> _Cost:
        return _Cost([n * a for a in self.numbers], {t: n * k for t, k in self.terms.items()})

    def rust(self) -> str:
        """The count as a Rust expression, with ``OpCount`` and the core's functions in scope
        (:func:`_emit_evaluation_ops` imports them)."""
        if not self.terms and not any(self.numbers):
            return "OpCount::ZERO"
        parts = [f"OpCount::new({self.numbers})"] if any(self.numbers) else []
        parts += [term + (f".times({k})" if k != 1 else "") for term, k in sorted(self.terms.items())]
        return " + ".join(parts)

    def const_rust(self, rt: str) -> str:
        """The count as a constant Rust expression, every path written out (what a
        ``kernel_table!`` line's ``ops { .. }`` holds)."""
        text = f"{rt}::ops::OpCount::new({self.numbers})"
        for term, k in sorted(self.terms.items()):
            text += f".plus({rt}::compose::{term}" + (f".times({k})" if k != 1 else "") + ")"
        return text

    def functions(self) -> set[str]:
        """The core's functions (in ``compose``) the count calls."""
        return {term.split("(")[0] for term in self.terms}


@functools.cache
def _library_ops() -> dict[str, list[int]]:
    """The operations of the core's shared chain and bound kernels (``generated/ssat.rs``),
    counted by printing them as that module does: what a composed row that calls one adds."""
    ops: dict[str, list[int]] = {}
    for k in library_kernels():
        emit_kernel(k, "cbfgen", ops=ops)
    return ops


def _stated(ops: dict[str, list[int]], name: str, in_library: bool = False) -> _Cost | None:
    """The stated count of kernel ``name``: the system's own (``ops``) or the core's shared
    chains' (``in_library``); None where none is stated."""
    table = _library_ops() if in_library else ops
    return _Cost(table[name]) if name in table else None


def _placed(plan) -> _Cost:
    """Placing a pose plan's box in its frame (``compose::place_jet`` or ``place_pose``)."""
    if plan.placement is None:
        return _Cost()
    return _Cost.call("PLACE_POSE_OPS" if plan.value else f"place_jet_ops({12 * plan.degree}, {plan.columns})")


def _composed_row(plan, ops: dict[str, list[int]]) -> _Cost | None:
    """A composed member's row from its poses: the family's chain and the contraction of
    its gradient with each moving pose's input columns."""
    chain = _stated(ops, plan.chain, bool(plan.library))
    if chain is None:
        return None
    for slot in plan.slots:
        if slot.moving:
            chain += _Cost.call(f"accumulate_columns_ops(12, {len(slot.at)})")
    return chain


def _pose_cache_ops(d: SystemDefinition, ops: dict[str, list[int]]) -> _Cost | str:
    """Every entry of the cycle's ``PoseCache`` once (each is computed at most once per
    cycle): the node kernels' jets and values, and each box placed in its frame; or the
    name of a node whose operations are not stated."""
    cost = _Cost()
    for name, _ in d.nodes:
        if name not in ops:
            return name
        cost += ops[name]
    for plan in d.poses:
        cost += _placed(plan)
    return cost


def _assembled_ops(d: SystemDefinition, ops: dict[str, list[int]]) -> dict[str, _Cost]:
    """The counts of the kernels assembled from others, as their ``x`` entry points run
    them (each pose computed afresh along its path, no cache): a composed member (its
    poses, its chain, the contraction per pose) and its lower bound (its poses' values,
    its bound kernel); a member on a frame (the frame's path, its kernel on the frame) and
    its bound. Those whose parts all state a count."""
    plans = {plan.name: plan for plan in d.poses}

    def pose(name: str) -> _Cost | None:
        plan = plans.get(name)
        if plan is None or any(step not in ops for step in plan.steps):
            return None
        return sum((_Cost(ops[step]) for step in plan.steps), _placed(plan))

    out: dict[str, _Cost] = {}
    for f in d.families:
        for m, k in enumerate(f.kernels):
            parts: list[tuple[str, list[_Cost | None]]] = []
            if f.composed:
                plan = f.composed[m]
                parts.append((k.name, [pose(slot.jet) for slot in plan.slots if slot.moving]
                              + [_composed_row(plan, ops)]))
                if plan.bound:
                    bound = plan.bound
                    parts.append((bound.kernel, [pose(slot.jet) for slot in bound.slots if slot.moving]
                                  + [_stated(ops, bound.chain, bool(bound.library))]))
            elif f.framed and f.framed[m]:
                framed = f.framed[m]
                for plan in (framed, framed.bound):
                    if plan:
                        parts.append((plan.kernel, [pose(plan.frame), _stated(ops, plan.on_frame)]))
            for name, costs in parts:
                if all(c is not None for c in costs):
                    out[name] = sum(costs, _Cost())
    return out


def _member_ops(f: FamilyDefinition, m: int, ops: dict[str, list[int]]) -> tuple[_Cost, _Cost] | str:
    """What ``evaluate`` performs for member ``m`` of ``f`` (as :func:`_evaluate_family`
    writes it, its lower bound included, nothing culled), in its state part (once per
    cycle when the member has an instance) and its instance part (per instance); poses
    read from the ``PoseCache`` are counted there. Or the name of a called function whose
    operations are not stated."""
    k = f.kernels[m]
    if f.composed:
        plan = f.composed[m]
        instance = _composed_row(plan, ops)
        if instance is None:
            return plan.chain
        if f.bounds and plan.bound:
            bound = _stated(ops, plan.bound.chain, bool(plan.bound.library))
            if bound is None:
                return plan.bound.chain
            instance += bound
        return _Cost(), instance
    framed = f.framed[m] if f.framed else None
    pieces: list[tuple[str, str | None]] = [(k.name, framed.on_frame if framed else None)]
    if f.bounds:
        pieces.append((f.bounds[m].name, framed.bound.on_frame if framed and framed.bound else None))
    state, instance = _Cost(), _Cost()
    for name, on_frame in pieces:
        # On a frame: the kernel on the frame per instance; with parameters: its state part
        # once, its instance part per instance; else the whole kernel once.
        parts = ([("", on_frame)] if on_frame is not None else
                 [("state", f"{name}_state"), ("", f"{name}_instance")] if f.params else [("", name)])
        for part, kernel in parts:
            found = _stated(ops, kernel)
            if found is None:
                return kernel
            if part == "state":
                state += found
            else:
                instance += found
    return state, instance


def _evaluation_ops(d: SystemDefinition, ops: dict[str, list[int]]) -> tuple[_Cost, list] | str:
    """The operations ``evaluate`` performs with every instance present and nothing culled:
    ``(fixed, slots)``, what runs a number of times the spec fixes summed in ``fixed`` (the
    pose cache's entries included) and, per capacity member, ``(family, state part,
    instance part, its capacity in Rust)`` (the state part once when the member has a
    slot, the instance part per slot); or the name of a called function whose operations
    are not stated."""
    fixed = _Cost()
    slots: list[tuple[str, _Cost, _Cost, str]] = []
    if d.pose_names:
        cache = _pose_cache_ops(d, ops)
        if isinstance(cache, str):
            return cache
        fixed += cache
    for f in d.families:
        for m in range(len(f.kernels)):
            found = _member_ops(f, m, ops)
            if isinstance(found, str):
                return found
            state, instance = found
            if f.capacity:
                slots.append((f.name, state, instance, f"c.{f.name}[{m}]" if f.indexed else f"c.{f.name}"))
            elif f.params:
                fixed += state + instance.times(f.count)
            else:
                fixed += state + instance
    return fixed, slots


def _emit_evaluation_ops(w, d: SystemDefinition, rt: str, ops: dict[str, list[int]]) -> None:
    """``evaluation_ops``: :func:`_evaluation_ops` as the method states it."""
    found = _evaluation_ops(d, ops)
    w(f"    fn evaluation_ops(&self) -> Option<{rt}::ops::OpCount> {{")
    if isinstance(found, str):
        w(f"        None // `{found}` states no count")
    else:
        fixed, slots = found
        used = set().union(*(c.functions() for c in [fixed, *(p for s in slots for p in s[1:3])]))
        w(f"        use {rt}::ops::OpCount;")
        if used:
            w(f"        use {rt}::compose::{{{', '.join(sorted(used))}}};")
        w(f"        let fixed = {fixed.rust()};")
        if slots:
            w("        let c = &self.capacity;")
            # A composed family's members share their chain: its count named once.
            by_family: dict[str, list[_Cost]] = {}
            for family, _, instance, _ in slots:
                by_family.setdefault(family, []).append(instance)
            shared = {family: costs[0].numbers for family, costs in by_family.items()
                      if len(costs) > 1 and all(c.terms for c in costs)
                      and all(c.numbers == costs[0].numbers for c in costs)}
            for family, numbers in shared.items():
                w(f"        let {family} = OpCount::new({numbers});")

            def instance_text(family: str, instance: _Cost) -> str:
                if family in shared:
                    return f"{family} + {_Cost(terms=instance.terms).rust()}"
                return instance.rust()
            w("        Some(fixed.plus_slots(&[" + ", ".join(
                f"({st.rust()}, {instance_text(family, i)}, {cap})" for family, st, i, cap in slots) + "]))")
        else:
            w("        Some(fixed)")
    w("    }")
    w("")


class _Names:
    """Every item name the module defines, so a clash is an error here, not in rustc."""

    def __init__(self, system: str):
        self.system = system
        self.seen: dict[str, str] = {}

    def add(self, name: str, what: str) -> str:
        if name in self.seen:
            from ....spec import SpecError
            raise SpecError(f"system {self.system!r}: {what} would be named `{name}`, as is "
                            f"{self.seen[name]}; rename one of them")
        self.seen[name] = what
        return name


def _reserve_names(d: SystemDefinition) -> None:
    """Every item name the module will define, so a clash is a SpecError naming both."""
    sys_type = camel(d.name)
    names = _Names(d.name)
    for item, what in [("DOC", "the module doc"), ("NX", "the state count"), ("NU", "the input count"),
                       ("state", "the state indices"), ("input", "the input indices"),
                       ("family", "the family indices"), (sys_type, "the system type"),
                       ("FAMILIES", "the family table"), ("Capacity", "the capacity type"),
                       ("Params", "the parameter type"), ("Barriers", "the barrier set"),
                       ("default_settings", "the default settings"), ("Filter", "the filter type"),
                       ("KERNELS", "the kernel table"), ("kernel_table", "the kernel wrappers"),
                       ("SYSTEM", "the erased system"), ("STATE_NAMES", "the state names"),
                       ("INPUT_NAMES", "the input names"),
                       ("INPUT_MATRIX_PATTERN", "the input matrix pattern"), ("xdot", "the dynamics")]:
        names.add(item, what)
    for k in d.kernels():
        names.add(k.name, f"kernel `{k.name}`")
        for c in k.constants:
            names.add(c.name, f"constant of kernel `{k.name}`")
    for f in d.families:
        if f.params:
            names.add(f"{camel(f.name)}Params", f"the parameters of family `{f.name}`")
        for k in f.kernels:
            names.add(f"{k.name.upper()}_ROW_COLUMNS", f"the row columns of kernel `{k.name}`")
        if f.capacity:
            names.add(f"{f.name.upper()}_MAX_CAPACITY", f"the largest capacity of family `{f.name}`")
        if f.indexed:
            u = f.name.upper()
            for suffix in ("RELATIVE_DEGREE", "ROW_NAMES", "INPUT_COLUMNS", "ROW_COLUMNS", "MEMBERS"):
                names.add(f"{u}_{suffix}", f"a table of family `{f.name}`")
            if _uniform(f):
                names.add(u, f"the kernel table of family `{f.name}`")
    for c in d.constants:
        names.add(c.name.upper(), f"constant `{c.name}`")
    for name, _, _ in d.rigid_bodies:
        names.add(f"{name}_ops", f"the operations of rigid-body output `{name}`")


def _emit_description(out: list[str], d: SystemDefinition, rt: str) -> None:
    """`DOC`, the sizes and the index modules of states, inputs and families."""
    w = out.append
    nx, nu = len(d.state_names), len(d.input_names)
    doc = d.doc.strip() or f"The {d.name} system."
    doc = d.doc.strip() or f"The {d.name} system."
    w(f"/// What the `{d.name}` module is: the spec's description.")
    w(f"pub const DOC: &str = {_str(doc)};")
    w("")
    w("/// Number of states.")
    w(f"pub const NX: usize = {nx};")
    w("/// Number of inputs.")
    w(f"pub const NU: usize = {nu};")
    w("")
    for mod, what, entries, docs in [("state", "states in `x`", d.state_names, d.state_docs),
                                     ("input", "inputs in `u`", d.input_names, d.input_docs)]:
        w(f"/// Indices of the {what}.")
        w(f"pub mod {mod} {{")
        for i, (n, nd) in enumerate(zip(entries, docs, strict=True)):
            out.extend(_doc(f"`{n}`" + (f": {nd}" if nd else "."), "    "))
            w(f"    pub const {n.upper()}: usize = {i};")
        w("}")
        w("")
    w("/// Indices of the families in [`FAMILIES`] (and `RowLayout::family`).")
    w("pub mod family {")
    for i, f in enumerate(d.families):
        kind = "a Lyapunov function, " if f.kind == "lyapunov" else ""
        w(f"    /// `{f.name}` ({kind}priority {f.priority}).")
        for warning in f.warnings:
            w("    ///")
            out.extend(_doc(f"Warning from the generator: {warning}", "    "))
        w(f"    pub const {f.name.upper()}: usize = {i};")
    w("}")
    w("")


def _emit_system_type(out: list[str], d: SystemDefinition, rt: str) -> None:
    """The system type and its `ControlAffine` impl, the layouts, `xdot` and the spec's constants."""
    w = out.append
    sys_type = camel(d.name)
    nx, nu = len(d.state_names), len(d.input_names)
    doc = d.doc.strip() or f"The {d.name} system."
    out.extend(_doc(doc))
    w("///")
    w(f"/// The control-affine model x' = f(x) + g(x) u, with {nx} state{'s' * (nx != 1)} (see [`state`]) "
      f"and {nu} input{'s' * (nu != 1)} (see [`input`]).")
    w("#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]")
    w(f"pub struct {sys_type};")
    w("")
    lower = ", ".join(float_literal(lim.lower) for lim in d.input_limits)
    upper = ", ".join(float_literal(lim.upper) for lim in d.input_limits)
    w(f"impl {rt}::system::ControlAffine<NX, NU> for {sys_type} {{")
    w(f"    const NAME: &'static str = {_str(d.name)};")
    w(f"    const STATE_NAMES: [&'static str; NX] = [{', '.join(_str(n) for n in d.state_names)}];")
    w(f"    const INPUT_NAMES: [&'static str; NU] = [{', '.join(_str(n) for n in d.input_names)}];")
    w(f"    const INPUT_MIN: [f64; NU] = [{lower}];")
    w(f"    const INPUT_MAX: [f64; NU] = [{upper}];")
    w("")
    w("    fn drift(x: &[f64; NX]) -> [f64; NX] {")
    w("        self::drift(x)")
    w("    }")
    w("")
    w("    fn input_matrix(x: &[f64; NX]) -> [[f64; NU]; NX] {")
    w("        self::input_matrix(x)")
    w("    }")
    w("}")
    w("")
    w("/// State layout, as `ControlAffine::STATE_NAMES`.")
    w(f"pub const STATE_NAMES: [&str; NX] = [{', '.join(_str(n) for n in d.state_names)}];")
    w("/// Input layout, as `ControlAffine::INPUT_NAMES`.")
    w(f"pub const INPUT_NAMES: [&str; NU] = [{', '.join(_str(n) for n in d.input_names)}];")
    w("/// (state row, input column) of each non-zero of g(x), as [`input_matrix_nonzeros`] returns them.")
    pattern = ", ".join(f"({r}, {c})" for r, c in d.input_pattern)
    w(f"pub const INPUT_MATRIX_PATTERN: [(usize, usize); {len(d.input_pattern)}] = [{pattern}];")
    w("")
    w("/// x' = f(x) + g(x) u, multiplying only the non-zeros of g.")
    w("pub fn xdot(x: &[f64; NX], u: &[f64; NU]) -> [f64; NX] {")
    w("    let mut dx = drift(x);")
    w("    for (&(row, col), g) in INPUT_MATRIX_PATTERN.iter().zip(input_matrix_nonzeros(x)) {")
    w("        dx[row] += g * u[col];")
    w("    }")
    w("    dx")
    w("}")
    w("")
    for c in d.constants:
        out.extend(_doc(c.doc))
        w("#[allow(clippy::approx_constant)] // the spec's numbers, whatever they resemble")
        w(f"pub const {c.name.upper()}: {_const_type(c.value)} = {_const_value(c.value)};")
    if d.constants:
        w("")


def _emit_interval_kernels(out: list[str], d: SystemDefinition, rt: str) -> None:
    """``INTERVAL_KERNELS``: the dynamics and every family's members on intervals, in the
    order the core's ``enclose_generated`` indexes them (``IntervalKernel::NONE`` for a
    kernel without an interval form)."""
    by_name = {k.name: k for k in d.kernels()}
    none = f"{rt}::filter::between_samples::IntervalKernel::NONE"

    def entry(name: str, columns: str) -> str:
        k = by_name.get(name)
        if k is None:
            return f"    {none},"
        return (f"    {rt}::interval_kernel!({k.name}{columns}({', '.join(map(kernel_argument, k.inputs))}) -> "
                f"({', '.join(map(kernel_result, k.outputs))})),")

    lines = [entry("drift", ""), entry("input_matrix", "")]
    lines += [entry(k.name, f"[{k.name.upper()}_INPUT_COLUMNS]") for f in d.families for k in f.kernels]
    out += ["/// The dynamics and every family's members on intervals, members in family order: what",
            f"/// certifies the rows between the samples (`{rt}::filter::between_samples`).",
            f"pub const INTERVAL_KERNELS: &[{rt}::filter::between_samples::IntervalKernel] = &[", *lines, "];", ""]


def _emit_kernels(out: list[str], d: SystemDefinition, rt: str, ops: dict[str, list[int]]) -> None:
    """Every kernel, each family's row columns and an indexed family's member tables; the
    operations of each kernel printed as one straight line go into ``ops``."""
    w = out.append
    # A family with parameters evaluates each member's kernel at many instances per state:
    # its kernels (rows and bound) are emitted cut in two, the state's part shared.
    split_kernels = {k.name: ["x"] + (["t"] if f.time else []) for f in d.families if f.params
                     for k in (*f.kernels, *f.bounds)}
    # A composed family's members are assembled from their pose and chain kernels.
    composed = {plan.kernel: (f, plan) for f in d.families for plan in f.composed}
    composed_bounds = {plan.bound.kernel: (f, plan.bound) for f in d.families for plan in f.composed if plan.bound}
    # A member whose rows read one frame is computed on that frame's jet.
    framed = {p.kernel: p for f in d.families for plan in f.framed if plan for p in (plan, plan.bound) if p}
    nodes = {name for name, _ in d.nodes}
    # A composed family's chain and bound kernels serve every member: compiled once.
    shared = nodes | {k.name for f in d.families if f.composed for k in f.chains}
    # A rigid-body dynamics output walks its tree at run time.
    rigid_bodies = {name: (tree, order) for name, tree, order in d.rigid_bodies}
    for k in d.kernels():
        if k.name in rigid_bodies:
            w(emit_rigid_body_output(k, *rigid_bodies[k.name], rt, attributes=[KERNEL_ALLOWS]))
        elif k.name in framed:
            w(emit_framed_member(k, framed[k.name], rt, attributes=[KERNEL_ALLOWS]))
        elif k.name in composed:
            f, plan = composed[k.name]
            w(emit_composed_member(k, plan, f.degree, bool(f.params), rt, attributes=[KERNEL_ALLOWS]))
        elif k.name in composed_bounds:
            f, bound = composed_bounds[k.name]
            w(emit_composed_bound(k, bound, bool(f.params), rt, attributes=[KERNEL_ALLOWS]))
        elif k.name in split_kernels:
            w(emit_split_kernel(k, rt, split_kernels[k.name], attributes=[KERNEL_ALLOWS], ops=ops))
        elif k.name in shared:
            # Compiled once and called: inlined, every member would repeat the chain, and
            # every path down the tree every joint above it.
            w(emit_kernel(k, rt, attributes=[KERNEL_ALLOWS], inline="#[inline(never)]", ops=ops))
        else:
            w(emit_kernel(k, rt, attributes=[KERNEL_ALLOWS], ops=ops))
    w(emit_placements(d.poses, rt, attributes=[KERNEL_ALLOWS]))
    for plan in d.poses:
        w(emit_pose_function(plan, len(d.state_names), rt, attributes=[KERNEL_ALLOWS]))
    if d.pose_names:
        by_name = {k.name: k for k in d.jets}
        w(emit_pose_cache([(by_name[name], parent) for name, parent in d.nodes], d.poses, len(d.state_names), rt,
                          attributes=[KERNEL_ALLOWS]))
    for f in d.families:
        for k, per_row in zip(f.kernels, f.row_columns, strict=True):
            w(f"/// Input columns each row of [`{k.name}`] can touch (its own sparsity in the QP; "
              f"`{k.name.upper()}_INPUT_COLUMNS` is their union).")
            rows = ", ".join("&[" + ", ".join(map(str, cols)) + "]" for cols in per_row)
            w(f"pub const {k.name.upper()}_ROW_COLUMNS: [&[usize]; {len(per_row)}] = [{rows}];")
        if f.indexed:
            _member_tables(w, f, rt)


def _emit_parameter_structs(out: list[str], d: SystemDefinition, rt: str) -> None:
    """Each family's parameter struct: fields, domains, `validate`, flat access."""
    w = out.append
    for f in d.families:
        if not f.params:
            continue
        ty = f"{camel(f.name)}Params"
        out.extend(_doc(f"Parameters of one `{f.name}` instance." + (f" {f.doc.strip()}" if f.doc.strip() else "")))
        w("#[derive(Debug, Clone, Copy, PartialEq, Default)]")
        w(f"pub struct {ty} {{")
        for p in f.params:
            pdoc = p.doc or f"`{p.name}`"
            if len(p.shape) == 2:
                pdoc += f" ({p.shape[0]} x {p.shape[1]})"
            if not isinstance(p.domain, Real):
                pdoc += f". Domain: {p.domain}"
            out.extend(_doc(pdoc, "    "))
            w(f"    pub {p.name}: {_param_type(p.shape, rt)},")
        w("}")
        w("")
        w(f"impl {ty} {{")
        w(f"    /// The domain of each parameter, in declaration order (see `{rt}::param_domain`).")
        w(f"    pub const DOMAINS: [(&'static str, {rt}::param_domain::Domain); {len(f.params)}] = [")
        for p in f.params:
            w(f"        ({_str(p.name)}, {_domain(p.domain, rt)}),")
        w("    ];")
        w("")
        w("    /// `Ok(())` when every parameter lies in its domain ([`Self::DOMAINS`]; every number")
        w(f"    /// finite and within `±{rt}::system::PARAM_LIMIT`, and what the spec declares).")
        w("    ///")
        w("    /// # Errors")
        w(f"    /// [`{rt}::error::CbfError::ParamOutOfDomain`] naming the family and parameter, what its")
        w("    /// domain asks and what was found (the caller names the instance).")
        w(f"    pub fn validate(&self) -> Result<(), {rt}::error::CbfError> {{")
        for i, p in enumerate(f.params):
            values = f"core::slice::from_ref(&self.{p.name})" if p.shape == () else f"self.{p.name}.as_slice()"
            shape = "&[" + ", ".join(map(str, p.shape)) + "]"
            w(f"        {rt}::param_domain::check({_str(f.name)}, {_str(p.name)}, Self::DOMAINS[{i}].1, {shape}, "
              f"{values})?;")
        w("        Ok(())")
        w("    }")
        if not f.capacity:
            w("")
            defaults = [p.name for p in f.params if p.default is not None]
            said = (f"the spec's defaults ({', '.join(defaults)}), " if defaults else "")
            w(f"    /// What a fixed instance holds before it is set: {said}[`{rt}::param_domain::UNSET`]")
            w("    /// for every parameter without a default, which [`Self::validate`] refuses: a barrier set")
            w("    /// does not run on parameters nobody set.")
            w("    pub fn initial() -> Self {")
            fields = ", ".join(f"{p.name}: {_initial_value(p, rt)}" for p in f.params)
            w(f"        Self {{ {fields} }}")
            w("    }")
        w("}")
        w("")
        _flat_instance(w, f, ty, rt)


def _emit_family_table(out: list[str], d: SystemDefinition, rt: str) -> None:
    """`FAMILIES`: each family's description and defaults."""
    w = out.append
    w("/// The barrier families, in spec order (indexed by `RowLayout::family`, see [`family`]).")
    w(f"pub const FAMILIES: [{rt}::system::FamilyInfo; {len(d.families)}] = [")
    for f in d.families:
        u = f.name.upper()
        w(f"    {rt}::system::FamilyInfo {{")
        w(f"        name: {_str(f.name)},")
        w(f"        kind: {rt}::system::FamilyKind::{'Lyapunov' if f.kind == 'lyapunov' else 'Barrier'},")
        w(f"        relative_degree: {u}_RELATIVE_DEGREE,")
        w(f"        row_names: &{u}_ROW_NAMES,")
        w(f"        members: &{u}_MEMBERS," if f.indexed else "        members: &[],")
        kind = "Capacity" if f.capacity else "Optional" if f.optional else "Fixed"
        w(f"        instances: {rt}::system::InstanceKind::{kind},")
        w(f"        count: {f.max_capacity if f.capacity else f.count},")
        shapes = [f"({_str(p.name)}, &[{', '.join(map(str, p.shape))}])" for p in f.params]
        w(f"        params: &[{', '.join(shapes)}],")
        w(f"        defaults: {rt}::system::FamilyParams {{")
        w(f"            poles: {_poles(f, rt)},")
        w(f"            priority: {f.priority},")
        w(f"            activation: {_activation(f.activation)},")
        w(f"            class_k: {_class_k(f, rt)},")
        w("        },")
        w("    },")
    w("];")
    w("")


def _emit_capacity(out: list[str], d: SystemDefinition, rt: str) -> None:
    """`Capacity`: the room each capacity family has, its check and row count."""
    w = out.append
    cap_families = [f for f in d.families if f.capacity]
    for f in cap_families:
        w(f"/// The largest capacity `{f.name}` accepts{' per member' if f.indexed else ''} (the spec's).")
        w(f"pub const {f.name.upper()}_MAX_CAPACITY: usize = {f.max_capacity};")
    w("/// How many instances each capacity family has room for; fixed at construction, so the")
    w("/// row layout (and the QP's sparsity) is too.")
    w("#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]")
    w("pub struct Capacity {")
    for f in cap_families:
        if f.indexed:
            w(f"    /// Slots for `{f.name}` instances per member, in [`{f.name.upper()}_MEMBERS`] order (each at "
              f"most `{rt}::system::MAX_INSTANCES`).")
            w(f"    pub {f.name}: [usize; {len(f.members)}],")
        else:
            w(f"    /// Slots for `{f.name}` instances (at most `{rt}::system::MAX_INSTANCES`).")
            w(f"    pub {f.name}: usize,")
    w("}")
    w("")

    w("impl Capacity {")
    w("    /// `Ok(())` when every count is within its family's `*_MAX_CAPACITY`.")
    w("    ///")
    w("    /// # Errors")
    w(f"    /// [`{rt}::error::CbfError::TooLarge`] naming the family.")
    w(f"    pub fn validate(&self) -> Result<(), {rt}::error::CbfError> {{")
    for f in cap_families:
        u = f.name.upper()
        counts = ([f"self.{f.name}[{m}]" for m in range(len(f.members))] if f.indexed else [f"self.{f.name}"])
        for cap in counts:
            w(f"        if {cap} > {u}_MAX_CAPACITY {{")
            w(f"            return Err({rt}::error::CbfError::TooLarge {{ what: {_str(f.name + ' capacity')}, "
              f"value: {cap}, max: {u}_MAX_CAPACITY }});")
            w("        }")
    w("        Ok(())")
    w("    }")
    w("")
    w("    /// Rows a barrier set of this capacity lays out (saturating, so an unvalidated")
    w("    /// capacity cannot wrap the count).")
    w("    pub fn rows(&self) -> usize {")
    fixed_rows = sum(f.count * len(f.row_names) * max(1, len(f.members)) for f in d.families if not f.capacity)
    terms = []
    for f in cap_families:
        counts = ([f"self.{f.name}[{m}]" for m in range(len(f.members))] if f.indexed else [f"self.{f.name}"])
        terms += [f".saturating_add({cap}.saturating_mul({len(f.row_names)}))" for cap in counts]
    w(f"        {fixed_rows}usize{''.join(terms)}")
    w("    }")
    w("}")
    w("")
    w(f"impl {rt}::dynamic::FlatCapacity for Capacity {{")
    w("    fn count_mut(&mut self, family: usize, member: usize) -> Option<&mut usize> {")
    arms = [f"(family::{f.name.upper()}, m) => self.{f.name}.get_mut(m)," if f.indexed
            else f"(family::{f.name.upper()}, 0) => Some(&mut self.{f.name}),"
            for f in cap_families]
    _match(w, arms)
    w("    }")
    w("}")
    w("")


def _emit_params(out: list[str], d: SystemDefinition, rt: str) -> None:
    """`Params`: every family's instances, and their flat access."""
    w = out.append
    cap_families = [f for f in d.families if f.capacity]
    w("/// Every family's runtime instances: what [`Barriers`] reads besides the state and time.")
    w("#[derive(Debug, Clone, PartialEq)]")
    w("pub struct Params {")
    for f in d.families:
        if not f.params:
            continue
        per = f" per member, in [`{f.name.upper()}_MEMBERS`] order" if f.indexed else ""
        if f.capacity:
            what = f"The `{f.name}` instances{per}, filled at run time up to [`Capacity::{f.name}`]."
        elif f.optional:
            what = f"The {f.count} `{f.name}` instance(s){per}; `None` switches one off."
        else:
            what = f"The {f.count} `{f.name}` instance(s){per}, always active."
        w(f"    /// {what}")
        w(f"    pub {f.name}: {_params_field_type(f, rt)},")
    w("}")
    w("")
    w("impl Params {")
    w("    /// Fixed instances at their spec defaults or unset (refused until set, see each")
    w("    /// parameter struct's `initial`), optional ones off, and empty capacity families sized")
    w("    /// for `capacity`.")
    w("    ///")
    w("    /// # Errors")
    w(f"    /// [`{rt}::error::CbfError::TooLarge`] for a capacity above its family's maximum.")
    w(f"    pub fn new(capacity: Capacity) -> Result<Self, {rt}::error::CbfError> {{")
    w("        capacity.validate()?;")
    w("        Ok(Self {")
    for f in d.families:
        if f.params:
            w(f"            {f.name}: {_params_field_init(f, rt)},")
    w("        })")
    w("    }")
    w("")
    w("    /// The capacities these parameters were sized for.")
    w("    pub fn capacity(&self) -> Capacity {")
    fields = []
    for f in cap_families:
        if f.indexed:
            fields.append(f"{f.name}: core::array::from_fn(|m| self.{f.name}[m].capacity())")
        else:
            fields.append(f"{f.name}: self.{f.name}.capacity()")
    w("        Capacity {" + ", ".join(fields) + "}")
    w("    }")
    w("}")
    w("")

    param_families = [f for f in d.families if f.params]
    w(f"impl {rt}::dynamic::FlatParams for Params {{")
    w(f"    const SYSTEM: &'static str = {_str(d.name)};")
    w(f"    const FAMILIES: &'static [{rt}::system::FamilyInfo] = &FAMILIES;")
    w("")
    for fn, ref, get in [("store", "&", "get"), ("store_mut", "&mut ", "get_mut")]:
        self_ref = "&self" if ref == "&" else "&mut self"
        store = f"{ref}dyn {rt}::dynamic::FamilyStore"
        w(f"    fn {fn}({self_ref}, family: usize, member: usize) -> Option<{store}> {{")
        arms = [f"(family::{f.name.upper()}, m) => self.{f.name}.{get}(m).map(|s| s as {store})," if f.indexed
                else f"(family::{f.name.upper()}, 0) => Some({ref}self.{f.name}),"
                for f in param_families]
        _match(w, arms)
        w("    }")
        w("")
    w("}")
    w("")


def _emit_barriers(out: list[str], d: SystemDefinition, rt: str, ops: dict[str, list[int]]) -> None:
    """`Barriers`: the row layout for a capacity and the `BarrierSet` that evaluates it
    (``ops``: the kernels' operations, for `evaluation_ops`)."""
    w = out.append
    w("/// The rows of every family, laid out once for a [`Capacity`] and evaluated each cycle")
    w("/// into preallocated storage. Row order: families in spec order; within a family,")
    w("/// instance by instance, the rows of one instance consecutive.")
    w("#[derive(Debug, Clone, PartialEq)]")
    w("pub struct Barriers {")
    w("    capacity: Capacity,")
    w(f"    layout: Vec<{rt}::system::RowLayout>,")
    w(f"    rows: Vec<{rt}::system::Row<NU>>,")
    culls = any(f.bounds for f in d.families)
    if culls:
        w("    /// Per family: instances whose lower bound exceeds this are culled (`+inf`: none).")
        w(f"    cull_above: [f64; {len(d.families)}],")
    w("}")
    w("")
    w("impl Barriers {")
    w("    /// Lay out the rows for `capacity`; every row starts inactive.")
    w("    ///")
    w("    /// # Errors")
    w(f"    /// [`{rt}::error::CbfError::TooLarge`] for a capacity above its family's maximum.")
    w("    #[allow(clippy::needless_range_loop)] // the loops mirror the layout's nesting")
    w(f"    pub fn new(capacity: Capacity) -> Result<Self, {rt}::error::CbfError> {{")
    w("        capacity.validate()?;")
    w("        let mut layout = Vec::with_capacity(capacity.rows());")
    for f in d.families:
        u = f.name.upper()
        if f.indexed:
            count = f"capacity.{f.name}[member]" if f.capacity else str(f.count)
            w(f"        for member in 0..{len(f.members)} {{")
            columns = f"{u}_ROW_COLUMNS[member][row]"
        else:
            count = f"capacity.{f.name}" if f.capacity else str(f.count)
            w("        {")
            w("            let member = 0;")
            columns = f"{u}_ROW_COLUMNS[row]"
        w(f"            for instance in 0..{count} {{")
        w(f"                for row in 0..{u}_ROW_NAMES.len() {{")
        w(f"                    layout.push({rt}::system::RowLayout {{ family: family::{u}, member, instance, row, "
          f"columns: {columns} }});")
        w("                }")
        w("            }")
        w("        }")
    w(f"        let rows = vec![{rt}::system::Row::ZERO; layout.len()];")
    cull = f", cull_above: [f64::INFINITY; {len(d.families)}]" if culls else ""
    w(f"        Ok(Self {{ capacity, layout, rows{cull} }})")
    w("    }")
    w("")
    w("    /// The capacity the rows were laid out for.")
    w("    pub fn capacity(&self) -> Capacity {")
    w("        self.capacity")
    w("    }")
    w("}")
    w("")

    w(f"impl {rt}::system::BarrierSet<NU> for Barriers {{")
    w("    type State = [f64; NX];")
    w("    type Params = Params;")
    w("")
    w(f"    fn families(&self) -> &[{rt}::system::FamilyInfo] {{")
    w("        &FAMILIES")
    w("    }")
    w("")
    w(f"    fn layout(&self) -> &[{rt}::system::RowLayout] {{")
    w("        &self.layout")
    w("    }")
    w("")
    w(f"    fn rows(&self) -> &[{rt}::system::Row<NU>] {{")
    w("        &self.rows")
    w("    }")
    w("")
    _emit_evaluation_ops(w, d, rt, ops)
    if culls:
        w("    fn cull_above(&mut self, thresholds: &[f64]) {")
        w("        for (cull, &threshold) in self.cull_above.iter_mut().zip(thresholds) {")
        w("            *cull = threshold;")
        w("        }")
        w("    }")
        w("")
    if d.objective is not None:
        w("    fn has_objective(&self) -> bool {")
        w("        true")
        w("    }")
        w("")
        w(f"    fn objective(&self, _t: f64, x: &[f64; NX], _params: &Params, "
          f"cost: &mut {rt}::system::Objective<NU>) {{")
        w("        (cost.p, cost.q) = objective(x);")
        w("    }")
        w("")
    w(f"    fn evaluate(&mut self, t: f64, x: &[f64; NX], params: &Params) -> Result<(), {rt}::error::CbfError> {{")
    w("        if params.capacity() != self.capacity {")
    w(f"            return Err({rt}::error::CbfError::CapacityMismatch);")
    w("        }")
    w(f"        {rt}::system::validate_state(x)?;")
    # Checked even where no family reads it: every system refuses the same inputs.
    w(f"        {rt}::system::validate_time(t)?;")
    for f in d.families:
        _validate_family(w, f)
    if d.pose_names:
        # Composed rows' poses: each evaluated once per cycle, when a row first needs it.
        w("        let mut poses = PoseCache::default();")
    w("        let mut i = 0;")
    for f in d.families:
        _evaluate_family(w, f)
    w("        debug_assert_eq!(i, self.rows.len());")
    w("        Ok(())")
    w("    }")
    w("")
    # `enclose` and `enclose_over`, on this system's interval kernels.
    w(f"    {rt}::generated_enclosure!({camel(d.name)});")
    w("}")
    w("")


def _emit_filter_and_system(out: list[str], d: SystemDefinition, rt: str) -> None:
    """`default_settings`, `Filter`, and the system behind the core's type-erased layer."""
    w = out.append
    sys_type = camel(d.name)
    w("/// The spec's defaults: every family's poles, slack weight and activation, and the")
    w("/// input limits.")
    w(f"pub fn default_settings() -> {rt}::filter::FilterSettings<NU> {{")
    w(f"    {rt}::filter::FilterSettings::defaults(")
    w("        &FAMILIES,")
    w(f"        <{sys_type} as {rt}::system::ControlAffine<NX, NU>>::INPUT_MIN,")
    w(f"        <{sys_type} as {rt}::system::ControlAffine<NX, NU>>::INPUT_MAX,")
    w("    )")
    w("}")
    w("")
    w("/// The ECBF-QP safety filter over this system's [`Barriers`].")
    w(f"pub type Filter = {rt}::filter::EcbfFilter<Barriers, NU>;")
    w("")

    w(f"impl {rt}::dynamic::GeneratedSystem<NX, NU> for {sys_type} {{")
    w("    const DOC: &'static str = DOC;")
    w(f"    const FAMILIES: &'static [{rt}::system::FamilyInfo] = &FAMILIES;")
    w(f"    const KERNELS: &'static [{rt}::system::KernelEntry] = KERNELS;")
    w(f"    const INTERVAL_KERNELS: &'static [{rt}::filter::between_samples::IntervalKernel] = INTERVAL_KERNELS;")
    w("    type Capacity = Capacity;")
    w("    type Params = Params;")
    w("    type Barriers = Barriers;")
    w("")
    w(f"    fn params(capacity: Capacity) -> Result<Params, {rt}::error::CbfError> {{")
    w("        Params::new(capacity)")
    w("    }")
    w("")
    w(f"    fn barriers(capacity: Capacity) -> Result<Barriers, {rt}::error::CbfError> {{")
    w("        Barriers::new(capacity)")
    w("    }")
    w("")
    w("    fn capacity_of(params: &Params) -> Capacity {")
    w("        params.capacity()")
    w("    }")
    w("}")
    w("")
    w(f"/// This system behind [`{rt}::dynamic::DynSystem`]: sizes and names at run time, and")
    w("/// its parameters, rows and filter on slices (for bindings and tools).")
    w(f"pub const SYSTEM: &dyn {rt}::dynamic::DynSystem = &{rt}::dynamic::Erased::<{sys_type}, NX, NU>::NEW;")
    w("")


def emit_system(d: SystemDefinition, rt: str) -> str:
    """The module text (before rustfmt), ``rt`` being the path to the runtime crate: one
    emitter per item, in the module's order."""
    _reserve_names(d)
    out: list[str] = []
    ops: dict[str, list[int]] = {}
    _emit_description(out, d, rt)
    _emit_system_type(out, d, rt)
    _emit_kernels(out, d, rt, ops)
    for emit in (_emit_parameter_structs, _emit_family_table, _emit_capacity, _emit_params):
        emit(out, d, rt)
    _emit_barriers(out, d, rt, ops)
    _emit_filter_and_system(out, d, rt)
    assembled = {name: cost.const_rust(rt) for name, cost in _assembled_ops(d, ops).items()}
    out.append(emit_kernel_table(d.kernels(), rt, f"`{d.name}`", {**ops, **assembled}))
    _emit_interval_kernels(out, d, rt)
    return "\n".join(out) + "\n"
