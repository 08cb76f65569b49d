#!/usr/bin/env python3
"""Fuzz cbfgen's Python API with seeded random cases (issue 12).

Each case is one short, independent scenario drawn from its own seed
(``numpy.random.default_rng([seed, case])``), for one built-in system (``cbfgen.systems()``;
Tachyon 3 more often, as it has the deep paths), in one of five categories:

  filter_new   EcbfFilter construction (``EcbfFilter(system | name, capacity)``,
               ``System.filter``, ``tachyon3.ecbf_filter``) with random settings and
               capacities (valid, boundary and absurd: 1e300, f64 max, 5e-324, negative,
               huge ints, unknown families, counts per member of the wrong length), then
               parameters of that capacity, a few updates and the filter's getters;
  params       Params building and editing by family name (``set``, ``push``, ``get``,
               ``remove``, ``clear``, ``set_enabled``, ``is_enabled``, ``count``, ``copy``)
               with bad family names, members and instances, dicts with a field missing or
               extra, values of the wrong shape, flat vectors of the wrong length, NaN and
               1e300 values; for Tachyon 3 also ``tachyon3.Environment``'s helpers (edge
               cuboids, floors, footholds, swing legs, stability bounds); then one update
               with them, or with another system's or capacity's parameters;
  update       EcbfFilter.update sequences at states near a nominal one and at extremes,
               nominal inputs from Tachyon 3's course gait or random (extremes too), random
               times, each followed by an ordinary cycle that must stay finite;
  kernels      the SSAT functions, ``System.rows`` at random parameters, the dynamics
               (``System.drift``, ``input_matrix``, ``xdot``), Tachyon 3's kinematics and
               every generated kernel through ``call_kernel``;
  course       Tachyon 3's Course (plan, clearance, finished, floor height) and short
               simulate runs.

Every call's result is checked: an outcome is ``ok``, ``typed_error`` (CbfError,
ValueError, TypeError, OverflowError), ``panic`` (pyo3's PanicException),
``other_exception``, ``nonfinite`` (a NaN or infinity in a returned value that came
without an exception: a filter output's ``u`` or ``slack``, ``Rows``, any kernel or course
output, every simulate series except ``min_h``, whose ``inf`` means "no row applied"),
``inconsistent`` (a call that raised changed what it promises to leave alone: a
parameter instance after a refused ``set``/``push``, a filter's output after a refused
``update``), ``abort`` (the process died) or ``hang`` (no result within
``--case-timeout``). Cases run in chunks in a child process, so an abort or a hang is
attributed to the case that was running, and the campaign continues with the next case in
a new child.

The exit status is 1 if any case panicked, aborted, hung, returned a non-finite value,
was inconsistent or raised an exception outside the typed ones (an untyped error is a
finding too, or this harness has rotted), else 0. Replay one case, printing each call
before it runs:

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

CATEGORIES = ("filter_new", "params", "update", "kernels", "course")
# How often each category is drawn: the filter update is the real-time path.
CATEGORY_WEIGHTS = (0.2, 0.15, 0.3, 0.25, 0.1)
OUTCOMES = ("ok", "typed_error", "panic", "other_exception", "nonfinite", "inconsistent", "abort", "hang")
FINDINGS = ("panic", "other_exception", "nonfinite", "inconsistent", "abort", "hang")
TYPED_ERRORS = (ValueError, TypeError, OverflowError)  # cbfgen.CbfError is a ValueError

F64_MAX = float(np.finfo(np.float64).max)
# Finite extremes: of the float format, and at or just past the documented domains'
# edges (STATE_LIMIT 1e5, MAX_INPUT, PARAM_LIMIT and MAX_COORDINATE 1e6, tolerances 1e-12
# and 1e3, MAX_SIM_TIME 600, SSAT alpha 1e-6 and 1e9, half extents 1e-6 and 1e4, times 1e9).
FINITE_EXTREMES = (0.0, -0.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 1e-12, 1e-12 * (1 - 1e-15),
                   1e-6, 1e-6 * (1 - 1e-15), 1e3, 600.0, 600.0000000000001, 1e4, 1e5, 100000.00000000001, 1e6, -1e6,
                   1000000.0000000001, 1e9, 1000000000.0000001, 1e12, 1e26, 1e300, -1e300, F64_MAX, -F64_MAX)
NON_FINITE = (math.nan, math.inf, -math.inf)
INT_EXTREMES = (-1, 0, 1, 2**31, 2**32 - 1, 2**32, 2**62, 2**63 - 1, 2**64 // 7 + 1, 2**64 - 1, 2**64,
                10**6, 10**9, -(2**63))
# Hip mount height in the body frame (systems/tachyon3/generated/tachyon3.rs HIP_POSITIONS[..][2]); the
# hips' x equal the toes' x in the standard posture.
HIP_Z = 0.12
# Tachyon 3 has many families, capacities and the course; the double integrator is small.
TACHYON3_WEIGHT = 0.65
# Typical value ranges of the built-in systems' parameters, by name; others draw from
# (-1, 1). Values outside are drawn too (extremes, NaN), as for every argument.
PARAM_RANGES = {"half": (0.02, 0.6), "floor_z": (-0.2, 0.2), "a": (-2.0, 2.0), "offset": (-0.5, 1.0),
                "amplitude": (0.0, 1.0), "omega": (0.0, 5.0)}
class Finding(Exception):
    """A call returned a non-finite value (``nonfinite``) or broke its promise to change
    nothing when it raises (``inconsistent``)."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind


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
        self.system = "-"  # the system this case exercises, if any

    # ------------------------------------------------------------ calls
    def call(self, name: str, fn, *args, expected: tuple = (), **kwargs):
        """``fn(*args, **kwargs)``, or ``FAILED`` if it raised a typed error (or one of
        ``expected``, for a call documented to raise another type)."""
        self.calls.append((name, args, kwargs))
        if self.verbose:
            print(">>", describe_call(name, args, kwargs), flush=True)
        try:
            result = fn(*args, **kwargs)
        except (*TYPED_ERRORS, *expected) as e:
            self.typed_errors[type(e).__name__] += 1
            if self.verbose:
                print(f"   {type(e).__name__}: {e}", flush=True)
            return self.FAILED
        where = first_non_finite(result)
        if where is not None:
            raise Finding("nonfinite", f"{name} returned a non-finite value at {where}")
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

    def perturbed(self, values, p_extreme: float, p_non_finite: float = 0.01) -> np.ndarray:
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
        values = np.asarray(values, dtype=float)
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
    kind = type(value).__name__
    if kind == "FilterOutput":
        return first_non_finite(value.u, f"{path}.u") or first_non_finite(
            [r["slack"] for r in value.relaxed] + [r["relative"] for r in value.relaxed], f"{path}.relaxed")
    if kind == "Rows":
        return first_non_finite(value.lie, f"{path}.lie") or first_non_finite(value.lg_lf, f"{path}.lg_lf")
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
    return None  # Params, EcbfFilter, System, Course: objects, not values


