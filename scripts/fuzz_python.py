#!/usr/bin/env python3
"""Fuzz cbfgen's Python API with seeded random cases (issue 12).

Each case is one short, independent scenario drawn from its own seed
(``numpy.random.default_rng([seed, case])``), in one of five categories:

  filter_new   EcbfFilter construction with random settings and capacities (valid,
               boundary and absurd: 1e300, f64 max, 5e-324, negative, huge ints), then a
               few updates when it builds;
  environment  Environment building: capacities, edge cuboids, foothold polygons,
               floors, swing legs, stability bounds; then one filter update with it;
  update       EcbfFilter.update sequences at states near the standard posture and at
               extremes, nominal inputs from the course's gait or random (extremes
               too), each followed by ordinary cycles that must stay finite;
  kernels      the SSAT functions, every family's rows, the dynamics, the kinematics,
               the double integrator's sine barrier;
  course       Course (plan, clearance, finished, floor height) and short simulate runs.

Every call's result is checked: an outcome is ``ok``, ``typed_error`` (CbfError,
ValueError, TypeError, OverflowError), ``panic`` (pyo3's PanicException),
``other_exception``, ``nonfinite`` (a NaN or infinity in a returned value that came
without an exception: a filter output's ``u``, any kernel or course output, every
simulate series except ``min_h``, whose ``inf`` means "no row applied"), ``abort`` (the
process died) or ``hang`` (no result within ``--case-timeout``). Cases run in chunks in
a child process, so an abort or a hang is attributed to the case that was running,
and the campaign continues with the next case in a new child.

The exit status is 1 if any case panicked, aborted, hung, returned a non-finite value
or raised an exception outside the typed ones (an untyped error is a finding too, or
this harness has rotted), else 0. Replay one case, printing each call before it runs:

    .venv/bin/python scripts/fuzz_python.py --seed 0 --replay 1234
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections import Counter

import numpy as np

CATEGORIES = ("filter_new", "environment", "update", "kernels", "course")
# How often each category is drawn: the filter update is the real-time path.
CATEGORY_WEIGHTS = (0.2, 0.15, 0.3, 0.25, 0.1)
OUTCOMES = ("ok", "typed_error", "panic", "other_exception", "nonfinite", "abort", "hang")
FINDINGS = ("panic", "other_exception", "nonfinite", "abort", "hang")
TYPED_ERRORS = (ValueError, TypeError, OverflowError)  # cbfgen.CbfError is a ValueError

F64_MAX = float(np.finfo(np.float64).max)
# Finite extremes: of the float format, and at or just past the documented domains'
# edges (STATE_LIMIT 1e5, MAX_INPUT and MAX_COORDINATE 1e6, tolerances 1e-12 and 1e3,
# MAX_SIM_TIME 600, SSAT alpha 1e-6 and 1e9, half extents 1e-6 and 1e4).
FINITE_EXTREMES = (0.0, -0.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 1e-12, 1e-12 * (1 - 1e-15),
                   1e-6, 1e-6 * (1 - 1e-15), 1e3, 600.0, 600.0000000000001, 1e4, 1e6, -1e6, 1000000.0000000001,
                   1e9, 1e12, 1e26, 1e300, -1e300, F64_MAX, -F64_MAX)
NON_FINITE = (math.nan, math.inf, -math.inf)
INT_EXTREMES = (-1, 0, 1, 2**31, 2**32 - 1, 2**32, 2**62, 2**63 - 1, 2**64 // 7 + 1, 2**64 - 1, 2**64,
                10**6, 10**9, -(2**63))
# Hip mount height in the body frame (generated/tachyon3.rs HIP_POSITIONS[..][2]); the
# hips' x equal the toes' x in the standard posture.
HIP_Z = 0.12


class Finding(Exception):
    """A call returned a non-finite value."""


class Case:
    """One case's calls: each is recorded (for the report and replays), run, and its
    result checked. A typed error is expected of bad input and ends only that call;
    anything else ends the case."""

    FAILED = object()

    def __init__(self, rng: np.random.Generator, verbose: bool = False):
        self.rng = rng
        self.verbose = verbose
        # How hostile this case's draws are: a factor on every probability of an
        # extreme, absurd or mangled value. Clean cases reach deep paths (solves,
        # fallbacks) that a single bad argument would stop at the argument check.
        self.hostility = float(rng.choice([0.0, 0.3, 1.0], p=[0.35, 0.4, 0.25]))
        self.calls: list[tuple[str, tuple, dict]] = []
        self.typed_errors: Counter[str] = Counter()

    # ------------------------------------------------------------ calls
    def call(self, name: str, fn, *args, **kwargs):
        self.calls.append((name, args, kwargs))
        if self.verbose:
            print(">>", describe_call(name, args, kwargs), flush=True)
        try:
            result = fn(*args, **kwargs)
        except TYPED_ERRORS as e:
            self.typed_errors[type(e).__name__] += 1
            if self.verbose:
                print(f"   {type(e).__name__}: {e}", flush=True)
            return self.FAILED
        where = first_non_finite(result)
        if where is not None:
            raise Finding(f"{name} returned a non-finite value at {where}")
        return result

    # ------------------------------------------------------------ draws
    def chance(self, p: float) -> bool:
        return bool(self.rng.random() < p)

    def badness(self) -> float:
        """A uniform draw divided by the hostility: a bad value is drawn where this falls
        below the value's probability (never in a clean case)."""
        u = self.rng.random()
        return u / self.hostility if self.hostility > 0 else math.inf

    def hostile(self, p: float) -> bool:
        """A bad draw: probability ``p`` in the most hostile cases, none in clean ones."""
        return self.chance(p * self.hostility)

    def pick(self, options):
        return options[int(self.rng.integers(len(options)))]

    def scalar(self, lo: float, hi: float, p_extreme: float = 0.1, p_non_finite: float = 0.01) -> float:
        """Uniform in [lo, hi], or sometimes a finite extreme or (rarely) NaN / inf."""
        u = self.badness()
        if u < p_non_finite:
            return self.pick(NON_FINITE)
        if u < p_non_finite + p_extreme:
            return self.pick(FINITE_EXTREMES)
        return float(self.rng.uniform(lo, hi))

    def count(self, typical: int, maximum: int, p_boundary: float = 0.05, p_absurd: float = 0.05) -> int:
        """0..typical mostly; sometimes the documented maximum or one above; sometimes an
        absurd integer (negative, > 2^64, the wrap-around of the row count)."""
        u = self.badness()
        if u < p_absurd:
            return self.pick(INT_EXTREMES)
        if u < p_absurd + p_boundary:
            return self.pick((maximum, maximum + 1))
        return int(self.rng.integers(0, typical + 1))

    def perturbed(self, values: np.ndarray, p_extreme: float, p_non_finite: float = 0.01) -> np.ndarray:
        """A copy with a few entries replaced by extremes."""
        out = np.array(values, dtype=float)
        for i in range(out.size):
            u = self.badness()
            if u < p_non_finite:
                out.flat[i] = self.pick(NON_FINITE)
            elif u < p_non_finite + p_extreme:
                out.flat[i] = self.pick(FINITE_EXTREMES)
        return out

    def array_like(self, values: np.ndarray, p_mangle: float = 0.03):
        """``values`` as a float64 array, or sometimes as another array-like: a list, an
        int or float32 array, or a refused form (complex, strings, a wrong shape)."""
        if not self.chance(p_mangle * self.hostility):
            return values
        form = self.pick(("list", "float32", "int", "complex", "strings", "reshaped", "extra", "fortran"))
        if form == "list":
            return values.tolist()
        if form == "float32":
            return values.astype(np.float32)
        if form == "int":
            return np.nan_to_num(values, posinf=0, neginf=0).clip(-1e9, 1e9).astype(np.int64)
        if form == "complex":
            return values + 1j * self.rng.random()
        if form == "strings":
            return [str(v) for v in values.ravel()]
        if form == "reshaped":
            return values.reshape(-1, 1) if values.size != 9 else values.reshape(1, 9)
        if form == "extra":
            return np.append(values.ravel(), 0.0)
        return np.asfortranarray(values)


