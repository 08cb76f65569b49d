"""The SSAT kernels, evaluated by SymEngine, against an independent numpy formulation.

The kernels work in box A's frame with Gottschalk's index bookkeeping; the reference
below builds the 15 axes in the world frame from plain cross products. Agreement checks
the frame change, the Levi-Civita indexing and the parallel-edge term.
"""

import numpy as np
import pytest

from symbolic.families import ssat

rng = np.random.default_rng(2)
_u = np.linspace(1e-6, 10.0, 2_000_001)
XTANH_PEAK = float(np.max(_u * (1.0 - np.tanh(_u))))  # max |x| - x tanh x, independently


def random_rotation():
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


def reference_axes(pa, ra, ha, pb, rb, hb, sabs_name, alpha, alpha_rot):
    """(y_i) for the 15 axes, world frame. Projections that are exactly 0 or 1 by
    construction (an axis on its own box's faces) are taken exactly, as in the kernel."""
    if sabs_name == "xtanh":
        def sabs(v, a):
            return v * np.tanh(a * v)
    else:
        def sabs(v, a):
            return np.sqrt(v * v + 1.0 / (a * a))
    d = pb - pa
    ys = []
    for i in range(3):
        n = ra[:, i]
        ys.append(sabs(n @ d, alpha) - ha[i] - sum(hb[j] * sabs(n @ rb[:, j], alpha_rot) for j in range(3)))
    for j in range(3):
        n = rb[:, j]
        ys.append(sabs(n @ d, alpha) - sum(ha[i] * sabs(n @ ra[:, i], alpha_rot) for i in range(3)) - hb[j])
    penalty_scale = ha.sum() + hb.sum()
    for i in range(3):
        for j in range(3):
            n = np.cross(ra[:, i], rb[:, j])
            ext = sum(ha[k] * sabs(n @ ra[:, k], alpha_rot) for k in range(3) if k != i)
            ext += sum(hb[k] * sabs(n @ rb[:, k], alpha_rot) for k in range(3) if k != j)
            cos = ra[:, i] @ rb[:, j]
            ys.append(sabs(n @ d, alpha) - ext - penalty_scale * cos ** 8)
    return np.array(ys)


def reference_h(ys, smax_name, alpha):
    m = ys.max()
    w = np.exp(alpha * (ys - m))
    if smax_name == "lse":
        return m + np.log(w.sum()) / alpha
    return (ys * w).sum() / w.sum()


@pytest.mark.parametrize("variant", ssat.VARIANTS, ids=lambda v: f"{v[0].name}_{v[1].name}")
def test_value_kernel_matches_world_frame_reference(variant):
    smax, sabs = variant
    kernel = ssat.value_kernel(smax, sabs)
    for _ in range(150):
        pa, pb = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
        ra, rb = random_rotation(), random_rotation()
        ha, hb = rng.uniform(0.05, 0.6, 3), rng.uniform(0.05, 0.6, 3)
        alpha, alpha_rot = rng.uniform(5, 300), rng.uniform(5, 300)
        got = kernel.evaluate({"p_a": pa, "r_a": ra.flatten(), "half_a": ha, "p_b": pb,
                               "r_b": rb.flatten(), "half_b": hb, "alpha": alpha,
                               "alpha_rot": alpha_rot})["h"][0]
        ys = reference_axes(pa, ra, ha, pb, rb, hb, sabs.name, alpha, alpha_rot)
        want = reference_h(ys, smax.name, alpha)
        assert got == pytest.approx(want, rel=1e-11, abs=1e-12)


@pytest.mark.parametrize("variant", ssat.VARIANTS, ids=lambda v: f"{v[0].name}_{v[1].name}")
def test_margin_kernel_is_the_worst_axis_bound(variant):
    smax, sabs = variant
    kernel = ssat.margin_kernel(smax, sabs)
    for _ in range(50):
        ha, hb = rng.uniform(0.05, 0.6, 3), rng.uniform(0.05, 0.6, 3)
        alpha, alpha_rot = rng.uniform(5, 300), rng.uniform(5, 300)
        got = kernel.evaluate({"half_a": ha, "half_b": hb, "alpha": alpha, "alpha_rot": alpha_rot})["margin"][0]
        centre = 1 / alpha if sabs.name == "sqrt" else 0.0
        per_unit = 0.0 if sabs.name == "sqrt" else XTANH_PEAK / alpha_rot
        cross = max(ha.sum() - ha[i] + hb.sum() - hb[j] for i in range(3) for j in range(3))
        worst = centre + per_unit * max(hb.sum(), ha.sum(), cross)
        lse = np.log(15) / alpha if smax.name == "lse" else 0.0
        assert got == pytest.approx(lse + worst, rel=1e-9)
