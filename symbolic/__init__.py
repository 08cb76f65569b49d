"""cbfgen's build-time symbolic stage: the generator.

A system is a spec file (:mod:`symbolic.spec`): its model and constraint families as
SymEngine expressions. :mod:`symbolic.codegen` differentiates each family to its relative
degree and reduces the results by common-subexpression elimination
(:mod:`symbolic.codegen.straight_line`); a backend (``codegen/backends/rust``) prints
straight-line code. ``python -m symbolic generate SPEC --out DIR`` generates any spec (what
``cbfgen-build`` runs); ``python -m symbolic.generate`` regenerates everything in this
repository. Nothing in this package knows about the QP solver; nothing in the Rust crates
re-derives what is defined here.
"""