def describe_call(name: str, args: tuple, kwargs: dict) -> str:
    with np.printoptions(precision=17, threshold=40, linewidth=10**6):
        parts = [repr(a) for a in args] + [f"{k}={v!r}" for k, v in kwargs.items()]
    text = f"{name}({', '.join(parts)})"
    return text if len(text) < 2000 else text[:2000] + "..."


def same(a, b) -> bool:
    """Whether two results of ``Params.get`` (dicts of floats and arrays, or None) are
    equal, NaN-free as they are."""
    if a is None or b is None:
        return a is b
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


# ====================================================================== draws
def pick_system(case: Case, cbfgen):
    names = list(cbfgen.systems())
    if "tachyon3" in names and (len(names) == 1 or case.chance(TACHYON3_WEIGHT)):
        case.system = "tachyon3"
    else:
        case.system = case.pick([n for n in names if n != "tachyon3"])
    return cbfgen.System(case.system)


def rotation(case: Case, mangle: bool = True):
    """Mostly a proper rotation (yaw-only like stair edges, or any); sometimes a
    reflection, a scaled or sheared matrix, or entries replaced by extremes; as 9 values
    or 3×3, and (``mangle``) sometimes as another array-like."""
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
    return case.array_like(r) if mangle else r


def half_extents(case: Case) -> np.ndarray:
    half = case.perturbed(case.rng.uniform(0.02, 0.6, 3), p_extreme=0.05)
    if case.hostile(0.03):
        half[int(case.rng.integers(3))] = case.pick((0.0, -0.1, 1e-300))
    return half


def unit_normal(case: Case, n: int) -> np.ndarray:
    """Mostly a unit vector (what a normal's domain accepts); sometimes scaled, zero or
    perturbed, which its domain refuses."""
    v = case.rng.normal(size=n)
    v /= np.linalg.norm(v) or 1.0
    if case.hostile(0.05):
        v = v * case.pick((0.0, 2.0, 1.0 + 1e-6))
    return case.perturbed(v, p_extreme=0.03)


def box(case: Case, center, spread: float):
    centre = case.perturbed(np.asarray(center) + case.rng.uniform(-spread, spread, 3), p_extreme=0.03)
    return case.array_like(centre), rotation(case), case.array_like(half_extents(case))


def tachyon3_state(case: Case, t3) -> np.ndarray:
    """Near the standard posture (at some origin pose), sometimes far from it, with a toe
    exactly at its hip, or with entries replaced by extremes."""
    x = np.array(t3.standard_posture())
    x[0:2] = case.rng.uniform(-2.0, 2.0, 2)
    x[3] = case.rng.uniform(-3.0, 3.0)
    mode = case.pick(("near", "near", "near", "wide", "toe_at_hip", "extreme", "domain_edge"))
    scale = 1.0 if mode == "wide" else 0.02
    x = x + case.rng.normal(0.0, scale, x.size)
    if mode == "toe_at_hip":
        leg = int(case.rng.integers(6))
        x[t3.STATE_NAMES.index("pitch")] = 0.0
        x[12 + 4 * leg] = x[t3.STATE_NAMES.index("bx")] + t3.standard_posture()[12 + 4 * leg]
        x[12 + 4 * leg + 1] = x[t3.STATE_NAMES.index("bz")] + HIP_Z
    return with_mode(case, x, mode)


