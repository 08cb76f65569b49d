"""``KERNELS``: every kernel of a generated module behind one uniform signature.

Each entry is a ``KernelEntry`` (src/system.rs): the kernel's name, its inputs and
outputs as (name, number of scalars), and a wrapper that reads every input flattened in
argument order from one slice and writes every output flattened in return order
(matrices row by row, symmetric matrices by upper triangle: the order
:meth:`symbolic.kernel.Kernel.evaluate` returns). A tool can then iterate over a module's
kernels without knowing any signature: the SymEngine cross-check does.

The wrappers live in a private inner module ``kernel_table``, so the only names this
adds to a module are ``KERNELS`` and ``kernel_table``. They panic on wrong lengths: a
tool's bug, never a control-path one.
"""

from __future__ import annotations

from collections.abc import Sequence

from ....kernel import Kernel
from .emitter import nalgebra_type


def _flat_size(kind: str, dim: int, cols: int) -> int:
    return {"scalar": 1, "vector": dim, "matrix": dim * cols, "symmetric": dim * (dim + 1) // 2}[kind]


def _wrapper(k: Kernel, runtime_crate: str) -> str:
    n_in = sum(len(i.symbols) for i in k.inputs)
    n_out = sum(_flat_size(o.kind, o.dim, o.cols) for o in k.outputs)
    args, pos = [], 0
    for inp in k.inputs:
        n = len(inp.symbols)
        if not inp.is_array:
            args.append(f"input[{pos}]")
        elif inp.shape is None:
            args.append(f"input[{pos}..{pos + n}].try_into().unwrap()")
        else:
            # A parameter's vector or matrix, from its components row by row.
            args.append(f"&{runtime_crate}::nalgebra::{nalgebra_type(inp)}::from_row_slice(&input[{pos}..{pos + n}])")
        pos += n
    lines = [
        f"/// `super::{k.name}` on flat slices.",
        f"pub(super) fn {k.name}(input: &[f64], output: &mut [f64]) {{",
        f'    assert_eq!((input.len(), output.len()), ({n_in}, {n_out}), "{k.name}: flat lengths");',
        f"    let out = super::{k.name}({', '.join(args)});",
    ]
    pos = 0
    for i, o in enumerate(k.outputs):
        v = "out" if len(k.outputs) == 1 else f"out.{i}"
        n = _flat_size(o.kind, o.dim, o.cols)
        if o.kind == "scalar":
            lines.append(f"    output[{pos}] = {v};")
        elif o.kind == "vector":
            lines.append(f"    output[{pos}..{pos + n}].copy_from_slice(&{v});")
        elif o.kind == "matrix":
            lines.append(f"    output[{pos}..{pos + n}].copy_from_slice({v}.as_flattened());")
        else:
            k_ = pos
            for r in range(o.dim):
                for c in range(r, o.dim):
                    lines.append(f"    output[{k_}] = {v}[{r}][{c}];")
                    k_ += 1
        pos += n
    lines.append("}")
    return "\n".join(lines)


def emit_kernel_table(kernels: Sequence[Kernel], runtime_crate: str, what: str,
                      attributes: Sequence[str] = ()) -> str:
    """``KERNELS`` and its private wrappers for ``kernels``. ``what`` names the module in
    the doc; ``attributes`` go on the wrapper module (lint allows for an include!d file)."""
    names = [k.name for k in kernels]
    if len(set(names)) != len(names):
        raise ValueError(f"{what}: kernel names repeat: {names}")
    entry = f"{runtime_crate}::system::KernelEntry"
    entries = []
    for k in kernels:
        ins = ", ".join(f'("{i.name}", {len(i.symbols)})' for i in k.inputs)
        outs = ", ".join(f'("{o.name}", {_flat_size(o.kind, o.dim, o.cols)})' for o in k.outputs)
        entries.append(f'    {entry} {{ name: "{k.name}", inputs: &[{ins}], outputs: &[{outs}], '
                       f"call: kernel_table::{k.name} }},")
    return "\n".join([
        f"/// Every kernel of {what} behind one uniform signature, in module order: inputs and",
        "/// outputs flattened in declaration order (matrices row by row, symmetric ones by upper",
        "/// triangle). For tools that iterate over kernels, such as the SymEngine cross-check.",
        f"pub const KERNELS: &[{entry}] = &[",
        *entries,
        "];",
        "",
        "/// Flat wrappers of this module's kernels, for [`KERNELS`].",
        *attributes,
        "mod kernel_table {",
        "\n\n".join(_wrapper(k, runtime_crate) for k in kernels),
        "}",
    ]) + "\n"
