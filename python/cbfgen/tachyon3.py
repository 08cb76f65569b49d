"""Tachyon 3, the paper's hexapod on wheels, from Python.

The robot is the generic ``System("tachyon3")``; this module adds what is its own: its
constants, :func:`world_kinematics` and :func:`standard_posture`, :class:`Environment`
(its :class:`~cbfgen.Params` with helpers for edge cuboids, floors, footholds, swing legs
and stability bounds), :func:`ecbf_filter` (the generic filter sized by edge and foothold
counts) and the scenarios, :class:`Course` for a loop of your own and :func:`simulate`
for the Rust one.

    from cbfgen import tachyon3 as t3

    course = t3.Course("step")
    safety = t3.ecbf_filter()
    x = course.initial_state()
    for k in range(2000):
        x, _jump = course.exchange_origin(k * t3.DT, x)  # needed on a course that turns
        u_ref = course.plan(k * t3.DT, x)
        out = safety.update(x, u_ref, course.environment)
        x = x + t3.DT * t3.SYSTEM.xdot(x, out.u)
"""

from __future__ import annotations

from collections.abc import Sequence

from ._native import (
    BODY_HALF_EXTENTS,
    CAMPAIGN_TIMING_COLUMNS,
    COURSE_RANGES,
    DT,
    HIP_OUTWARD,
    HIP_POSITIONS,
    HIP_RANGES,
    KNEE_RANGE,
    LEG_NAMES,
    MAX_EDGES,
    MAX_FOOTHOLD_EDGES,
    MAX_SIM_TIME,
    NOMINAL_CLEARANCE,
    SCENARIOS,
    STANCE_AXLE,
    TOE_RADIUS,
    TRIPODS,
    Course,
    EcbfFilter,
    Environment,
    System,
    campaign,
    leg_joints,
    merge_campaign,
    roll_clearance,
    simulate,
    standard_posture,
    world_kinematics,
)

SYSTEM = System("tachyon3")
"""The generic system: sizes, names, dynamics, families."""
NX: int = SYSTEM.nx
NU: int = SYSTEM.nu
STATE_NAMES: list[str] = SYSTEM.state_names
INPUT_NAMES: list[str] = SYSTEM.input_names
FAMILIES: list[str] = [f["name"] for f in SYSTEM.families]
JOINT_LIMIT_ROWS: list[str] = SYSTEM.families[FAMILIES.index("joint_limits")]["row_names"]
PAPER_FOOTHOLD_EDGES: tuple[int, ...] = (15, 15, 15, 14, 14, 14)
"""Foothold half-planes per leg in the paper's worst case (269 rows with 20 edges)."""
DRIVE_LEGS: tuple[int, ...] = tuple(sorted({leg for axle in STANCE_AXLE for leg in axle}))
"""The legs with driven wheels (LF, RF, LR, RR): the two axles. The middle legs' wheels
are passive and omnidirectional (the paper's Fig. 2)."""


def capacity(edges: int = 20, foothold_edges: Sequence[int] | None = None) -> dict[str, int | list[int]]:
    """The generic capacity of ``edges`` edge cuboids (a body and a toe instance each) and
    ``foothold_edges`` half-planes per leg (the paper's worst case when None)."""
    feet = list(PAPER_FOOTHOLD_EDGES if foothold_edges is None else foothold_edges)
    return {"body_edge": edges, "toe_edge": edges, "foothold": feet}


def ecbf_filter(edges: int = 20, foothold_edges: Sequence[int] | None = None, **settings: object) -> EcbfFilter:
    """The generic :class:`~cbfgen.EcbfFilter` of Tachyon 3 with room for ``edges`` edge
    cuboids and ``foothold_edges`` half-planes per leg: it accepts an
    :class:`Environment` of the same sizes. Keyword settings as for ``EcbfFilter``."""
    return EcbfFilter(SYSTEM, capacity(edges, foothold_edges), **settings)


__all__ = [
    "BODY_HALF_EXTENTS",
    "CAMPAIGN_TIMING_COLUMNS",
    "COURSE_RANGES",
    "DRIVE_LEGS",
    "DT",
    "FAMILIES",
    "HIP_OUTWARD",
    "HIP_POSITIONS",
    "HIP_RANGES",
    "INPUT_NAMES",
    "JOINT_LIMIT_ROWS",
    "KNEE_RANGE",
    "LEG_NAMES",
    "MAX_EDGES",
    "MAX_FOOTHOLD_EDGES",
    "MAX_SIM_TIME",
    "NOMINAL_CLEARANCE",
    "NU",
    "NX",
    "PAPER_FOOTHOLD_EDGES",
    "SCENARIOS",
    "STANCE_AXLE",
    "STATE_NAMES",
    "SYSTEM",
    "TOE_RADIUS",
    "TRIPODS",
    "Course",
    "Environment",
    "campaign",
    "capacity",
    "ecbf_filter",
    "leg_joints",
    "merge_campaign",
    "roll_clearance",
    "simulate",
    "standard_posture",
    "world_kinematics",
]
