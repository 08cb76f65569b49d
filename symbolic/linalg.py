"""3 x 3 rotations and products on SymEngine expressions, for specs and primitives."""

from __future__ import annotations

import symengine as se


def rot_z(a: se.Expr) -> list[list[se.Expr]]:
    c, s = se.cos(a), se.sin(a)
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def rot_y(a: se.Expr) -> list[list[se.Expr]]:
    c, s = se.cos(a), se.sin(a)
    return [[c, 0, s], [0, 1, 0], [-s, 0, c]]


def matmul(a, b):
    return [[se.Add(*[a[i][k] * b[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]


def matvec(a, v):
    return [se.Add(*[a[i][k] * v[k] for k in range(3)]) for i in range(3)]


def matvec_transposed(a, v):
    """``a^T v``: a rotation's inverse applied to ``v``."""
    return [se.Add(*[a[k][i] * v[k] for k in range(3)]) for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
