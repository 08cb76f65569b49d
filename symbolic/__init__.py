"""cbfgen's build-time symbolic stage.

Robot models and constraint families are written as SymEngine expressions here,
differentiated, reduced by common-subexpression elimination and emitted as
straight-line Rust into ``generated/`` (see ``python -m symbolic.generate --help``); a
user's own system is a spec file (:mod:`symbolic.spec`), generated with
``python -m symbolic generate SPEC --out DIR``.
Nothing in this package knows about the QP solver; nothing in ``src/`` re-derives
what is defined here.
"""