def first_non_finite(value, path: str = "result"):
    """Where ``value`` holds a NaN or an infinity (None if nowhere). Simulation ``min_h``
    entries are exempt: their ``inf`` is documented as "no row of this family applied"."""
    if isinstance(value, (bool, int, str, type(None))):
        return None
    if isinstance(value, float):
        return None if math.isfinite(value) else path
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc" and not np.all(np.isfinite(value)):
            return f"{path}[{np.argwhere(~np.isfinite(value))[0].tolist()}]"
        return None
    if type(value).__name__ == "FilterOutput":
        return first_non_finite(value.u, f"{path}.u")
    if isinstance(value, dict):
        for key, item in value.items():
            if key == "min_h":
                continue
            where = first_non_finite(item, f"{path}[{key!r}]")
            if where:
                return where
        return None
    if isinstance(value, (tuple, list)):
        for i, item in enumerate(value):
            where = first_non_finite(item, f"{path}[{i}]")
            if where:
                return where
        return None
    return None  # Environment, EcbfFilter, Course: objects, not values


def describe_call(name: str, args: tuple, kwargs: dict) -> str:
    with np.printoptions(precision=17, threshold=40, linewidth=10**6):
        parts = [repr(a) for a in args] + [f"{k}={v!r}" for k, v in kwargs.items()]
    text = f"{name}({', '.join(parts)})"
    return text if len(text) < 2000 else text[:2000] + "..."


