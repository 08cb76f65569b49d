"""Every generated kernel, called in Rust through the `cbfgen` Python module, against its
symbolic definition evaluated numerically by SymEngine (see symengine_reference.py).

The kernels are the generator's own list (`symbolic.generate.all_kernels`), and Rust is
reached through the uniform kernel table the generator emits (`cbfgen.call_kernel`), so a
new system is cross-checked without a line of test code. Inputs are uniform in [-2, 2]
unless a kernel's domain needs better (the Tachyon 3, SSAT and sphere-box samplers below:
proper rotations, states around the standing posture, edges near the body).

For each kernel, 500 random inputs. Every output value must agree with SymEngine's
double-precision evaluation to a relative 1e-9. A value that does not is looked at
again in 256-bit arithmetic (SymEngine's MPFR evaluation of the same expressions):

* if SymEngine's own double result is within 1e-12 of that truth, the value is
  well-conditioned and the Rust kernel is wrong: the test fails;
* otherwise the value comes out of cancellation (SSAT Hessians where one axis
  dominates: a difference of O(alpha) terms that nearly vanishes). Both double
  evaluations are then rounding-limited, in different ways, and Rust must be within
  1e-9 of the truth or within 1e-10 of that output's typical size (RMS over the
  samples). The worst seen is 1.6e-11, in the Boltzmann Hessians.

A value within 1e-12 of its whole output's size (RMS over samples and values) of
SymEngine's needs no second look: an entry that cancels to nothing, as the off-diagonals
of ANYmal's mass matrix between the trunk's linear axes do (sums of rotation products
that are 0 only through sin^2 + cos^2 = 1), carries the rounding of the terms it
cancels, which are the size of its neighbours.

At most half of an output's values may need the second look: a drifted kernel fails
fast, with a count. A value whose truth is exactly zero must be zero to 1e-12 of that
output's typical size.

Run by `scripts/cbf test`, which builds and installs the module first and sets
CBFGEN_REQUIRE_BINDINGS, so a missing module fails instead of skipping.
"""

from __future__ import annotations

import ast
import functools
import os
import zlib
from collections.abc import Callable

import numpy as np
import pytest

from symbolic.families import sphere_box as sphere_box_family
from symbolic.families import ssat as ssat_family
from symbolic.generate import all_kernels, builtin_systems
from symbolic.kernel import Kernel

from .symengine_reference import SymEngineReference

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

SAMPLES = 500
RELATIVE = 1e-9
WELL_CONDITIONED = 1e-12
CANCELLING = 1e-10
ROUNDING_OF_OUTPUT = 1e-12
MAX_SECOND_LOOKS = 0.5

Inputs = dict[str, np.ndarray]
# inputs -> {output name: flat values in the kernel's output layout}
RustCall = Callable[[Inputs], dict[str, np.ndarray]]


KERNELS: dict[tuple[str, str], Kernel] = {(module, k.name): k for module, ks in all_kernels().items() for k in ks}


SYSTEM_CONSTANTS = {c.name: c.value for d in builtin_systems() for c in d.constants}


@functools.cache  # it scans every kernel, and the Panda sampler asks three times a sample
def constant(name: str):
    """A kernel's constant, or a built-in system's (``hip_positions``)."""
    for k in KERNELS.values():
        for c in k.constants:
            if c.name == name:
                return ast.literal_eval(c.value)
    return SYSTEM_CONSTANTS[name]


# ----------------------------------------------------------------- random inputs
def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


def random_state(rng: np.random.Generator) -> np.ndarray:
    """Around the standard posture: any origin pose and speed, body and toes displaced
    and moving (the same ranges as the Rust finite-difference test)."""
    x = np.asarray(cbfgen.tachyon3.standard_posture())
    x[0:2] = rng.uniform(-2, 2, 2)
    x[2] = rng.uniform(-0.2, 0.2)
    x[3] = rng.uniform(-3, 3)
    x[4] = rng.uniform(-1, 1)
    x[5] = rng.uniform(-0.5, 0.5)
    x[6] = rng.uniform(-0.1, 0.1)
    x[7] = rng.uniform(0.2, 0.5)
    x[8] = rng.uniform(-0.3, 0.3)
    x[9:12] = rng.uniform(-0.5, 0.5, 3)
    hips = SYSTEM_CONSTANTS["hip_positions"]
    for leg in range(6):
        t = 12 + 4 * leg
        x[t] = x[6] + hips[leg][0] + rng.uniform(-0.3, 0.3)
        x[t + 1] = rng.uniform(-0.05, 0.15)
        x[t + 2:t + 4] = rng.uniform(-0.5, 0.5, 2)
    return x


