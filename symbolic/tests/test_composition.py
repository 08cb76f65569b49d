"""Composed collision rows (``compose=True``) against the same rows differentiated whole.

Every member of a composed family of the built-in systems (the Panda's obstacle and
self-collision rows, ANYmal's self-collision rows) is called in Rust as the module runs
it: pose kernels, the family's chain kernel and the contraction with the poses' input
columns (``cbfgen.call_kernel``). Its truth is the unrolled definition of the same row
(``define(..., unrolled=True)``: h through the kinematics, differentiated by the Lie
engine as a non-composed family is), evaluated by SymEngine in double precision and,
where the two differ by more than the tolerance, in 256-bit arithmetic. Every output must
be within 1e-12 of the truth, relative to the larger of the truth and its
typical size: for h and each L_f^k h, its size over the member's samples (a value that
cancels to nothing carries the rounding of the terms it cancels); for an L_g L_f h entry,
the size of its row, the vector the QP reads.

States: random ones (the arm inside its limits; ANYmal's joints in [-2, 2] as the
cross-check draws them), states where the boxes overlap, and states where they touch
(h = 0 to 1e-9, by bisection between a state apart and one overlapping; for an obstacle,
the obstacle slid along a line through the link box).

The generator-side checks (mismatched members, boxes that are neither moving nor fixed,
names that collide) are tested at the end on small specs.
"""

from __future__ import annotations

import functools
import os
import zlib

import numpy as np
import pytest

from symbolic.generate import all_kernels, builtin_systems
from symbolic.spec import SpecError

from .symengine_reference import SymEngineReference
from .test_rust_vs_symengine import constant, random_rotation, rust_call

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

TOLERANCE = 1e-12
TOUCHING = 1e-9
RANDOM_STATES = 2


@functools.cache
def composed_members() -> list[tuple[str, str, bool]]:
    """(module, member kernel, has parameters) of every composed family's members."""
    return [(d.name, plan.kernel, bool(f.params)) for d in builtin_systems(unrolled=True) for f in d.families
            for plan in f.composed]


def kernel(module: str, name: str):
    return next(k for k in all_kernels()[module] if k.name == name)


def random_state(module: str, rng: np.random.Generator) -> np.ndarray:
    if module == "panda":
        q_min, q_max = np.array(constant("q_min")), np.array(constant("q_max"))
        qd_max = np.array(constant("qd_max"))
        return np.concatenate([rng.uniform(q_min, q_max), rng.uniform(-qd_max, qd_max)])
    n = len(kernel(module, "drift").inputs[0].symbols)
    return rng.uniform(-2, 2, n)


def bisect(h, apart: dict, overlapping: dict, key: str) -> dict:
    """Inputs between ``apart`` (h > 0) and ``overlapping`` (h < 0), moving ``key``, where
    |h| <= TOUCHING."""
    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        v = {**apart, key: (1 - mid) * apart[key] + mid * overlapping[key]}
        value = h(v)
        if abs(value) <= TOUCHING:
            return v
        lo, hi = (mid, hi) if value > 0 else (lo, mid)
    raise AssertionError(f"no touching pose between the two (last h {value})")


def samples(module: str, name: str, with_params: bool, rng: np.random.Generator) -> tuple[list[dict], int]:
    """Random inputs, overlapping ones and touching ones; and how many of them overlap or touch."""
    call = rust_call(module, kernel(module, name))

    def h(v):
        return call(v)["lie"][0]

    if with_params:  # an obstacle box around the link box, then slid off it
        x = random_state(module, rng)
        # The link box's centre: the obstacle overlaps it when centred there.
        link = constant("link_names").index(name.removeprefix("obstacle_"))
        center = np.asarray(cbfgen.call_kernel(module, "link_boxes", x))[3 * link:3 * link + 3]
        base = {"x": x, "rotation": random_rotation(rng).ravel(), "half": rng.uniform(0.02, 0.2, 3)}
        inside = {**base, "center": center}
        direction = rng.normal(size=3)
        outside = {**base, "center": center + 2.0 * direction / np.linalg.norm(direction)}
        assert h(inside) < 0 < h(outside), name
        far = [{**base, "center": center + rng.uniform(-0.6, 0.6, 3)} for _ in range(RANDOM_STATES)]
        return far + [inside, bisect(h, outside, inside, "center")], 2
    states = [{"x": random_state(module, rng)} for _ in range(8 * RANDOM_STATES)]
    values = [h(v) for v in states]
    chosen = states[:RANDOM_STATES]
    apart = [v for v, value in zip(states, values, strict=True) if value > 0]
    overlapping = [v for v, value in zip(states, values, strict=True) if value < 0]
    if apart and overlapping:
        chosen += [overlapping[0], bisect(h, apart[0], overlapping[0], "x")]
        return chosen, 2
    return chosen, 0