def with_mode(case: Case, x: np.ndarray, mode: str) -> np.ndarray:
    import cbfgen

    if mode == "extreme":
        x = case.perturbed(x, p_extreme=0.1)
    if mode == "domain_edge":  # some entries at ±STATE_LIMIT: inside the domain, so finite results
        edge = case.rng.random(x.size) < case.rng.uniform(0.05, 1.0)
        x[edge] = case.rng.choice([-1.0, 1.0], edge.sum()) * cbfgen.STATE_LIMIT
    return x


def nominal_state(system) -> np.ndarray:
    from cbfgen import tachyon3 as t3

    return np.array(t3.standard_posture()) if system.name == "tachyon3" else np.zeros(system.nx)


def state(case: Case, system) -> np.ndarray:
    """A state of ``system``: near its nominal one mostly, sometimes far from it or with
    extreme entries (and Tachyon 3's own singular postures)."""
    if system.name == "tachyon3":
        from cbfgen import tachyon3 as t3

        return tachyon3_state(case, t3)
    mode = case.pick(("near", "near", "near", "wide", "extreme", "domain_edge"))
    x = case.rng.normal(0.0, 100.0 if mode == "wide" else 1.0, system.nx)
    return with_mode(case, x, mode)


def input_scale(system) -> np.ndarray:
    """Typical input magnitudes: the spec's limits, at most 10 (the double integrator's
    are ±MAX_INPUT)."""
    return np.minimum(np.maximum(np.abs(system.input_min), np.abs(system.input_max)), 10.0)


def nominal_input(case: Case, system) -> np.ndarray:
    u = case.rng.uniform(-1.5, 1.5, system.nu) * input_scale(system)
    if case.chance(0.3):
        u = case.perturbed(u, p_extreme=0.1)
    return u


def time_of(case: Case) -> float:
    return case.scalar(0.0, 20.0, p_extreme=0.05)


def param_value(case: Case, name: str, shape: list[int]):
    """One parameter's value (an array of ``shape``), mostly in its typical range."""
    if name == "rotation" and list(shape) == [3, 3]:
        return rotation(case)
    if name == "half" and list(shape) == [3]:
        return half_extents(case)
    if name == "normal" and len(shape) == 1:
        return unit_normal(case, shape[0])
    lo, hi = PARAM_RANGES.get(name, (-1.0, 1.0))
    if not shape:
        return case.scalar(lo, hi, p_extreme=0.05)
    return case.perturbed(case.rng.uniform(lo, hi, shape), p_extreme=0.03)


def family_values(case: Case, family: dict):
    """One instance of ``family`` (an entry of ``System.families``): mostly a dict
    ``{name: value}`` or the flat vector, valid; sometimes a field missing or extra, a value
    of the wrong shape or dtype, or a flat vector of the wrong length or shape."""
    values = {name: param_value(case, name, shape) for name, shape in family["params"]}
    if case.chance(0.35):
        try:
            flat = np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in values.values()] or [np.zeros(0)])
        except (TypeError, ValueError):  # a mangled rotation (strings, complex): keep the dict
            return values
        u = case.badness()
        if u < 0.03:
            flat = np.append(flat, 0.0)
        elif u < 0.06:
            flat = flat[:-1]
        elif u < 0.08:
            flat = flat.reshape(1, -1)
        return case.array_like(flat)
    values = {name: case.array_like(v) if isinstance(v, np.ndarray) else v for name, v in values.items()}
    u = case.badness()
    if u < 0.03 and values:
        del values[case.pick(list(values))]
    elif u < 0.06:
        values[case.pick(("no_such_param", "x", "HALF"))] = 0.0
    elif u < 0.09 and values:
        key = case.pick(list(values))
        values[key] = np.zeros(int(np.prod(np.shape(values[key]))) + 1)  # one value more than its shape holds
    elif u < 0.1:
        values = case.pick((None, 3.0, "values", [values]))
    return values


def family_name(case: Case, family: dict) -> str:
    if case.hostile(0.03):
        return case.pick(("no_such_family", "", family["name"].upper(), family["name"] + " "))
    return family["name"]


def member_kw(case: Case, family: dict, required: bool = True) -> dict:
    """``member=`` for ``family``: by index or by name (any case) for an indexed family,
    absent for another; sometimes missing, out of range, unknown or of the wrong type.
    ``required=False`` (clear, set_enabled) may also leave it out: every member then."""
    members = family["members"]
    if case.hostile(0.04):
        bad = case.pick((None, 6, -1, len(members), "xx", "", 2**70, 1.5, "lf", 0))
        return {} if bad is None else {"member": bad}
    if not members or (not required and case.chance(0.4)):
        return {}
    i = int(case.rng.integers(len(members)))
    return {"member": i if case.chance(0.5) else case.pick((members[i], members[i].upper()))}