def random_edge_near(rng: np.random.Generator, point: np.ndarray, spread: float) -> Inputs:
    rot = random_rotation(rng)
    if rng.random() < 0.5:  # stair edges are yaw-only
        a = rng.uniform(-3, 3)
        rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    return {"center": point + rng.uniform(-spread, spread, 3),
            "rotation": rot.ravel(), "half": rng.uniform(0.02, 0.5, 3)}


def ssat_inputs(rng: np.random.Generator) -> Inputs:
    return {"p_a": rng.uniform(-1, 1, 3), "r_a": random_rotation(rng).ravel(),
            "half_a": rng.uniform(0.05, 0.6, 3), "p_b": rng.uniform(-1, 1, 3),
            "r_b": random_rotation(rng).ravel(), "half_b": rng.uniform(0.05, 0.6, 3),
            "alpha": rng.uniform(5, 300), "alpha_rot": rng.uniform(5, 300)}


def sphere_box_inputs(rng: np.random.Generator) -> Inputs:
    """A box of mixed proportions and a sphere centre around it, from a few smoothing
    lengths off its surface to well outside, with alpha from blunt to sharp."""
    half = 10 ** rng.uniform(-2.5, 0, 3)
    center = rng.uniform(-1, 1, 3)
    return {"point": center + rng.uniform(-1.5, 1.5, 3) * (half + 0.05), "center": center,
            "rotation": random_rotation(rng).ravel(), "half": half, "radius": rng.uniform(0, 0.3),
            "alpha": 10 ** rng.uniform(0.5, 3.5)}


def family_inputs(family: str, leg: int, rng: np.random.Generator) -> Inputs:
    x = random_state(rng)
    v: Inputs = {"x": x}
    if family == "body_edge":
        center, _, _ = cbfgen.tachyon3.world_kinematics(x)
        v.update(random_edge_near(rng, np.asarray(center), 0.8))
    elif family == "toe_edge":
        _, _, toes = cbfgen.tachyon3.world_kinematics(x)
        v.update(random_edge_near(rng, np.asarray(toes)[leg], 0.4))
    elif family == "foothold":
        a = rng.uniform(-np.pi, np.pi)
        v.update(normal=np.array([np.cos(a), np.sin(a)]) * rng.uniform(0.5, 2), offset=rng.uniform(-1, 1))
    elif family == "foothold_pull":
        a = rng.uniform(-np.pi, np.pi)
        v.update(target=rng.uniform(-1, 1, 2), direction=np.array([np.cos(a), np.sin(a)]))
    elif family == "foot_height":
        v.update(floor_z=rng.uniform(-0.2, 0.2))
    elif family == "stability":
        v.update(a=rng.choice([-1.0, 1.0]), b=rng.uniform(-0.5, 0.5))
    return v


def sine_barrier_inputs(rng: np.random.Generator) -> Inputs:
    return {"x": rng.uniform(-3, 3, 2), "t": rng.uniform(0, 20), "amplitude": rng.uniform(0, 2),
            "omega": rng.uniform(0.1, 5), "offset": rng.uniform(-1, 1)}


def panda_inputs(rng: np.random.Generator) -> Inputs:
    """The arm inside its joint and rate limits, and an obstacle box (a proper rotation)
    within reach: as the closed loop evaluates it. Uniform numbers would make rotation
    matrices of any size and negative extents, where L_f^2 h is a near-cancelling sum of
    terms of 1e4-1e5."""
    q_min, q_max = np.array(constant("q_min")), np.array(constant("q_max"))
    qd_max = np.array(constant("qd_max"))
    x = np.concatenate([rng.uniform(q_min, q_max), rng.uniform(-qd_max, qd_max)])
    return {"x": x, "center": rng.uniform([-0.8, -0.8, -0.2], [0.8, 0.8, 1.0]),
            "rotation": random_rotation(rng).ravel(), "half": rng.uniform(0.02, 0.6, 3)}


