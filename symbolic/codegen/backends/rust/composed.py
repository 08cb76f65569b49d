"""A composed member's row function (:mod:`symbolic.codegen.composition`): its pose
kernels, the family's chain kernel, and the chain's gradient contracted with the poses'
input columns by ``cbfgen::compose::accumulate_columns``. Same name, signature and
constants as the unrolled kernel it stands for (and, for a family with parameters, the
same ``_state`` / ``_instance`` split), so what calls it does not change; the filter calls
``<member>_from_poses`` with each pose kernel evaluated once per cycle."""

from __future__ import annotations

from collections.abc import Sequence

from ....kernel import Kernel
from ...composition import SLOTS, BoundPlan, FramePlan, MemberPlan, PosePlan, Static
from .emitter import (
    SCALAR,
    _doc_lines,
    constant,
    float_literal,
    generic,
    input_element,
    input_type,
    kernel_signature,
    rustdoc_text,
)

S = SCALAR


def _jet(degree: int, columns: int) -> str:
    """A pose's jet on the kernels' scalar: the pose, its drift derivatives, its input part."""
    return f"([{S}; 12], [{S}; {12 * degree}], [[{S}; {columns}]; 12])"


def _fixed_array(kernel: Kernel):
    """A fixed box's entries (numbers, or the kernel's parameter components) as a Rust array
    reference."""
    inputs = {inp.name: inp for inp in kernel.inputs}

    def array(values: Sequence[Static]) -> str:
        return "&[" + ", ".join(input_element(inputs[v[0]], v[1]) if isinstance(v, tuple) else constant(v)
                                for v in values) + "]"
    return array


def _chain_path(plan: MemberPlan | BoundPlan, runtime_crate: str) -> str:
    """The chain or bound kernel's path: the system's own, or the core's (``plan.library``)."""
    return f"{runtime_crate}::generated::{plan.library}::{plan.chain}" if plan.library else plan.chain


def emit_composed_member(kernel: Kernel, plan: MemberPlan, degree: int, with_params: bool, runtime_crate: str,
                         attributes: Sequence[str] = ()) -> str:
    array = _fixed_array(kernel)
    moving = [(s, slot) for s, slot in zip(SLOTS, plan.slots, strict=True) if slot.moving]
    chain_args = []
    for s, slot in zip(SLOTS, plan.slots, strict=True):
        chain_args += [f"&pose_{s}.0", f"&pose_{s}.1"] if slot.moving else [array(slot.pose)]
    chain_args += [array(slot.half) for slot in plan.slots]
    chain_args += [constant(v) for v in plan.options]
    grads = ", ".join(f"grad_{s}" for s, _ in moving)
    args, ret = kernel_signature(kernel, runtime_crate, S)
    params = [inp for inp in kernel.inputs if inp.name != "x"]
    param_args = "".join(f", {p.name}: {input_type(p, runtime_crate, S)}" for p in params)
    jet_types = {s: _jet(degree, len(slot.at)) for s, slot in moving}
    poses = ", ".join(f"pose_{s}: &{jet_types[s]}" for s, _ in moving)
    from_poses = [
        f"/// [`{kernel.name}`] from its boxes' pose kernels ({', '.join(f'[`{slot.jet}`]' for _, slot in moving)}) "
        "at the state: what the filter calls, each pose computed once per cycle for every row that reads it.",
        *attributes, "#[inline]",
        f"pub fn {kernel.name}_from_poses{generic(runtime_crate)}({poses}{param_args}) -> {ret} {{",
        f"    let (lie, {grads}) = {_chain_path(plan, runtime_crate)}({', '.join(chain_args)});",
        f"    let mut lg_lf = [{constant(0.0)}; {len(plan.columns)}];",
        *(f"    {runtime_crate}::compose::accumulate_columns(&grad_{s}, &pose_{s}.2, "
          f"&[{', '.join(map(str, slot.at))}], &mut lg_lf);" for s, slot in moving),
        "    ([lie], [lg_lf])", "}"]
    consts: list[str] = []
    for c in kernel.constants:
        consts += [f"/// {rustdoc_text(c.doc)}", f"pub const {c.name}: {c.rust_type} = {c.value};"]
    jets = [(slot.jet, jet_types[s]) for s, slot in moving]
    return "\n".join(consts + from_poses + _entry_points(kernel, jets, ret, with_params, runtime_crate,
                                                          attributes)) + "\n"