def instance_kw(case: Case, params, family: str, kw: dict) -> dict:
    """``instance=``: mostly one that is there (or absent: 0), sometimes one past the last
    or an absurd integer."""
    if case.hostile(0.04):
        return {"instance": case.pick((-1, 2**64, 10**9, 2**63))}
    try:
        present = params.count(family, **kw)
    except Exception:  # noqa: BLE001 - a bad family or member: the call itself will say
        present = 1
    if case.chance(0.1):
        return {"instance": present}
    return {"instance": int(case.rng.integers(0, max(present, 1)))} if case.chance(0.7) else {}


def capacity(case: Case, system, typical: int = 8) -> dict:
    """A capacity for ``system``'s capacity families: counts up to ``typical`` mostly (the
    documented maximum, one above or absurd integers sometimes), one count for every member
    or a list of them; sometimes a family without a capacity, an unknown one, a list of the
    wrong length or a count that is no count."""
    out: dict = {}
    for f in system.families:
        if f["instances"] != "capacity" or not case.chance(0.8):
            continue
        if f["members"] and case.chance(0.6):
            out[f["name"]] = [case.count(typical, f["count"], p_boundary=0.02, p_absurd=0.02) for _ in f["members"]]
        else:
            out[f["name"]] = case.count(typical, f["count"])
    u = case.badness()
    if u < 0.03:
        f = case.pick(system.families)
        out[f["name"]] = case.pick(([1] * (len(f["members"]) + 2), [1, 2], "abcdef", 1.5, None, -1))
    elif u < 0.05:
        out[case.pick(("no_such_family", "joint_limits", "stability", "sine_barrier"))] = 1
    return out


def filter_settings(case: Case, cbfgen, system, p: float) -> dict:
    """Keyword arguments for EcbfFilter: each setting present with probability ``p``."""
    kw: dict = {}
    families = system.families
    nu = system.nu

    def per_family(draw):
        chosen = [f for f in families if case.chance(0.5)] or [case.pick(families)]
        out = {f["name"]: draw(f) for f in chosen}
        if case.hostile(0.02):
            out[case.pick(("no_such_family", "",))] = draw(chosen[0])
        return out

    def poles(f):
        n = f["relative_degree"] if not case.hostile(0.03) else case.pick((0, 1, 3))
        return tuple(case.scalar(1.0, 60.0) for _ in range(n))

    if case.chance(p):
        kw["activation"] = per_family(lambda f: case.scalar(-1.0, 2.0, p_non_finite=0.05))
    if case.chance(p):
        kw["priority"] = per_family(lambda f: int(case.rng.integers(0, 16)) if not case.hostile(0.03)
                                    else case.pick((16, 255, -1)))
    if case.chance(p):
        kw["poles"] = per_family(poles)
    if case.chance(p):
        kw["input_weights"] = case.array_like(case.perturbed(case.rng.uniform(0.1, 10.0, nu), 0.05))
    limits = input_scale(system)
    if case.chance(p):
        kw["input_min"] = case.array_like(case.perturbed(-limits * case.rng.uniform(0.2, 2.0), 0.05))
    if case.chance(p):
        kw["input_max"] = case.array_like(case.perturbed(limits * case.rng.uniform(0.2, 2.0), 0.05))
    if case.hostile(p / 3):  # a degenerate box: min = max (1e307 used to give NaN)
        v = case.pick((0.0, 1.0, cbfgen.MAX_INPUT, -cbfgen.MAX_INPUT, 1e307, -1e300, F64_MAX))
        kw["input_min"] = kw["input_max"] = [v] * nu
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
    if case.hostile(0.02):
        kw[case.pick(("no_such_setting", "edges", "capacity"))] = 1
    return kw


# ================================================================== building blocks
# Params operations by the kind of a family's instances ("fixed", "optional", "capacity"),
# weighted by repetition; ALL_OPERATIONS includes the ones each kind refuses.
OPERATIONS = {
    "fixed": ("set", "set", "get", "count", "is_enabled", "copy"),
    "optional": ("set", "set", "get", "remove", "clear", "count", "copy"),
    "capacity": ("push", "push", "push", "set", "get", "clear", "set_enabled", "is_enabled", "count", "copy"),
}
ALL_OPERATIONS = ("set", "push", "get", "remove", "clear", "set_enabled", "is_enabled", "count", "copy")

def make_filter(case: Case, cbfgen, system, cap: dict, settings: dict):
    """The filter of ``system`` for capacity ``cap``, by one of the equivalent routes."""
    how = case.pick(("EcbfFilter", "EcbfFilter(name)", "System.filter"))
    if how == "EcbfFilter":
        return case.call("EcbfFilter", cbfgen.EcbfFilter, system, cap, **settings)
    if how == "EcbfFilter(name)":
        name = system.name if not case.hostile(0.03) else case.pick(("no_such_system", "", "Tachyon3"))
        return case.call("EcbfFilter", cbfgen.EcbfFilter, name, cap, **settings)
    return case.call("System.filter", system.filter, cap, **settings)