def chain_inputs(kernel: Kernel) -> Callable[[np.random.Generator], Inputs]:
    """A composed family's chain kernel: boxes of proper rotations, within a metre of
    each other (touching, overlapping and apart), moving at up to a few m/s and rad/s."""
    def draw(rng: np.random.Generator) -> Inputs:
        v: Inputs = {}
        for inp in kernel.inputs:
            if inp.name.startswith("pose_"):
                v[inp.name] = np.concatenate([rng.uniform(-0.5, 0.5, 3), random_rotation(rng).ravel()])
            elif inp.name.startswith("half_"):
                v[inp.name] = rng.uniform(0.02, 0.4, 3)
            elif inp.name in ("alpha", "alpha_rot"):  # the core's chains take the sharpness
                v[inp.name] = rng.uniform(5, 300)
            else:  # rates_*: derivatives of the pose
                v[inp.name] = rng.uniform(-3, 3, len(inp.symbols))
        return v
    return draw


def frame_inputs(kernel: Kernel, state: Callable[[np.random.Generator], np.ndarray] | None):
    """A node of a pose's path along the kinematic tree: the state (``state``, else uniform)
    and its frame's jet: a proper rotation within a metre of the origin, moving at up to a
    few m/s and rad/s, input columns of a few units."""
    def draw(rng: np.random.Generator) -> Inputs:
        v: Inputs = {}
        for inp in kernel.inputs:
            if inp.name == "x":
                v["x"] = state(rng) if state else rng.uniform(-2, 2, len(inp.symbols))
            elif inp.name == "frame":
                v["frame"] = np.concatenate([rng.uniform(-0.5, 0.5, 3), random_rotation(rng).ravel()])
            else:  # frame_rates, frame_lg
                v[inp.name] = rng.uniform(-3, 3, len(inp.symbols))
        return v
    return draw


def domain_samplers() -> dict[tuple[str, str], Callable[[np.random.Generator], Inputs]]:
    """Kernels whose inputs need a domain better than uniform numbers."""
    out = {}
    for smax, sabs in ssat_family.VARIANTS:
        variant = f"{smax.name}_{sabs.name}"
        for suffix in ("", "_derivatives", "_margin"):
            out[("ssat", f"ssat_{variant}{suffix}")] = ssat_inputs
    for kernel in sphere_box_family.kernels():
        out[("sphere_box", kernel.name)] = sphere_box_inputs
    state_only = lambda rng: {"x": random_state(rng)}  # noqa: E731
    for name in ("drift", "input_matrix", "input_matrix_nonzeros", "world_kinematics"):
        out[("tachyon3", name)] = state_only
    out[("tachyon3", "body_edge")] = lambda rng: family_inputs("body_edge", 0, rng)
    # One kernel for every toe: the edge near a random toe, so each row is exercised.
    out[("tachyon3", "toe_edge")] = lambda rng: family_inputs("toe_edge", int(rng.integers(6)), rng)
    for family in ("joint_limits", "foothold", "foothold_pull", "foot_height", "stability"):
        for leg, leg_name in enumerate(constant("leg_names")):
            out[("tachyon3", f"{family}_{leg_name.lower()}")] = lambda rng, f=family, at=leg: family_inputs(f, at, rng)
    out[("double_integrator", "sine_barrier")] = sine_barrier_inputs
    for kernel in all_kernels()["panda"]:
        out[("panda", kernel.name)] = panda_inputs
    for module, kernels in all_kernels().items():
        for kernel in kernels:
            if any(i.name == "pose_a" for i in kernel.inputs):
                out[(module, kernel.name)] = chain_inputs(kernel)
            elif any(i.name == "frame" for i in kernel.inputs):
                arm = module in ("panda", "panda_spheres")
                out[(module, kernel.name)] = frame_inputs(kernel, (lambda rng: panda_inputs(rng)["x"]) if arm else None)
    return out