def _entry_points(kernel: Kernel, jets: Sequence[tuple[str, str]], ret: str, with_params: bool,
                  runtime_crate: str, attributes: Sequence[str], assembled: str = "_from_poses") -> list[str]:
    """``<kernel>(x, params...)`` over ``<kernel>_from_poses`` with the poses ``jets`` (name,
    Rust type) evaluated afresh; with parameters also the ``_state`` / ``_instance`` split
    every family with parameters has (the poses once per cycle, the rest per instance)."""
    args, _ = kernel_signature(kernel, runtime_crate, S)
    params = [inp for inp in kernel.inputs if inp.name != "x"]
    param_args = "".join(f", {p.name}: {input_type(p, runtime_crate, S)}" for p in params)
    param_names = "".join(f", {p.name}" for p in params)
    head = [*_doc_lines(kernel), *attributes, "#[inline]"]
    g = generic(runtime_crate)
    if not with_params:
        return [*head, f"pub fn {kernel.name}{g}({args}) -> {ret} {{",
                f"    {kernel.name}{assembled}({', '.join(f'&{jet}(x)' for jet, _ in jets)}{param_names})", "}"]
    state_type = "(" + ", ".join(t for _, t in jets) + ",)"
    n_x = len(next(inp for inp in kernel.inputs if inp.name == "x").symbols)
    return [f"/// The poses [`{kernel.name}`] reads: computed once per cycle for every instance, and handed to "
            f"[`{kernel.name}_instance`].", *attributes, "#[inline]",
            f"pub fn {kernel.name}_state{g}(x: &[{S}; {n_x}]) -> {state_type} {{",
            "    (" + "".join(f"{jet}(x), " for jet, _ in jets) + ")", "}",
            f"/// One instance of [`{kernel.name}`], from [`{kernel.name}_state`]'s poses.", *attributes,
            "#[inline]", f"pub fn {kernel.name}_instance{g}(state_part: &{state_type}{param_args}) -> {ret} {{",
            f"    {kernel.name}{assembled}(" + ", ".join(f"&state_part.{n}" for n in range(len(jets)))
            + f"{param_names})", "}",
            *head, f"pub fn {kernel.name}{g}({args}) -> {ret} {{",
            f"    {kernel.name}_instance(&{kernel.name}_state(x){param_names})", "}"]


def emit_composed_bound(kernel: Kernel, plan: BoundPlan, with_params: bool, runtime_crate: str,
                        attributes: Sequence[str] = ()) -> str:
    """A composed member's lower bound: its boxes' value kernels and the family's bound
    kernel, with the unrolled bound's name and signature (and split, with parameters)."""
    array = _fixed_array(kernel)
    moving = [(s, slot) for s, slot in zip(SLOTS, plan.slots, strict=True) if slot.moving]
    params = [inp for inp in kernel.inputs if inp.name != "x"]
    param_args = "".join(f", {p.name}: {input_type(p, runtime_crate, S)}" for p in params)
    chain_args = [f"pose_{s}" if slot.moving else array(slot.pose) for s, slot in zip(SLOTS, plan.slots, strict=True)]
    chain_args += [array(slot.half) for slot in plan.slots]
    chain_args += [constant(v) for v in plan.options]
    poses = ", ".join(f"pose_{s}: &[{S}; 12]" for s, _ in moving)
    from_poses = [f"/// [`{kernel.name}`] from its boxes' poses "
                  f"({', '.join(f'[`{slot.jet}`]' for _, slot in moving)}) at the state.", *attributes, "#[inline]",
                  f"pub fn {kernel.name}_from_poses{generic(runtime_crate)}({poses}{param_args}) -> {S} {{",
                  f"    {_chain_path(plan, runtime_crate)}({', '.join(chain_args)})", "}"]
    jets = [(slot.jet, f"[{S}; 12]") for _, slot in moving]
    return "\n".join(from_poses + _entry_points(kernel, jets, S, with_params, runtime_crate, attributes)) + "\n"