def edit_params(case: Case, system, params, operations: int) -> None:
    """``operations`` random edits of ``params`` by family name. A refused ``set`` or
    ``push`` must leave the instance (and the count) as they were."""
    families = system.families
    with_params = [f for f in families if f["params"]] or families
    for _ in range(operations):
        # Mostly an operation the family's kind supports (so that cases reach the value
        # checks and the filter), sometimes any on any family.
        hostile = case.hostile(0.3)
        f = case.pick(families if hostile else with_params)
        name = family_name(case, f)
        op = case.pick(ALL_OPERATIONS if hostile else OPERATIONS[f["instances"]])
        if op in ("set", "push"):
            kw = member_kw(case, f)
            where = {**kw, **(instance_kw(case, params, name, kw) if op == "set" else {})}
            before = snapshot(params, name, where, op)
            done = case.call(f"Params.{op}", getattr(params, op), name, family_values(case, f), **where)
            if done is Case.FAILED and before is not None and snapshot(params, name, where, op) != before:
                raise Finding("inconsistent", f"a refused Params.{op}({name!r}, **{where}) changed the parameters; "
                                              f"last call: {describe_call(*case.calls[-1])}")
        elif op == "get":
            kw = member_kw(case, f)
            case.call("Params.get", params.get, name, **kw, **instance_kw(case, params, name, kw))
        elif op == "remove":
            kw = member_kw(case, f)
            case.call("Params.remove", params.remove, name, **kw, **instance_kw(case, params, name, kw))
        elif op == "clear":
            case.call("Params.clear", params.clear, name, **member_kw(case, f, required=False))
        elif op == "set_enabled":
            case.call("Params.set_enabled", params.set_enabled, name, case.chance(0.7),
                      **member_kw(case, f, required=False))
        elif op in ("is_enabled", "count"):
            case.call(f"Params.{op}", getattr(params, op), name, **member_kw(case, f))
        else:
            case.call("Params.copy", params.copy)
    case.call("Params.capacity", lambda: params.capacity)


def snapshot(params, family: str, where: dict, op: str):
    """What a ``set`` (the instance) or ``push`` (the count and last instance) at ``where``
    may change, for comparison after a refused call; None where it cannot be read."""
    def plain(got):
        return None if got is None else {k: np.asarray(v).tolist() for k, v in got.items()}

    try:
        member = {k: v for k, v in where.items() if k == "member"}
        if op == "push":
            n = params.count(family, **member)
            return n, plain(params.get(family, **member, instance=n - 1) if n else None)
        return "instance", plain(params.get(family, **where))  # None: an empty slot
    except Exception:  # noqa: BLE001 - nothing to compare
        return None


def tachyon3_environment(case: Case, t3, edges, foothold_edges, x=None):
    """A Tachyon 3 environment of this size through its own helpers: edge cuboids near the
    robot, floors, foothold polygons and stability bounds, mostly valid. ``FAILED`` if it
    could not be built."""
    env = case.call("Environment", t3.Environment, edges, foothold_edges)
    if env is Case.FAILED:
        return env
    if x is None:
        x = np.array(t3.standard_posture())
    body = np.array([x[0], x[1], 0.3])
    # Up to one more than the capacity, never thousands.
    for _ in range(int(case.rng.integers(0, min(edges, 6) + 2))):
        case.call("Environment.push_edge", env.push_edge, *box(case, body, 0.8))
    if case.chance(0.7):
        floor = case.perturbed(case.rng.uniform(-0.2, 0.2, 6), p_extreme=0.03)
        case.call("Environment.floor_z=", setattr, env, "floor_z", case.array_like(floor))
    if case.chance(0.7):
        case.call("Environment.swing=", setattr, env, "swing", [bool(s) for s in case.rng.integers(0, 2, 6)])
    sizes = list(foothold_edges) if foothold_edges is not None else list(t3.PAPER_FOOTHOLD_EDGES)
    for _ in range(int(case.rng.integers(0, 3))):
        leg = case.pick((0, 1, 2, 3, 4, 5, "LF", "mr", 6, -1, "XX")) if case.hostile(0.1) else int(case.rng.integers(6))
        k = int(case.rng.integers(0, min(max(sizes), 8) + 2))
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
    case.call("Environment.sizes", lambda: env.sizes)
    case.call("Environment.capacity", lambda: env.capacity)
    case.call("Environment.floor_z", lambda: env.floor_z)
    case.call("Environment.foothold", env.foothold, int(case.rng.integers(6)))
    return env


def tachyon3_sizes(case: Case, t3, typical_edges: int, typical_foothold: int):
    edges = case.count(typical_edges, t3.MAX_EDGES)
    foothold_edges = None
    if case.chance(0.5):
        foothold_edges = [case.count(typical_foothold, t3.MAX_FOOTHOLD_EDGES, p_boundary=0.02, p_absurd=0.02)
                          for _ in range(6)]
    if case.hostile(0.03):
        foothold_edges = case.pick(([1, 2, 3], [1] * 7, "abcdef", [1.5] * 6))
    return edges, foothold_edges


