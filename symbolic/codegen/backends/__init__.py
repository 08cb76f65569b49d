"""One package per target language: the expression printer, the module templates and the
names the language reserves. What the spec checks identifiers against is the union of
every backend's reserved names (one backend today: ``rust``)."""

from .rust import reserved as _rust

# Identifiers a spec may not use for anything that becomes a local or a function.
RESERVED_WORDS = _rust.KEYWORDS
RESERVED_LOCALS = (_rust.LOCALS,)
# Identifiers a spec may not use for items of the generated module.
MODULE_ITEMS = _rust.MODULE_ITEMS