SAMPLERS = domain_samplers()


def uniform_inputs(kernel: Kernel) -> Callable[[np.random.Generator], Inputs]:
    def draw(rng: np.random.Generator) -> Inputs:
        return {i.name: rng.uniform(-2, 2, len(i.symbols)) if i.is_array else rng.uniform(-2, 2)
                for i in kernel.inputs}
    return draw


def rust_call(module: str, kernel: Kernel) -> RustCall:
    """The kernel through the generated table: inputs flattened in declaration order, the
    flat result split by the table's own output lengths."""
    table = {(m, n): (ins, outs) for m, n, ins, outs in cbfgen.kernel_table()}
    inputs, outputs = table[(module, kernel.name)]
    assert [n for n, _ in inputs] == [i.name for i in kernel.inputs], f"{kernel.name}: input order"

    def call(v: Inputs) -> dict[str, np.ndarray]:
        flat = np.concatenate([np.atleast_1d(np.asarray(v[name], dtype=float)).ravel() for name, _ in inputs])
        result = cbfgen.call_kernel(module, kernel.name, flat)
        ends = np.cumsum([n for _, n in outputs])
        return {name: part for (name, _), part in zip(outputs, np.split(result, ends[:-1]), strict=True)}
    return call


def test_the_generated_table_is_the_generators_list():
    # Systems loaded with cbfgen.load in the same process list their kernels too.
    modules = {m for m, _ in KERNELS}
    assert sorted((m, n) for m, n, _, _ in cbfgen.kernel_table() if m in modules) == sorted(KERNELS)


def compare(name: str, ref: np.ndarray, got: np.ndarray, truth_of: Callable[[int], np.ndarray]) -> None:
    """Assert the module docstring's rule on (samples x values) arrays; ``truth_of(i)``
    gives sample i's values in high precision."""
    err = np.abs(got - ref)
    suspects = np.argwhere(err > np.maximum(RELATIVE * np.abs(ref), ROUNDING_OF_OUTPUT * np.sqrt(np.mean(ref ** 2))))
    nonzero = max(1, np.count_nonzero(ref))
    assert len(suspects) <= MAX_SECOND_LOOKS * nonzero, (
        f"{name}: {len(suspects)} of {nonzero} values differ by more than {RELATIVE:g} relative")
    typical = np.sqrt(np.mean(ref ** 2, axis=0))
    truths: dict[int, np.ndarray] = {}
    for i, j in suspects:
        if i not in truths:
            truths[i] = truth_of(i)
        truth = truths[i][j]
        ref_err, rust_err = abs(ref[i, j] - truth), abs(got[i, j] - truth)
        where = f"{name}: sample {i}, value {j}: rust {got[i, j]!r}, symengine {ref[i, j]!r}, truth {truth!r}"
        if truth == 0.0:
            assert rust_err <= 1e-12 * typical[j], where
        elif ref_err <= WELL_CONDITIONED * abs(truth):
            pytest.fail(f"{where}: well-conditioned, and rust is off by {rust_err / abs(truth):.2e} relative")
        else:
            assert rust_err <= max(RELATIVE * abs(truth), CANCELLING * typical[j]), where


@pytest.mark.parametrize("module, name", sorted(KERNELS))
def test_rust_kernel_matches_symengine(module, name):
    kernel = KERNELS[(module, name)]
    draw = SAMPLERS.get((module, name)) or uniform_inputs(kernel)
    rust = rust_call(module, kernel)
    reference = SymEngineReference(kernel)
    rng = np.random.default_rng(zlib.crc32(f"{module}.{name}".encode()))
    inputs = [draw(rng) for _ in range(SAMPLES)]
    refs = reference.batch(inputs)
    gots: dict[str, list[np.ndarray]] = {}
    for v in inputs:
        for out, vals in rust(v).items():
            gots.setdefault(out, []).append(np.asarray(vals, dtype=float))
    assert sorted(gots) == sorted(refs), f"{name}: outputs differ"
    for out in refs:
        compare(f"{name}.{out}", refs[out], np.array(gots[out]),
                lambda i, o=out: reference.high_precision(inputs[i])[o])
