"""Specs of the built-in systems (see :mod:`symbolic.spec`); ``python -m symbolic generate
symbolic/systems/<name>.py --out DIR`` writes each one's Rust module."""
