"""A composed member's row function (:mod:`symbolic.codegen.composition`): its pose
kernels, the family's chain kernel, and the chain's gradient contracted with the poses'
input columns by ``cbfgen::compose::accumulate_columns``. Same name, signature and
constants as the unrolled kernel it stands for (and, for a family with parameters, the
same ``_state`` / ``_instance`` split), so the module around it does not change."""

from __future__ import annotations

from collections.abc import Sequence

from ....kernel import Kernel
from ...composition import SLOTS, MemberPlan, Static
from .emitter import _doc_lines, float_literal, input_element, input_type, kernel_signature, rustdoc_text


def emit_composed_member(kernel: Kernel, plan: MemberPlan, degree: int, with_params: bool, runtime_crate: str,
                         attributes: Sequence[str] = ()) -> str:
    inputs = {inp.name: inp for inp in kernel.inputs}

    def value(v: Static) -> str:
        if isinstance(v, tuple):
            return input_element(inputs[v[0]], v[1])
        return float_literal(v)

    def array(values: Sequence[Static]) -> str:
        return "&[" + ", ".join(value(v) for v in values) + "]"

    moving = [(s, slot) for s, slot in zip(SLOTS, plan.slots, strict=True) if slot.moving]
    chain_args = []
    for s, slot in zip(SLOTS, plan.slots, strict=True):
        chain_args += [f"pose_{s}", f"rates_{s}"] if slot.moving else [array(slot.pose)]
    chain_args += [array(slot.half) for slot in plan.slots]
    grads = ", ".join(f"grad_{s}" for s, _ in moving)
    assemble = [
        f"    let (lie, {grads}) = {plan.chain}({', '.join(chain_args)});",
        f"    let mut lg_lf = [0.0; {len(plan.columns)}];",
        *(f"    {runtime_crate}::compose::accumulate_columns(&grad_{s}, lg_{s}, "
          f"&[{', '.join(map(str, slot.at))}], &mut lg_lf);" for s, slot in moving),
        "    ([lie], [lg_lf])",
    ]
    args, ret = kernel_signature(kernel, runtime_crate)
    consts: list[str] = []
    for c in kernel.constants:
        consts += [f"/// {rustdoc_text(c.doc)}", f"pub const {c.name}: {c.rust_type} = {c.value};"]
    head = [*_doc_lines(kernel), *attributes, "#[inline]"]
    if not with_params:
        body = [f"    let (pose_{s}, rates_{s}, lg_{s}) = &{slot.jet}(x);" for s, slot in moving]
        return "\n".join(consts + head + [f"pub fn {kernel.name}({args}) -> {ret} {{", *body, *assemble, "}"]) + "\n"
    # A family with parameters: the poses once per cycle (``_state``), the chain per instance.
    jet_types = [f"([f64; 12], [f64; {12 * degree}], [[f64; {len(slot.at)}]; 12])" for _, slot in moving]
    state_type = "(" + ", ".join(jet_types) + ",)"
    params = [inp for inp in kernel.inputs if inp.name != "x"]
    param_args = "".join(f", {p.name}: {input_type(p, runtime_crate)}" for p in params)
    state_fn = [f"/// The poses [`{kernel.name}`] reads: computed once per cycle for every instance, and handed to "
                f"[`{kernel.name}_instance`].", *attributes, "#[inline]",
                f"pub fn {kernel.name}_state(x: &[f64; {len(inputs['x'].symbols)}]) -> {state_type} {{",
                "    (" + "".join(f"{slot.jet}(x), " for _, slot in moving) + ")", "}"]
    instance_fn = [f"/// One instance of [`{kernel.name}`], from [`{kernel.name}_state`]'s poses.", *attributes,
                   "#[inline]", f"pub fn {kernel.name}_instance(state_part: &{state_type}{param_args}) -> {ret} {{",
                   *(f"    let (pose_{s}, rates_{s}, lg_{s}) = &state_part.{n};" for n, (s, _) in enumerate(moving)),
                   *assemble, "}"]
    wrapper = [*head, f"pub fn {kernel.name}({args}) -> {ret} {{",
               f"    {kernel.name}_instance(&{kernel.name}_state(x){''.join(f', {p.name}' for p in params)})", "}"]
    return "\n".join(consts + state_fn + instance_fn + wrapper) + "\n"