def emit_framed_member(kernel: Kernel, plan: FramePlan, runtime_crate: str, attributes: Sequence[str] = ()) -> str:
    """A member whose rows read one frame: ``<member>_from_frame`` (its kernel on the frame's
    jet, what the filter calls with the jet computed once per cycle for every row on that
    frame) and the entry points every family with parameters has."""
    args, ret = kernel_signature(kernel, runtime_crate, S)
    params = [inp for inp in kernel.inputs if inp.name != "x"]
    param_args = "".join(f", {p.name}: {input_type(p, runtime_crate, S)}" for p in params)
    param_names = "".join(f", {p.name}" for p in params)
    if plan.degree:
        jet_type = _jet(plan.degree, plan.columns)
        call = (f"{plan.on_frame}(&frame.0, &frame.1, &{runtime_crate}::compose::flatten(&frame.2)"
                f"{param_names})")
        what = "its frame's jet"
    else:
        jet_type = f"[{S}; 12]"
        call = f"{plan.on_frame}(frame{param_names})"
        what = "its frame's pose"
    consts: list[str] = []
    for c in kernel.constants:
        consts += [f"/// {rustdoc_text(c.doc)}", f"pub const {c.name}: {c.rust_type} = {c.value};"]
    from_frame = [f"/// [`{kernel.name}`] from {what} ([`{plan.frame}`]): what the filter calls, the frame computed "
                  "once per cycle for every row on it.", *attributes, "#[inline]",
                  f"pub fn {kernel.name}_from_frame{generic(runtime_crate)}"
                  f"(frame: &{jet_type}{param_args}) -> {ret} {{",
                  f"    {call}", "}"]
    return "\n".join(consts + from_frame + _entry_points(kernel, [(plan.frame, jet_type)], ret, True, runtime_crate,
                                                           attributes, assembled="_from_frame")) + "\n"


def placement_name(plan: PosePlan) -> str:
    """The constant holding where a pose plan's box sits in its frame: one per box, shared
    by its jet's and its value's pose functions."""
    return plan.name.removeprefix("pose_").removesuffix("_value").upper() + "_PLACEMENT"


def emit_placements(plans: Sequence[PosePlan], runtime_crate: str, attributes: Sequence[str] = ()) -> str:
    """One ``Placement`` constant per box fixed in a link frame (``placement_name``)."""
    seen: dict[str, tuple[float, ...]] = {}
    out: list[str] = []
    for plan in plans:
        if plan.placement is None:
            continue
        name = placement_name(plan)
        if name in seen:
            if seen[name] != plan.placement:
                raise ValueError(f"pose plans {plan.name} and another place one box differently")
            continue
        seen[name] = plan.placement
        offset = ", ".join(float_literal(v) for v in plan.placement[:3])
        axes = ", ".join(float_literal(v) for v in plan.placement[3:])
        out += [f"/// Where the box of [`{plan.name}`] sits in its frame ([`{plan.steps[-1]}`]).", *attributes,
                f"pub const {name}: {runtime_crate}::compose::Placement = {runtime_crate}::compose::Placement {{ "
                f"offset: [{offset}], axes: [{axes}] }};"]
    return "\n".join(out) + "\n" if out else ""


