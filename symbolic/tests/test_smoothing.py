"""The smoothing primitives keep the error bounds the certified margin is built from."""

import math

import numpy as np
import pytest
import symengine as se

from symbolic.smoothing import BOLTZMANN, LSE, SQRT, SQRT_RAMP, SQRT_UNDER, XTANH, XTANH_ABS_GAP

x, alpha, shift = se.symbols("x alpha shift")
rng = np.random.default_rng(1)


def test_xtanh_gap_constant_is_the_true_maximum():
    u = np.linspace(1e-6, 10.0, 2_000_001)
    peak = float(np.max(u * (1.0 - np.tanh(u))))
    assert peak <= XTANH_ABS_GAP < peak + 1e-9


@pytest.mark.parametrize("sabs", [XTANH, SQRT, SQRT_UNDER], ids=lambda s: s.name)
def test_smooth_abs_stays_within_its_bounds(sabs):
    expr = sabs(x, alpha)
    for _ in range(2000):
        a = float(10 ** rng.uniform(-1, 3))
        v = float(rng.normal() * 10 ** rng.uniform(-4, 1))
        s = float(expr.subs({x: v, alpha: a}))
        under = float(sabs.under(se.RealDouble(a)))
        over = float(sabs.over(se.RealDouble(a)))
        assert -over - 1e-15 <= abs(v) - s <= under + 1e-15


@pytest.mark.parametrize("smax", [LSE, BOLTZMANN], ids=lambda s: s.name)
def test_smooth_max_bounds_and_shift_invariance(smax):
    ys = list(se.symbols("y0:15"))
    expr = smax(ys, alpha, shift)
    for _ in range(300):
        vals = rng.normal(size=15) * 10 ** rng.uniform(-3, 0)
        a = float(10 ** rng.uniform(0, 3))
        subs = {**{y: float(v) for y, v in zip(ys, vals, strict=False)}, alpha: a}
        at_max = float(expr.subs({**subs, shift: float(vals.max())}))
        at_other = float(expr.subs({**subs, shift: float(vals.max()) - 0.05 / a}))
        assert at_max == pytest.approx(at_other, rel=1e-12, abs=1e-15)
        top = float(vals.max())
        if smax is LSE:
            assert top - 1e-15 <= at_max <= top + float(LSE.over(15, se.RealDouble(a))) + 1e-15
        else:
            # Never above the max, and at most (n-1)/(e alpha) below it.
            assert top - 14 / (math.e * a) - 1e-15 <= at_max <= top + 1e-15


@pytest.mark.parametrize("smax", [LSE, BOLTZMANN], ids=lambda s: s.name)
def test_every_derivative_with_respect_to_the_shift_vanishes(smax):
    """Why the emitter may treat the runtime shift as a constant when differentiating."""
    ys = list(se.symbols("y0:4"))
    expr = smax(ys, alpha, shift)
    first = se.diff(expr, shift)
    mixed = se.diff(first, ys[0])
    for _ in range(50):
        subs = {**{y: float(v) for y, v in zip(ys, rng.normal(size=4), strict=False)},
                alpha: float(rng.uniform(1, 50)), shift: float(rng.normal())}
        assert abs(float(first.subs(subs))) < 1e-12
        assert abs(float(mixed.subs(subs))) < 1e-10


@pytest.mark.parametrize("smax", [LSE, BOLTZMANN], ids=lambda s: s.name)
def test_building_with_named_intermediates_keeps_the_value(smax):
    from symbolic.kernel import Kernel

    k = Kernel("probe", "probe")
    ys = k.array_input("y", [str(i) for i in range(6)], "values")
    a = k.scalar_input("a", "sharpness")
    shift = k.runtime_max("m", ys)
    k.output_scalar("plain", smax(ys, a, shift), "without lets")
    k.output_scalar("named", smax(ys, a, shift, k.let_), "with lets")
    for _ in range(50):
        out = k.evaluate({"y": rng.normal(size=6), "a": float(rng.uniform(1, 100))})
        assert out["named"][0] == pytest.approx(out["plain"][0], rel=1e-14, abs=1e-15)


def test_sqrt_ramp_is_an_increasing_upper_bound_of_max_x_0_within_its_overshoot():
    expr = SQRT_RAMP(x, alpha)
    slope = se.diff(expr, x)
    for _ in range(2000):
        a = float(10 ** rng.uniform(-1, 4))
        v = float(rng.normal() * 10 ** rng.uniform(-5, 1))
        r = float(expr.subs({x: v, alpha: a}))
        over = float(SQRT_RAMP.over(se.RealDouble(a)))
        assert max(v, 0.0) - 1e-15 <= r <= max(v, 0.0) + over + 1e-15
        assert float(slope.subs({x: v, alpha: a})) >= 0.0
    # The overshoot bound is attained at 0.
    assert float(expr.subs({x: 0.0, alpha: 7.0})) == pytest.approx(1 / 7.0, rel=1e-15)