# ====================================================================== draws
def rotation(case: Case):
    """Mostly a proper rotation (yaw-only like stair edges, or any); sometimes a
    reflection, a scaled or sheared matrix, or entries replaced by extremes."""
    if case.chance(0.4):
        a = case.rng.uniform(-np.pi, np.pi)
        r = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    else:
        q, rr = np.linalg.qr(case.rng.normal(size=(3, 3)))
        q = q @ np.diag(np.sign(np.diag(rr)))
        r = q if np.linalg.det(q) > 0 else -q
    u = case.badness()
    if u < 0.03:
        r = r @ np.diag([1.0, 1.0, -1.0])
    elif u < 0.06:
        r = r * case.pick((1.0 + 1e-6, 2.0, 1e300, 5e-324))
    elif u < 0.09:
        r = case.perturbed(r, p_extreme=0.2)
    r = r.ravel() if case.chance(0.5) else r
    return case.array_like(r)


def box(case: Case, center, spread: float):
    centre = case.perturbed(np.asarray(center) + case.rng.uniform(-spread, spread, 3), p_extreme=0.03)
    half = case.perturbed(case.rng.uniform(0.02, 0.6, 3), p_extreme=0.05)
    if case.hostile(0.03):
        half[int(case.rng.integers(3))] = case.pick((0.0, -0.1, 1e-300))
    return case.array_like(centre), rotation(case), case.array_like(half)


def state(case: Case, cbfgen) -> np.ndarray:
    """Near the standard posture (at some origin pose), sometimes far from it, with a toe
    exactly at its hip, or with entries replaced by extremes."""
    x = np.array(cbfgen.standard_posture())
    x[0:2] = case.rng.uniform(-2.0, 2.0, 2)
    x[3] = case.rng.uniform(-3.0, 3.0)
    mode = case.pick(("near", "near", "near", "wide", "toe_at_hip", "extreme", "domain_edge"))
    scale = 1.0 if mode == "wide" else 0.02
    x = x + case.rng.normal(0.0, scale, x.size)
    if mode == "toe_at_hip":
        leg = int(case.rng.integers(6))
        x[cbfgen.STATE_NAMES.index("pitch")] = 0.0
        x[12 + 4 * leg] = x[cbfgen.STATE_NAMES.index("bx")] + cbfgen.standard_posture()[12 + 4 * leg]
        x[12 + 4 * leg + 1] = x[cbfgen.STATE_NAMES.index("bz")] + HIP_Z
    if mode == "extreme":
        x = case.perturbed(x, p_extreme=0.1)
    if mode == "domain_edge":  # some entries at ±STATE_LIMIT: inside the domain, so finite results
        edge = case.rng.random(x.size) < case.rng.uniform(0.05, 1.0)
        x[edge] = case.rng.choice([-1.0, 1.0], edge.sum()) * cbfgen.STATE_LIMIT
    return x


def nominal_input(case: Case, cbfgen) -> np.ndarray:
    limits = np.array(cbfgen.INPUT_LIMITS)
    u = case.rng.uniform(-1.5, 1.5, cbfgen.NU) * limits
    if case.chance(0.3):
        u = case.perturbed(u, p_extreme=0.1)
    return u


