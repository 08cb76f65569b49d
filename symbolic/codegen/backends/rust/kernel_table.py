"""``KERNELS``: every kernel of a generated module behind one uniform signature.

Each entry is a ``KernelEntry`` (src/system.rs): the kernel's name, its inputs and
outputs as (name, number of scalars), and a wrapper that reads every input flattened in
argument order from one slice and writes every output flattened in return order
(matrices row by row, symmetric matrices by upper triangle: the order
:meth:`symbolic.kernel.Kernel.evaluate` returns). A tool can then iterate over a module's
kernels without knowing any signature: the SymEngine cross-check does.

The module states each kernel's signature in one line of the core's ``kernel_table!``
macro (src/kernel_table.rs), which writes the entry and its wrapper: the flattening code
is the core's, once. The only name this adds to a module is ``KERNELS``.
"""

from __future__ import annotations

from collections.abc import Sequence

from ....kernel import Kernel


def kernel_argument(inp) -> str:
    """An argument as ``kernel_table!`` reads it: ``name: kind[dims]``."""
    if not inp.is_array:
        return f"{inp.name}: scalar[]"
    if inp.shape is None:
        return f"{inp.name}: array[{len(inp.symbols)}]"
    return f"{inp.name}: {'vector' if len(inp.shape) == 1 else 'matrix'}[{', '.join(map(str, inp.shape))}]"


def kernel_result(out) -> str:
    """A result as ``kernel_table!`` writes it: ``name: kind[dims]``."""
    dims = {"scalar": "", "vector": f"{out.dim}", "symmetric": f"{out.dim}", "matrix": f"{out.dim}, {out.cols}"}
    kind = "array" if out.kind == "vector" else out.kind
    return f"{out.name}: {kind}[{dims[out.kind]}]"


def emit_kernel_table(kernels: Sequence[Kernel], runtime_crate: str, what: str,
                      ops: dict[str, list[int] | str] | None = None) -> str:
    """``KERNELS`` for ``kernels``: one line per kernel in ``kernel_table!`` (src/kernel_table.rs),
    which writes the entries and their flat wrappers. ``what`` names the module in the doc;
    ``ops`` holds the operation counts their lines state: of a kernel printed as one
    straight line, its counts (``ops [add, neg, mul, div, sqrt, elementary, lanes,
    compare]``); of one assembled from others, a constant Rust expression of its count
    (``ops { .. }``)."""
    names = [k.name for k in kernels]
    if len(set(names)) != len(names):
        raise ValueError(f"{what}: kernel names repeat: {names}")
    ops = ops or {}

    def stated(k: Kernel) -> str:
        if k.name not in ops:
            return ""
        count = ops[k.name]
        return f" ops {{{count}}}" if isinstance(count, str) else f" ops [{', '.join(map(str, count))}]"

    lines = [f"    {k.name}({', '.join(map(kernel_argument, k.inputs))}) -> "
             f"({', '.join(map(kernel_result, k.outputs))}){stated(k)};" for k in kernels]
    return "\n".join([
        f"{runtime_crate}::kernel_table! {{",
        f"    /// Every kernel of {what} behind one uniform signature, in module order: inputs and",
        "    /// outputs flattened in declaration order (matrices row by row, symmetric ones by upper",
        "    /// triangle). For tools that iterate over kernels, such as the SymEngine cross-check.",
        *lines,
        "}",
    ]) + "\n"