def assert_rows_equal(module: str, name: str, inputs: list[dict]) -> None:
    """The module's ``name`` (as Rust runs it) against its unrolled definition in SymEngine,
    to TOLERANCE of each output's scale (module doc)."""
    unrolled = kernel(module, name)
    reference = SymEngineReference(unrolled)
    rust = rust_call(module, unrolled)
    refs = reference.batch(inputs)
    gots = [rust(v) for v in inputs]
    truths: dict[int, dict] = {}
    for out, ref in refs.items():
        got = np.array([g[out] for g in gots])
        # An input column is an entry of the row the QP reads as one vector: its scale is
        # the row's size. Each of h, L_f h, ... is its own quantity, in its own units.
        typical = np.linalg.norm(ref, axis=1, keepdims=True) if out == "lg_lf" else np.sqrt(np.mean(ref ** 2, axis=0))
        scale = np.maximum(np.maximum(np.abs(ref), typical), np.finfo(float).tiny)
        # SymEngine's double evaluation of the unrolled row first; where the two differ by
        # more than the tolerance, the 256-bit value decides (both doubles round).
        for i in sorted({int(i) for i in np.argwhere(np.abs(got - ref) > TOLERANCE * scale)[:, 0]}):
            if i not in truths:
                truths[i] = reference.high_precision(inputs[i])
            worst = np.max(np.abs(got[i] - truths[i][out]) / scale[i])
            assert worst <= TOLERANCE, f"{name}.{out}, sample {i}: off by {worst:.2e} of its scale"


@pytest.mark.parametrize("module, name, with_params", composed_members())
def test_composed_row_is_the_unrolled_row(module, name, with_params):
    rng = np.random.default_rng(zlib.crc32(f"composed.{module}.{name}".encode()))
    inputs, _ = samples(module, name, with_params, rng)
    assert_rows_equal(module, name, inputs)


@functools.cache
def framed_members() -> list[tuple[str, str]]:
    """(module, kernel) of every member computed on its frame's jet, and of its bound."""
    return [(d.name, p.kernel) for d in builtin_systems(unrolled=True) for f in d.families for plan in f.framed
            if plan for p in (plan, plan.bound) if p]


def test_members_are_computed_on_their_frames():
    # The Panda-as-spheres' spheres share their links' frames: every member on a link with
    # another sphere of its family, and its bound, is computed on that link's jet; a sphere
    # alone on its link (link1's in sphere_obstacle, link2's in table) is smaller whole.
    members = {name for module, name in framed_members() if module == "panda_spheres"}
    (spheres,) = [d for d in builtin_systems() if d.name == "panda_spheres"]
    expected = set()
    for f in spheres.families:
        links = [label.rsplit("_", 1)[0] for label in f.members]
        for link, k, bound in zip(links, f.kernels, f.bounds, strict=True):
            if links.count(link) > 1:
                expected |= {k.name, bound.name}
    assert members == expected and len(expected) == 2 * (19 + 17)


@pytest.mark.parametrize("module, name", framed_members())
def test_a_member_on_its_frame_is_the_unrolled_member(module, name):
    # Random states and parameters: a parameter named radius or half is a positive size,
    # any other a few units either way (the rows are smooth in them).
    rng = np.random.default_rng(zlib.crc32(f"framed.{module}.{name}".encode()))
    inputs = []
    for _ in range(6):
        v = {"x": random_state(module, rng)}
        for inp in kernel(module, name).inputs[1:]:
            n = len(inp.symbols)
            low, high = (0.01, 0.3) if inp.name in ("radius", "half") else (-1.0, 1.0)
            v[inp.name] = rng.uniform(low, high, n) if inp.is_array else rng.uniform(low, high)
        inputs.append(v)
    assert_rows_equal(module, name, inputs)


def test_touching_and_overlapping_poses_are_among_the_samples():
    # The bisection needs both signs among a member's random states: most self-collision
    # pairs of an arm that stays inside its limits never meet, so count the members that did.
    touched = {}
    for module, name, with_params in composed_members():
        rng = np.random.default_rng(zlib.crc32(f"composed.{module}.{name}".encode()))
        touched[name] = samples(module, name, with_params, rng)[1]
    met = [n for n, c in touched.items() if c]
    assert len(met) >= 20, f"only {met} were sampled touching and overlapping"


