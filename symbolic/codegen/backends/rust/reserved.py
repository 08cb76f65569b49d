"""Names the Rust backend cannot give a spec's identifiers: the language's keywords and
reserved words, the locals its kernels define, and the items every generated module has."""

import re

# Rust keywords and reserved words (2021 edition, and `gen` reserved for 2024).
KEYWORDS = frozenset("""
    as async await break const continue crate dyn else enum extern false fn for gen if impl in let
    loop match mod move mut pub ref return self static struct super trait true type unsafe use
    where while abstract become box do final macro override priv try typeof unsized virtual yield
    union
""".split())
# Locals of the generated kernels: SymEngine's CSE temporaries x0.., the printer's t0.. and
# pw.., the time argument t and the state argument x.
LOCALS = re.compile(r"^(x\d+|t\d+|pw\d*|x|t|state_part)$")
# Items every generated module defines, and the crates it names.
MODULE_ITEMS = frozenset({"state", "input", "drift", "input_matrix", "default_settings", "core", "std",
                          "nalgebra", "alloc"})
