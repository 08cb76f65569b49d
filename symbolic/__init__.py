"""cbfgen's build-time symbolic stage.

Robot models and constraint families are written as SymEngine expressions here,
differentiated, reduced by common-subexpression elimination and emitted as
straight-line Rust into ``generated/`` (see ``python -m symbolic.generate --help``).
Nothing in this package knows about the QP solver; nothing in ``src/`` re-derives
what is defined here.
"""