def test_the_arms_poses_are_assembled_along_its_kinematic_tree():
    # One node per joint, shared by every box below it; a box fixed in a link (the hand,
    # past two fixed joints) is placed in that link's frame by numbers, with no kernel.
    (panda,) = [d for d in builtin_systems() if d.name == "panda"]
    plans = {p.name: p for p in panda.poses}
    joints = tuple(f"frame_panda_link{i}" for i in range(1, 8))
    assert plans["pose_link7"].steps == joints
    assert plans["pose_hand"].steps == joints and plans["pose_hand"].placement is not None
    assert plans["pose_hand_value"].steps == tuple(f"{j}_value" for j in joints)
    assert set(panda.pose_names) == set(plans)
    assert sorted(k.name for k in panda.jets) == sorted([*joints, *(f"{j}_value" for j in joints)])


# ------------------------------------------------------------- generator checks
def arm(h, **family):
    """A planar two-link arm on joint accelerations, with one family ``h``."""
    import symengine as se

    from symbolic import primitives as prim
    from symbolic.spec import System

    s = System("two_link")
    x = s.states(["q1", "q2", "qd1", "qd2"])
    s.inputs(["qdd1", "qdd2"], limits=[(-1.0, 1.0)] * 2)
    s.dynamics(f=[x[2], x[3], 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])

    def link(p, angle, length):
        rot = prim.rot_z(angle)
        center = [length * se.cos(angle), length * se.sin(angle), 0]
        return prim.Box(center, rot, [length, 0.05, 0.05])

    s.family("pair", lambda p: h(p, link, x), **family)
    return s


def test_a_composed_family_needs_one_primitive_call():
    from symbolic import primitives as prim
    from symbolic.codegen.definition import define

    def doubled(p, link, x):
        return 2 * prim.ssat(p, link(p, x[0], 0.5), link(p, x[1], 0.3))

    with pytest.raises(SpecError, match="one composable primitive call"):
        define(arm(doubled, compose=True))


def test_a_moving_box_may_not_depend_on_parameters():
    from symbolic import primitives as prim
    from symbolic.codegen.definition import define

    def scaled(p, link, x):
        return prim.ssat(p, link(p, x[0], 0.5), link(p, x[1] * p.k, 0.3))

    with pytest.raises(SpecError, match="depends on parameters"):
        define(arm(scaled, compose=True, params={"k": ()}, count=1))


def test_one_name_for_two_placements_is_refused():
    from symbolic import primitives as prim
    from symbolic.codegen.definition import define

    def named(p, link, x):
        return prim.ssat(p, link(p, x[0], 0.5), link(p, x[1], 0.3), names=("link", "link"))

    with pytest.raises(SpecError, match="already places another box"):
        define(arm(named, compose=True))


def test_composed_and_unrolled_rows_agree_on_a_small_arm():
    # Two moving boxes (the chain with both poses moving): the composed definition's
    # degree and columns are the unrolled one's (define checks), and generation emits it.
    from symbolic import primitives as prim
    from symbolic.codegen.backends.rust.system_module import emit_system
    from symbolic.codegen.definition import define

    def pair(p, link, x):
        return prim.ssat(p, link(p, x[0], 0.5), link(p, x[1], 0.3), names=("upper", "lower"))

    spec = arm(pair, compose=True)
    definition = define(spec, unrolled=True)
    (family,) = definition.families
    # The default smooth SAT at degree 2 is the core's chain: the system emits none.
    assert family.chains == () and {p.chain for p in family.composed} == {"ssat_chain2"}
    assert {p.library for p in family.composed} == {"ssat"}
    assert [k.name for k in definition.jets] == ["pose_upper", "pose_lower"]
    assert family.kernels[0].outputs[0].exprs[0] != 0  # the unrolled row, not a signature
    text = emit_system(define(arm(pair, compose=True)), "cbfgen")
    assert "pub fn pair<S: " in text and "accumulate_columns(&grad_a" in text and "accumulate_columns(&grad_b" in text
    assert "cbfgen::generated::ssat::ssat_chain2(" in text and "fn pair_chain" not in text


def test_a_smoothing_the_core_does_not_ship_gets_the_systems_own_chain_with_the_sharpness_as_arguments():
    from symbolic import primitives as prim
    from symbolic.codegen.backends.rust.system_module import emit_system
    from symbolic.codegen.definition import define

    def pair(p, link, x):
        return prim.ssat(p, link(p, x[0], 0.5), link(p, x[1], 0.3), alpha=50.0, alpha_rot=20.0, smax=prim.BOLTZMANN,
                         names=("upper", "lower"))

    (family,) = define(arm(pair, compose=True)).families
    assert [k.name for k in family.chains] == ["pair_chain"]
    assert [i.name for i in family.chains[0].inputs][-2:] == ["alpha", "alpha_rot"]
    assert [(p.library, p.options) for p in family.composed] == [(None, (50.0, 20.0))]
    text = emit_system(define(arm(pair, compose=True)), "cbfgen")
    assert "pub fn pair_chain<S: " in text and "pair_chain(&pose_a.0, &pose_a.1, &pose_b.0, &pose_b.1, &[" in text