def environment(case: Case, cbfgen, edges: int, foothold_edges, x=None):
    """An environment of this capacity with edge cuboids near the robot, floors, foothold
    polygons and stability bounds, mostly valid. ``FAILED`` if it could not be built."""
    env = case.call("Environment", cbfgen.Environment, edges, foothold_edges)
    if env is Case.FAILED:
        return env
    if x is None:
        x = np.array(cbfgen.standard_posture())
    body = np.array([x[0], x[1], 0.3])
    # Up to one more than the capacity, never thousands.
    for _ in range(int(case.rng.integers(0, min(edges, 6) + 2))):
        case.call("Environment.push_edge", env.push_edge, *box(case, body, 0.8))
    if case.chance(0.7):
        floor = case.perturbed(case.rng.uniform(-0.2, 0.2, 6), p_extreme=0.03)
        case.call("Environment.floor_z=", setattr, env, "floor_z", case.array_like(floor))
    if case.chance(0.7):
        case.call("Environment.swing=", setattr, env, "swing", [bool(s) for s in case.rng.integers(0, 2, 6)])
    capacity = list(foothold_edges) if foothold_edges is not None else [15, 15, 15, 14, 14, 14]
    for _ in range(int(case.rng.integers(0, 3))):
        leg = case.pick((0, 1, 2, 3, 4, 5, "LF", "mr", 6, -1, "XX")) if case.hostile(0.1) else int(case.rng.integers(6))
        k = int(case.rng.integers(0, min(max(capacity), 8) + 2))
        angles = case.rng.uniform(-np.pi, np.pi, k)
        normals = np.stack([np.cos(angles), np.sin(angles)], axis=1) * case.rng.uniform(0.5, 2.0, (k, 1))
        normals = case.perturbed(normals, p_extreme=0.03)
        offsets = case.perturbed(case.rng.uniform(-0.5, 1.0, k), p_extreme=0.03)
        if case.hostile(0.03):
            normals = normals.T  # (2, k): must be refused unless k == 2
        case.call("Environment.set_foothold", env.set_foothold, leg, case.array_like(normals), case.array_like(offsets))
    for _ in range(int(case.rng.integers(0, 3))):
        leg = int(case.rng.integers(6))
        bounds = [None if case.chance(0.3) else (case.scalar(-2, 2), case.scalar(-1, 1)) for _ in range(2)]
        case.call("Environment.set_stability", env.set_stability, leg, *bounds)
    case.call("Environment.capacity", lambda: env.capacity)
    case.call("Environment.floor_z", lambda: env.floor_z)
    case.call("Environment.foothold", env.foothold, int(case.rng.integers(6)))
    return env


def filter_settings(case: Case, cbfgen, p: float) -> dict:
    """Keyword arguments for EcbfFilter: each setting present with probability ``p``."""
    kw: dict = {}
    families = list(cbfgen.FAMILIES)

    def per_family(draw):
        chosen = [f for f in families if case.chance(0.5)] or [case.pick(families)]
        if case.hostile(0.02):
            chosen.append("no_such_family")
        return {f: draw() for f in chosen}

    if case.chance(p):
        kw["activation"] = per_family(lambda: case.scalar(-1.0, 2.0, p_non_finite=0.05))
    if case.chance(p):
        kw["slack_weight"] = per_family(lambda: case.scalar(1.0, 1e6))
    if case.chance(p):
        kw["poles"] = per_family(lambda: (case.scalar(1.0, 60.0), case.scalar(1.0, 60.0)))
    if case.chance(p):
        kw["input_weights"] = case.array_like(case.perturbed(case.rng.uniform(0.1, 10.0, cbfgen.NU), 0.05))
    limits = np.array(cbfgen.INPUT_LIMITS)
    if case.chance(p):
        kw["input_min"] = case.array_like(case.perturbed(-limits * case.rng.uniform(0.2, 2.0), 0.05))
    if case.chance(p):
        kw["input_max"] = case.array_like(case.perturbed(limits * case.rng.uniform(0.2, 2.0), 0.05))
    if case.hostile(p / 3):  # a degenerate box: min = max (1e307 used to give NaN)
        v = case.pick((0.0, 1.0, cbfgen.MAX_INPUT, -cbfgen.MAX_INPUT, 1e307, -1e300, F64_MAX))
        kw["input_min"] = kw["input_max"] = [v] * cbfgen.NU
    for name in ("eps_abs", "eps_rel"):
        if case.chance(p):
            kw[name] = case.scalar(1e-6, 1e-2)
    if case.chance(p):
        kw["max_iter"] = case.count(400, cbfgen.MAX_ITERATIONS, p_boundary=0.1)
    if case.chance(p):
        kw["polish"] = case.chance(0.5)
    if case.chance(p):
        kw["time_limit_us"] = case.scalar(50.0, 5000.0) if not case.chance(0.1) else case.pick(
            (cbfgen.MAX_TIME_LIMIT_US, cbfgen.MAX_TIME_LIMIT_US * (1 + 1e-15)))
    return kw