def setup(case: Case, cbfgen, system, typical: int, settings_p: float):
    """``(filter, params)`` of one capacity for ``system`` (Tachyon 3: sometimes sized by
    edges through ``tachyon3.ecbf_filter`` and ``Environment``), or ``(FAILED, _)``."""
    settings = filter_settings(case, cbfgen, system, settings_p)
    if system.name == "tachyon3" and case.chance(0.5):
        from cbfgen import tachyon3 as t3

        edges, foothold_edges = tachyon3_sizes(case, t3, typical, typical)
        safety = case.call("tachyon3.ecbf_filter", t3.ecbf_filter, edges, foothold_edges, **settings)
        if safety is Case.FAILED:
            return safety, None
        params = tachyon3_environment(case, t3, edges, foothold_edges)
    else:
        cap = capacity(case, system, typical)
        safety = make_filter(case, cbfgen, system, cap, settings)
        if safety is Case.FAILED:
            return safety, None
        params = case.call("System.params", system.params, cap)
    if params is not Case.FAILED:
        edit_params(case, system, params, int(case.rng.integers(0, 8)))
    return safety, params


def update(case: Case, safety, x, u_ref, params, **kw):
    """One filter update; a refused one must leave the filter's output as it was."""
    before = np.array(safety.output.u)
    out = case.call("EcbfFilter.update", safety.update, x, u_ref, params, **kw)
    if out is Case.FAILED and not np.array_equal(np.array(safety.output.u), before):
        raise Finding("inconsistent", f"a refused EcbfFilter.update changed the output; "
                                      f"last call: {describe_call(*case.calls[-1])}")
    return out


def other_params(case: Case, cbfgen, system):
    """Parameters the filter must refuse: another system's, or (Tachyon 3) of another
    capacity."""
    others = [n for n in cbfgen.systems() if n != system.name]
    if others and case.chance(0.7):
        return case.call("System.params", cbfgen.System(case.pick(others)).params)
    return case.call("System.params", system.params, {f["name"]: 3 for f in system.families
                                                      if f["instances"] == "capacity"})


def inspect_filter(case: Case, safety) -> None:
    """The filter's getters: shapes and settings always; every array finite (``lie`` or
    ``lg_lf`` is None after a cycle whose rows were not finite)."""
    case.call("EcbfFilter.output", lambda: safety.output)
    case.call("EcbfFilter.slack", lambda: safety.slack)

    def shapes():
        lie, lg = safety.lie, safety.lg_lf
        return (safety.row_count, len(safety.layout), None if lie is None else lie.shape,
                None if lg is None else lg.shape, len(safety.applicable), len(safety.active))

    case.call("EcbfFilter.layout", shapes)
    case.call("EcbfFilter.lie", lambda: safety.lie)
    # (Default activations are inf: "always on".)
    case.call("EcbfFilter.family_settings", lambda: sorted(safety.family_settings))


# ================================================================== categories
def case_filter_new(case: Case, cbfgen) -> None:
    system = pick_system(case, cbfgen)
    safety, params = setup(case, cbfgen, system, typical=25, settings_p=0.4)
    if safety is Case.FAILED or params is Case.FAILED:
        return
    for _ in range(int(case.rng.integers(1, 4))):
        x, u_ref = state(case, system), nominal_input(case, system)
        update(case, safety, case.array_like(x), case.array_like(u_ref), params, t=time_of(case))
    case.call("EcbfFilter.fallback_input", safety.fallback_input, case.array_like(nominal_input(case, system)))
    inspect_filter(case, safety)


def case_params(case: Case, cbfgen) -> None:
    system = pick_system(case, cbfgen)
    if system.name == "tachyon3" and case.chance(0.4):
        from cbfgen import tachyon3 as t3

        edges, foothold_edges = tachyon3_sizes(case, t3, 8, 6)
        params = tachyon3_environment(case, t3, edges, foothold_edges)
        cap = case.call("tachyon3.capacity", t3.capacity, edges, foothold_edges)
    else:
        cap = capacity(case, system)
        params = case.call("System.params", system.params, cap)
    if params is Case.FAILED:
        return
    edit_params(case, system, params, int(case.rng.integers(1, 16)))
    if cap is Case.FAILED or not case.chance(0.5):
        return
    safety = make_filter(case, cbfgen, system, cap, {})
    if safety is Case.FAILED:
        return
    x = state(case, system)
    if case.chance(0.2):  # parameters of another system or capacity: refused, and the next cycle is fine
        update(case, safety, x, nominal_input(case, system), other_params(case, cbfgen, system))
    update(case, safety, x, nominal_input(case, system), params)
    case.call("System.rows", system.rows, x, params, time_of(case))


