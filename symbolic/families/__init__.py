"""Constraint families: each module builds the kernels of one kind of constraint."""