# ================================================================== categories
def case_filter_new(case: Case, cbfgen) -> None:
    edges = case.count(25, cbfgen.MAX_EDGES)
    foothold_edges = None
    if case.chance(0.5):
        foothold_edges = [case.count(16, cbfgen.MAX_FOOTHOLD_EDGES, p_boundary=0.02, p_absurd=0.02)
                          for _ in range(6)]
    safety = case.call("EcbfFilter", cbfgen.EcbfFilter, edges, foothold_edges, **filter_settings(case, cbfgen, 0.4))
    if safety is Case.FAILED:
        return
    env = environment(case, cbfgen, edges, foothold_edges)
    if env is Case.FAILED:
        return
    for _ in range(int(case.rng.integers(1, 4))):
        x, u_ref = state(case, cbfgen), nominal_input(case, cbfgen)
        case.call("EcbfFilter.update", safety.update, case.array_like(x), case.array_like(u_ref), env)
    case.call("EcbfFilter.fallback_input", safety.fallback_input, nominal_input(case, cbfgen))


def case_environment(case: Case, cbfgen) -> None:
    edges = case.count(8, cbfgen.MAX_EDGES)
    foothold_edges = None
    if case.chance(0.6):
        foothold_edges = [case.count(6, cbfgen.MAX_FOOTHOLD_EDGES, p_boundary=0.02, p_absurd=0.02)
                          for _ in range(6)]
    if case.hostile(0.05):
        foothold_edges = case.pick(([1, 2, 3], [1] * 7, "abcdef", [1.5] * 6))
    env = environment(case, cbfgen, edges, foothold_edges)
    if env is Case.FAILED or not case.chance(0.5):
        return
    safety = case.call("EcbfFilter", cbfgen.EcbfFilter, edges, foothold_edges)
    if safety is not Case.FAILED:
        case.call("EcbfFilter.update", safety.update, state(case, cbfgen), nominal_input(case, cbfgen), env)


def case_update(case: Case, cbfgen) -> None:
    safety = case.call("EcbfFilter", cbfgen.EcbfFilter, **filter_settings(case, cbfgen, 0.1))
    if safety is Case.FAILED:
        return
    course = cbfgen.Course(case.pick(cbfgen.SCENARIOS)) if case.chance(0.5) else None
    if course is None:
        env = environment(case, cbfgen, 20, None)
        if env is Case.FAILED:
            return
    for _ in range(int(case.rng.integers(1, 6))):
        x = state(case, cbfgen)
        if course is not None:
            x[0] += course.initial_state()[0]
            planned = case.call("Course.plan", course.plan, case.rng.uniform(0.0, 20.0), x)
            env = course.environment
            u_ref = nominal_input(case, cbfgen) if planned is Case.FAILED or case.chance(0.3) else planned
        else:
            u_ref = nominal_input(case, cbfgen)
        case.call("EcbfFilter.update", safety.update, case.array_like(x), case.array_like(u_ref), env)
    # An ordinary cycle after whatever came before must still be finite.
    x = np.array(cbfgen.standard_posture()) + case.rng.normal(0.0, 0.01, cbfgen.NX)
    case.call("EcbfFilter.update", safety.update, x, np.zeros(cbfgen.NU), env)
    case.call("EcbfFilter.output", lambda: safety.output)
    case.call("EcbfFilter.fallback_input", safety.fallback_input, nominal_input(case, cbfgen))