def case_update(case: Case, cbfgen) -> None:
    system = pick_system(case, cbfgen)
    course = None
    if system.name == "tachyon3" and case.chance(0.5):
        from cbfgen import tachyon3 as t3

        safety = case.call("tachyon3.ecbf_filter", t3.ecbf_filter, **filter_settings(case, cbfgen, system, 0.1))
        course = t3.Course(case.pick(t3.SCENARIOS))
        params = course.environment
    else:
        safety, params = setup(case, cbfgen, system, typical=4, settings_p=0.1)
    if safety is Case.FAILED or params is Case.FAILED:
        return
    for _ in range(int(case.rng.integers(1, 6))):
        x = state(case, system)
        if course is not None:
            x[0] += course.initial_state()[0]
            planned = case.call("Course.plan", course.plan, case.rng.uniform(0.0, 20.0), x)
            u_ref = nominal_input(case, system) if planned is Case.FAILED or case.chance(0.3) else planned
        else:
            u_ref = nominal_input(case, system)
        if case.hostile(0.05):
            update(case, safety, x, u_ref, other_params(case, cbfgen, system))
        update(case, safety, case.array_like(x), case.array_like(u_ref), params, t=time_of(case))
    # An ordinary cycle after whatever came before must still be finite.
    x = nominal_state(system) + case.rng.normal(0.0, 0.01, system.nx)
    update(case, safety, x, np.zeros(system.nu), params)
    inspect_filter(case, safety)
    case.call("EcbfFilter.fallback_input", safety.fallback_input, nominal_input(case, system))


def case_kernels(case: Case, cbfgen) -> None:
    kind = case.pick(("ssat", "ssat_derivatives", "ssat_margin", "rows", "rows", "rows", "dynamics", "dynamics",
                      "call_kernel", "call_kernel"))
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
    system = pick_system(case, cbfgen)
    x = state(case, system)
    if kind == "rows":
        params = case.call("System.params", system.params, capacity(case, system, 4))
        if params is Case.FAILED:
            return
        edit_params(case, system, params, int(case.rng.integers(0, 10)))
        case.call("System.rows", system.rows, case.array_like(x), params, time_of(case))
    elif kind == "dynamics":
        which = case.pick(("drift", "input_matrix", "xdot", "world_kinematics"))
        if which == "xdot":
            case.call("System.xdot", system.xdot, case.array_like(x), case.array_like(nominal_input(case, system)))
        elif which == "world_kinematics" and system.name == "tachyon3":
            from cbfgen import tachyon3 as t3

            case.call("world_kinematics", t3.world_kinematics, case.array_like(x))
        else:
            which = "drift" if which == "world_kinematics" else which
            case.call(f"System.{which}", getattr(system, which), case.array_like(x))
    else:
        call_kernel(case, cbfgen, system, x)


def call_kernel(case: Case, cbfgen, system, x: np.ndarray) -> None:
    """A generated kernel of ``system`` (or the SSAT's) with its inputs drawn by name."""
    module = system.name if not case.chance(0.2) else "ssat"
    kernels = [k for k in cbfgen.kernel_table() if k[0] == module]
    _, name, inputs, _ = case.pick(kernels)
    parts = []
    for arg, n in inputs:
        if arg == "x":
            parts.append(x)
        elif arg.startswith("r_") or arg == "rotation":
            parts.append(rotation(case, mangle=False))
        elif arg.startswith("half"):
            parts.append(half_extents(case))
        elif arg.startswith("alpha"):
            parts.append([case.scalar(5.0, 300.0, p_extreme=0.15)])
        else:
            lo, hi = PARAM_RANGES.get(arg, (-1.0, 1.0))
            parts.append(case.perturbed(case.rng.uniform(lo, hi, n), p_extreme=0.03))
    flat = np.concatenate([np.ravel(np.asarray(p, dtype=float)) for p in parts])
    if case.hostile(0.05):
        flat = case.pick((flat[:-1], np.append(flat, 0.0), flat.reshape(1, -1), np.zeros(10**6)))
    if case.hostile(0.02):
        module, name = case.pick(((module, "no_such_kernel"), ("no_such_module", name)))
    # An unknown kernel is a KeyError (a LookupError, not a ValueError like other names).
    case.call("call_kernel", cbfgen.call_kernel, module, name, case.array_like(flat), expected=(KeyError,))


def case_course(case: Case, cbfgen) -> None:
    from cbfgen import tachyon3 as t3

    case.system = "tachyon3"
    scenario = case.pick(t3.SCENARIOS) if not case.hostile(0.02) else "moon"
    if case.chance(0.3):
        u = case.rng.random()
        if u < 1 - 0.3 * case.hostility:
            max_time = float(case.rng.uniform(0.001, 0.05))
        elif u < 0.98:
            max_time = case.pick(FINITE_EXTREMES + NON_FINITE + (-1.0,))
        else:
            # whole runs, that stop when the course is done
            max_time = case.pick((30.0, t3.MAX_SIM_TIME, 1e4))
        case.call("simulate", t3.simulate, scenario, case.chance(0.7), max_time)
        return
    course = case.call("Course", t3.Course, scenario)
    if course is Case.FAILED:
        return
    x = case.call("Course.initial_state", course.initial_state, case.scalar(0.0, 1.0))
    if x is Case.FAILED:
        x = course.initial_state()
    for _ in range(int(case.rng.integers(1, 4))):
        t = case.scalar(0.0, 60.0)
        y = x + case.rng.normal(0.0, 0.02, x.size)
        if case.chance(0.2):
            y = tachyon3_state(case, t3)
        case.call("Course.plan", course.plan, t, case.array_like(y))
        case.call("Course.clearance", course.clearance, y)
        case.call("Course.finished", course.finished, y)
    case.call("Course.floor_height", course.floor_height, case.scalar(-1.0, 5.0))
    case.call("Course.nominal_body_height", lambda: course.nominal_body_height)


