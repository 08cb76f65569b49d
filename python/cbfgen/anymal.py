"""ANYmal C and seed 004's whole-body controller, from Python.

The robot's two systems are generic (``System("anymal")``: the kinematic filter in
generalized accelerations; ``System("anymal_wbc")``: free-flyer coordinates, its dynamics
and contacts); this module adds the hierarchical whole-body controller that turns a trunk
motion, swing-foot motions and contact forces into torques, with the foothold CBF among
its highest-priority rows (docs/anymal.md), the standing state and the trot the Rust tests
use, and seed 004's stepping stones: :class:`SteppingStones` lays a field and
:class:`StoneWalk` walks it with both layers (the kino-dynamic MPC and the whole-body
controller) and Table II's measurements. A plant of your own (MuJoCo:
:mod:`cbfgen.physics.anymal`) calls them:

    import numpy as np
    from cbfgen import anymal

    x = anymal.standing()                      # the anymal_wbc state, (42,)
    wbc = anymal.WholeBodyController()
    out = wbc.update(x, [True] * 4, x[:3], np.eye(3), np.zeros(3), np.zeros(3),
                     np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 3)))
    out["torques"]                             # (12,), in JOINT_NAMES order
"""

from __future__ import annotations

from ._native import (
    ANYMAL_CONTROLLERS,
    ANYMAL_FOOT_RADIUS,
    ANYMAL_FOOTHOLD_BARRIERS,
    ANYMAL_JOINT_NAMES,
    ANYMAL_LEGS,
    ANYMAL_TOTAL_MASS,
    ANYMAL_WHOLE_BODY_BARRIERS,
    SteppingStones,
    StoneWalk,
    System,
    WholeBodyController,
    anymal_standing,
    anymal_trot,
)

SYSTEM = System("anymal_wbc")
"""The free-flyer system: state and input names, kernels (``dynamics``, ``contacts``)."""
NX: int = SYSTEM.nx
LEGS: list[str] = ANYMAL_LEGS
JOINT_NAMES: list[str] = ANYMAL_JOINT_NAMES
TOTAL_MASS: float = ANYMAL_TOTAL_MASS
FOOT_RADIUS: float = ANYMAL_FOOT_RADIUS
CONTROLLERS: list[str] = ANYMAL_CONTROLLERS
"""Seed 004's Table II controllers, by where the foothold constraints are."""
FOOTHOLD_BARRIERS: list[str] = ANYMAL_FOOTHOLD_BARRIERS
"""The sets eq. 25's CBF (the MPC's) can keep a swing foot in: ``StoneWalk(barrier=)``."""
WHOLE_BODY_BARRIERS: list[str] = ANYMAL_WHOLE_BODY_BARRIERS
"""The sets eq. 26's CBF (the whole-body QP's) can keep it in: ``StoneWalk(whole_body_barrier=)``."""
standing = anymal_standing
trot = anymal_trot

__all__ = [
    "CONTROLLERS",
    "FOOTHOLD_BARRIERS",
    "FOOT_RADIUS",
    "JOINT_NAMES",
    "LEGS",
    "NX",
    "SYSTEM",
    "SteppingStones",
    "StoneWalk",
    "TOTAL_MASS",
    "WHOLE_BODY_BARRIERS",
    "WholeBodyController",
    "standing",
    "trot",
]