def case_kernels(case: Case, cbfgen) -> None:
    kind = case.pick(("ssat", "ssat_derivatives", "ssat_margin", "rows", "rows", "rows", "dynamics", "sine_barrier"))
    if kind.startswith("ssat"):
        variant = case.pick(cbfgen.SSAT_VARIANTS) if not case.hostile(0.02) else "no_such_variant"
        smoothing = {"alpha": case.scalar(5.0, 300.0, p_extreme=0.15),
                     "alpha_rot": case.scalar(5.0, 300.0, p_extreme=0.15), "variant": variant}
        a, b = box(case, np.zeros(3), 1.0), box(case, np.zeros(3), 1.0)
        if kind == "ssat_margin":
            case.call("ssat_margin", cbfgen.ssat_margin, a[2], b[2], **smoothing)
        else:
            case.call(kind, getattr(cbfgen, kind), *a, *b, **smoothing)
        return
    x = case.array_like(state(case, cbfgen))
    leg = case.pick((6, -1, "XX", "rr")) if case.hostile(0.03) else int(case.rng.integers(6))
    if kind == "rows":
        family = case.pick(("joint_limits", "foot_height", "stability", "body_edge", "toe_edge", "foothold"))
        if family == "joint_limits":
            case.call(family, cbfgen.joint_limits, leg, x)
        elif family == "foot_height":
            case.call(family, cbfgen.foot_height, leg, x, case.scalar(-0.2, 0.2))
        elif family == "stability":
            case.call(family, cbfgen.stability, leg, x, case.scalar(-2.0, 2.0), case.scalar(-1.0, 1.0))
        elif family == "body_edge":
            case.call(family, cbfgen.body_edge, x, *box(case, [0.0, 0.0, 0.3], 0.8))
        elif family == "toe_edge":
            case.call(family, cbfgen.toe_edge, leg, x, *box(case, [0.0, 0.0, 0.1], 0.8))
        else:
            angle = case.rng.uniform(-np.pi, np.pi)
            normal = case.perturbed([np.cos(angle), np.sin(angle)], p_extreme=0.05)
            case.call(family, cbfgen.foothold, leg, x, case.array_like(normal), case.scalar(-0.5, 1.0))
    elif kind == "dynamics":
        which = case.pick(("dynamics_f", "dynamics_g", "xdot", "world_kinematics"))
        if which == "xdot":
            case.call(which, cbfgen.xdot, x, case.array_like(nominal_input(case, cbfgen)))
        else:
            case.call(which, getattr(cbfgen, which), x)
    else:
        q = case.array_like(case.perturbed(case.rng.uniform(-2.0, 2.0, 2), p_extreme=0.1))
        case.call("sine_barrier", cbfgen.sine_barrier, q, case.scalar(0.0, 100.0), case.scalar(-1.0, 1.0),
                  case.scalar(0.0, 20.0), case.scalar(-1.0, 1.0))


def case_course(case: Case, cbfgen) -> None:
    scenario = case.pick(cbfgen.SCENARIOS) if not case.hostile(0.02) else "moon"
    if case.chance(0.3):
        u = case.rng.random()
        if u < 1 - 0.3 * case.hostility:
            max_time = float(case.rng.uniform(0.001, 0.05))
        elif u < 0.98:
            max_time = case.pick(FINITE_EXTREMES + NON_FINITE + (-1.0,))
        else:
            # whole runs, that stop when the course is done
            max_time = case.pick((30.0, cbfgen.MAX_SIM_TIME, 1e4))
        case.call("simulate", cbfgen.simulate, scenario, case.chance(0.7), max_time)
        return
    course = case.call("Course", cbfgen.Course, scenario)
    if course is Case.FAILED:
        return
    x = case.call("Course.initial_state", course.initial_state, case.scalar(0.0, 1.0))
    if x is Case.FAILED:
        x = course.initial_state()
    for _ in range(int(case.rng.integers(1, 4))):
        t = case.scalar(0.0, 60.0)
        y = x + case.rng.normal(0.0, 0.02, x.size)
        if case.chance(0.2):
            y = state(case, cbfgen)
        case.call("Course.plan", course.plan, t, case.array_like(y))
        case.call("Course.clearance", course.clearance, y)
        case.call("Course.finished", course.finished, y)
    case.call("Course.floor_height", course.floor_height, case.scalar(-1.0, 5.0))
    case.call("Course.nominal_body_height", lambda: course.nominal_body_height)


