"""The Rust backend: :mod:`.emitter` prints kernels as straight-line functions,
:mod:`.system_module` wraps a system's kernels in the runtime's traits, and
:mod:`.kernel_table` lists every kernel of a module behind one uniform signature."""
