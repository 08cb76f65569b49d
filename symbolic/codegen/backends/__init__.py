"""One package per target language: the expression printer and the module templates."""