RUNNERS = {"filter_new": case_filter_new, "environment": case_environment, "update": case_update,
           "kernels": case_kernels, "course": case_course}


def draw_category(rng: np.random.Generator) -> str:
    return CATEGORIES[int(rng.choice(len(CATEGORIES), p=CATEGORY_WEIGHTS))]


def run_case(
    seed: int, index: int, verbose: bool = False, inject: tuple[str, int] | None = None
) -> tuple[str, str, str]:
    """``(category, outcome, detail)`` of case ``index``. ``inject`` = (kind, case) makes
    that case abort, hang, panic or return NaN instead: the harness's own check that it
    attributes each kind of finding (python/tests/test_fuzz_python.py)."""
    import cbfgen

    rng = np.random.default_rng([seed, index])
    category = draw_category(rng)
    case = Case(rng, verbose)
    try:
        if inject is not None and inject[1] == index:
            injected(case, inject[0])
        RUNNERS[category](case, cbfgen)
    except Finding as e:
        return category, "nonfinite", f"{e}; last call: {last_call(case)}"
    except BaseException as e:  # noqa: BLE001 - PanicException derives from BaseException
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            raise
        outcome = "panic" if type(e).__name__ == "PanicException" else "other_exception"
        return category, outcome, f"{type(e).__name__}: {e}; last call: {last_call(case)}"
    if case.typed_errors:
        return category, "typed_error", ",".join(sorted(case.typed_errors))
    return category, "ok", ""


def injected(case: Case, kind: str) -> None:
    if kind == "abort":
        os.abort()
    if kind == "hang":
        time.sleep(3600)
    if kind == "panic":
        raise type("PanicException", (BaseException,), {})("injected")
    if kind == "nonfinite":
        case.call("injected", lambda: math.nan)
    raise ValueError(f"unknown injection {kind!r}")


def last_call(case: Case) -> str:
    return describe_call(*case.calls[-1]) if case.calls else "-"


# ================================================================== processes
def worker(seed: int, start: int, stop: int, inject: tuple[str, int] | None) -> None:
    """Run cases [start, stop), announcing each before it runs, so that the parent can
    attribute a death or a hang to it."""
    warnings.simplefilter("ignore")
    np.seterr(all="ignore")
    out = sys.stdout
    for index in range(start, stop):
        out.write(f"start {index}\n")
        out.flush()
        category, outcome, detail = run_case(seed, index, inject=inject)
        out.write(json.dumps({"case": index, "category": category, "outcome": outcome, "detail": detail}) + "\n")
        out.flush()


def campaign(seed: int, cases: int, chunk: int, case_timeout: float, progress: bool, inject: str | None):
    """Counts per category and outcome, and the findings."""
    counts = {c: Counter() for c in CATEGORIES}
    errors: Counter[str] = Counter()
    findings: list[dict] = []
    started = time.monotonic()
    index = 0
    while index < cases:
        stop = min(index + chunk, cases)
        with tempfile.TemporaryFile(mode="w+") as stderr:
            child = subprocess.Popen(
                [sys.executable, os.path.abspath(__file__), "--worker", "--seed", str(seed),
                 "--start", str(index), "--stop", str(stop)] + (["--inject", inject] if inject else []),
                stdout=subprocess.PIPE, stderr=stderr, text=True)
            lines: queue.Queue = queue.Queue()
            threading.Thread(target=forward_lines, args=(child.stdout, lines), daemon=True).start()
            running = None
            while True:
                try:
                    # Only a hang detector: a case takes milliseconds, a whole simulation ~2 s.
                    line = lines.get(timeout=case_timeout if running is not None else case_timeout + 30)
                except queue.Empty:
                    child.kill()
                    child.wait()
                    if running is None:
                        raise RuntimeError("the fuzz worker did not start") from None
                    outcome, detail = "hang", f"no result within {case_timeout:g} s"
                    break
                if line is None:
                    child.wait()
                    if running is None:
                        if index < stop:  # died between cases: at import, or in the harness
                            stderr.seek(0)
                            raise RuntimeError(
                                f"the fuzz worker exited early ({child.returncode}):\n{stderr.read()[-3000:]}"
                            )
                        outcome = None
                        break
                    stderr.seek(0)
                    # The first lines say why ("memory allocation of ... failed"); a
                    # backtrace may follow.
                    why = " | ".join(stderr.read().strip().splitlines()[:3])[:600]
                    outcome, detail = "abort", f"exit status {child.returncode}: {why}"
                    break
                if line.startswith("start "):
                    running = int(line.split()[1])
                    continue
                result = json.loads(line)
                counts[result["category"]][result["outcome"]] += 1
                if result["outcome"] == "typed_error":
                    errors.update(result["detail"].split(","))
                elif result["outcome"] in FINDINGS:
                    findings.append(result)
                running = None
                index = result["case"] + 1
            if child.poll() is None:
                child.kill()
                child.wait()
        if outcome is not None:  # the running case died or hung; go on after it
            category = draw_category(np.random.default_rng([seed, running]))
            counts[category][outcome] += 1
            findings.append({"case": running, "category": category, "outcome": outcome, "detail": detail})
            index = running + 1
        if progress:
            elapsed = time.monotonic() - started
            print(f"  {index}/{cases} cases, {len(findings)} findings, {elapsed:.0f} s", file=sys.stderr, flush=True)
    return counts, errors, findings