def emit_pose_function(plan: PosePlan, n_x: int, runtime_crate: str, attributes: Sequence[str] = ()) -> str:
    """A pose function assembled along the kinematic tree: the root frame's kernel, then
    each node's kernel on its parent's jet (or pose), down to the box's frame, and the box
    placed in it (``cbfgen::compose::place_jet``)."""
    steps = ", ".join(f"[`{step}`]" for step in plan.steps)
    placed = f"&{placement_name(plan)}" if plan.placement is not None else ""
    if plan.value:
        ret = f"[{S}; 12]"
        calls = [f"    let pose = {plan.steps[0]}(x);",
                 *(f"    let pose = {step}(x, &pose);" for step in plan.steps[1:]),
                 f"    {runtime_crate}::compose::place_pose(&pose, {placed})" if placed else "    pose"]
        what = "The pose of a box, value only (what lower bounds read): centre, then rotation row by row"
    else:
        ret = _jet(plan.degree, plan.columns)
        calls = [f"    let jet = {plan.steps[0]}(x);",
                 *(f"    let jet = {step}(x, &jet.0, &jet.1, &{runtime_crate}::compose::flatten(&jet.2));"
                   for step in plan.steps[1:]),
                 f"    {runtime_crate}::compose::place_jet(&jet, {placed})" if placed else "    jet"]
        what = ("The pose of a box the composed rows read: centre and rotation (row by row), their drift "
                "derivatives L_f y ... L_f^r y and the input part L_g L_f^(r-1) y (one row per pose entry)")
    how = f"along the kinematic tree: {steps}" + (", then the box placed in the last frame" if placed else "")
    return "\n".join([f"/// {what}; {how}.", *attributes, "#[inline]",
                      f"pub fn {plan.name}{generic(runtime_crate)}(x: &[{S}; {n_x}]) -> {ret} {{", *calls, "}"]) + "\n"


def emit_pose_cache(nodes: Sequence[tuple[Kernel, str | None]], plans: Sequence[PosePlan], n_x: int,
                    runtime_crate: str, attributes: Sequence[str] = ()) -> str:
    """``PoseCache``: every node's jet and every pose function's result, each computed at
    most once per cycle, when a row first asks (a node after the node it reads). What the
    filter's ``evaluate`` reads poses through: a link shared by ten rows costs one
    evaluation of each joint above it."""
    types = {k.name: kernel_signature(k, runtime_crate)[1] for k, _ in nodes}
    for plan in plans:
        types[plan.name] = ("[f64; 12]" if plan.value else
                            f"([f64; 12], [f64; {12 * plan.degree}], [[f64; {plan.columns}]; 12])")
    x = f"x: &[f64; {n_x}]"
    out = ["/// Every pose a cycle's rows read, each computed at most once per cycle: the node kernels' jets "
           "along the kinematic tree, and the boxes placed in them.", "#[derive(Default)]", *attributes,
           "struct PoseCache {"]
    out += [f"    {name}: Option<{t}>," for name, t in types.items()]
    out += ["}", "", *attributes, "impl PoseCache {"]
    for k, parent in nodes:
        if parent is None:
            call = f"self::{k.name}(x)"
        elif types[parent] == "[f64; 12]":
            call = f"self::{k.name}(x, &self.{parent}(x))"
        else:
            call = (f"{{ let parent = self.{parent}(x); "
                    f"self::{k.name}(x, &parent.0, &parent.1, &{runtime_crate}::compose::flatten(&parent.2)) }}")
        out += _cached_method(k.name, types[k.name], x, call)
    for plan in plans:
        frame = f"self.{plan.steps[-1]}(x)"
        if plan.placement is None:
            call = frame
        else:
            place = "place_pose" if plan.value else "place_jet"
            call = f"{runtime_crate}::compose::{place}(&{frame}, &{placement_name(plan)})"
        out += _cached_method(plan.name, types[plan.name], x, call)
    return "\n".join([*out, "}"]) + "\n"


def _cached_method(name: str, rust_type: str, x: str, call: str) -> list[str]:
    return ["    #[inline]", f"    fn {name}(&mut self, {x}) -> {rust_type} {{",
            f"        if let Some(value) = self.{name} {{", "            return value;", "        }",
            f"        let value = {call};", f"        self.{name} = Some(value);", "        value", "    }"]