RUNNERS = {"filter_new": case_filter_new, "params": case_params, "update": case_update, "kernels": case_kernels,
           "course": case_course}


def draw_category(rng: np.random.Generator) -> str:
    return CATEGORIES[int(rng.choice(len(CATEGORIES), p=CATEGORY_WEIGHTS))]


def run_case(
    seed: int, index: int, verbose: bool = False, inject: tuple[str, int] | None = None
) -> tuple[str, str, str, str]:
    """``(category, system, outcome, detail)`` of case ``index`` (system "-" for the SSAT).
    ``inject`` = (kind, case) makes that case abort, hang, panic or return NaN instead: the
    harness's own check that it attributes each kind of finding
    (python/tests/test_fuzz_python.py)."""
    import cbfgen

    rng = np.random.default_rng([seed, index])
    category = draw_category(rng)
    case = Case(rng, verbose)
    try:
        if inject is not None and inject[1] == index:
            injected(case, inject[0])
        RUNNERS[category](case, cbfgen)
    except Finding as e:
        return category, case.system, e.kind, f"{e}; last call: {last_call(case)}"
    except BaseException as e:  # noqa: BLE001 - PanicException derives from BaseException
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            raise
        outcome = "panic" if type(e).__name__ == "PanicException" else "other_exception"
        return category, case.system, outcome, f"{type(e).__name__}: {e}; last call: {last_call(case)}"
    if case.typed_errors:
        return category, case.system, "typed_error", ",".join(sorted(case.typed_errors))
    return category, case.system, "ok", ""


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
        category, system, outcome, detail = run_case(seed, index, inject=inject)
        out.write(json.dumps({"case": index, "category": category, "system": system, "outcome": outcome,
                              "detail": detail}) + "\n")
        out.flush()


def campaign(seed: int, cases: int, chunk: int, case_timeout: float, progress: bool, inject: str | None):
    """Counts per category and outcome, cases per system, typed errors by type, and the
    findings."""
    counts = {c: Counter() for c in CATEGORIES}
    systems: Counter[str] = Counter()
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
                systems[result["system"]] += 1
                if result["outcome"] == "typed_error":
                    errors.update(result["detail"].split(","))
                if result["outcome"] in FINDINGS:
                    findings.append(result)
                running = None
                index = result["case"] + 1
            if child.poll() is None:
                child.kill()
                child.wait()
        if outcome is not None:  # the running case died or hung; go on after it
            category = draw_category(np.random.default_rng([seed, running]))
            counts[category][outcome] += 1
            systems["?"] += 1  # the case died before it could say
            findings.append({"case": running, "category": category, "system": "?", "outcome": outcome,
                             "detail": detail})
            index = running + 1
        if progress:
            elapsed = time.monotonic() - started
            print(f"  {index}/{cases} cases, {len(findings)} findings, {elapsed:.0f} s", file=sys.stderr, flush=True)
    return counts, systems, errors, findings


def forward_lines(stream, lines: queue.Queue) -> None:
    """Every line of ``stream`` into ``lines``, then None at its end."""
    for line in stream:
        lines.put(line)
    lines.put(None)


def report(seed: int, cases: int, counts, systems, errors, findings, shown: int) -> None:
    width = max(len(o) for o in OUTCOMES)
    print(f"cbfgen Python fuzz: {cases} cases, seed {seed}")
    print(f"{'':<{width}}" + "".join(f"{c:>13}" for c in CATEGORIES) + f"{'total':>10}")
    for outcome in OUTCOMES:
        row = [counts[c][outcome] for c in CATEGORIES]
        print(f"{outcome:<{width}}" + "".join(f"{n:>13}" for n in row) + f"{sum(row):>10}")
    print("cases by system: " + ", ".join(f"{k} {v}" for k, v in sorted(systems.items())))
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
        category, system, outcome, detail = run_case(args.seed, args.replay, verbose=True)
        print(f"case {args.replay} ({category}, {system}): {outcome} {detail}")
        return 1 if outcome in FINDINGS else 0
    counts, systems, errors, findings = campaign(args.seed, args.cases, args.chunk, args.case_timeout,
                                                 not args.quiet, args.inject)
    report(args.seed, args.cases, counts, systems, errors, findings, args.show)
    if args.summary_json:
        with open(args.summary_json, "w") as f:
            json.dump({"seed": args.seed, "cases": args.cases, "counts": {c: dict(n) for c, n in counts.items()},
                       "systems": dict(systems), "typed_errors": dict(errors),
                       "findings": findings}, f, indent=1)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