def forward_lines(stream, lines: queue.Queue) -> None:
    """Every line of ``stream`` into ``lines``, then None at its end."""
    for line in stream:
        lines.put(line)
    lines.put(None)


def report(seed: int, cases: int, counts, errors, findings, shown: int) -> None:
    width = max(len(o) for o in OUTCOMES)
    print(f"cbfgen Python fuzz: {cases} cases, seed {seed}")
    print(f"{'':<{width}}" + "".join(f"{c:>13}" for c in CATEGORIES) + f"{'total':>10}")
    for outcome in OUTCOMES:
        row = [counts[c][outcome] for c in CATEGORIES]
        print(f"{outcome:<{width}}" + "".join(f"{n:>13}" for n in row) + f"{sum(row):>10}")
    print("typed errors by type: " + ", ".join(f"{k} {v}" for k, v in sorted(errors.items())))
    for f in findings[:shown]:
        print(f"\n[{f['outcome']}] case {f['case']} ({f['category']}): {f['detail']}")
        print(f"  replay: {sys.executable} {sys.argv[0]} --seed {seed} --replay {f['case']}")
    if len(findings) > shown:
        print(f"\n... and {len(findings) - shown} more findings")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=100_000, help="number of cases (default 100000)")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed; case i draws from [seed, i]")
    parser.add_argument("--chunk", type=int, default=2000, help="cases per child process")
    parser.add_argument("--case-timeout", type=float, default=30.0,
                        help="seconds without a result before a case counts as hung (default 30)")
    parser.add_argument("--show", type=int, default=20, help="findings to print in full")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.add_argument("--summary-json", metavar="PATH", help="also write the counts and findings as JSON")
    parser.add_argument("--replay", type=int, metavar="CASE", help="run one case here, printing each call")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--stop", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--inject", metavar="KIND:CASE", help=argparse.SUPPRESS)  # abort|hang|panic|nonfinite
    args = parser.parse_args()

    inject = None
    if args.inject:
        kind, case = args.inject.split(":")
        inject = (kind, int(case))
    if args.worker:
        worker(args.seed, args.start, args.stop, inject)
        return 0
    if args.replay is not None:
        warnings.simplefilter("ignore")
        np.seterr(all="ignore")
        category, outcome, detail = run_case(args.seed, args.replay, verbose=True)
        print(f"case {args.replay} ({category}): {outcome} {detail}")
        return 1 if outcome in FINDINGS else 0
    counts, errors, findings = campaign(args.seed, args.cases, args.chunk, args.case_timeout, not args.quiet,
                                        args.inject)
    report(args.seed, args.cases, counts, errors, findings, args.show)
    if args.summary_json:
        with open(args.summary_json, "w") as f:
            json.dump({"seed": args.seed, "cases": args.cases, "counts": {c: dict(n) for c, n in counts.items()},
                       "typed_errors": dict(errors), "findings": findings}, f, indent=1)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
