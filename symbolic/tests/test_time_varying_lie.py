"""Time-varying barriers h(x, t) in the Lie engine, against two independent truths:

* SymEngine differentiation of the fully substituted h (every let expanded) along the
  augmented field (t' = 1, x' = f + g u), done here from scratch;
* a central finite difference along the augmented flow (RK4 in x, t advancing with it).
"""

import numpy as np
import pytest
import symengine as se

from symbolic.kernel import Kernel, Let
from symbolic.lie import LieEngine

P, V, TH, T = se.symbols("x_p x_v x_th t")
X = [P, V, TH]
# A nonlinear drift, the input on v only: positions have relative degree 2.
F = [V * se.cos(TH), -se.sin(P), se.Rational(3, 10) * V]
G = [[se.Integer(0)], [se.Integer(1)], [se.Integer(0)]]


def build():
    k = Kernel("probe", "probe")
    k.array_input("x", ["p", "v", "th"], "state")
    t = k.scalar_input("t", "time")
    eng = LieEngine(k, X, F, G, time=t)
    # Time inside lets, in a let of a let, and directly in h.
    wave = eng.let_("wave", se.sin(2 * t) * TH)
    gap = eng.let_("gap", se.exp(se.Rational(1, 10) * t) * (P - wave))
    rows = {
        "position": eng.row(gap * gap + se.cos(t) * P - se.Rational(1, 5), "position"),
        "speed": eng.row(gap + se.cos(3 * t) * V, "speed"),
    }
    return k, rows


def expand(kernel, e):
    """e with every let replaced by its definition, recursively."""
    subs = {}
    for d in kernel.definitions:
        assert isinstance(d, Let)
        subs[d.symbol] = d.expr.xreplace(subs)
    return e.xreplace(subs)


def augmented_lf(e):
    return se.diff(e, T) + se.Add(*[se.diff(e, x) * f for x, f in zip(X, F, strict=False)])


def lg(e):
    return se.Add(*[se.diff(e, x) * g[0] for x, g in zip(X, G, strict=False)])


@pytest.fixture(scope="module")
def probe():
    return build()


def points(n=50):
    rng = np.random.default_rng(7)
    return [rng.uniform(-2, 2, 4) for _ in range(n)]


def value(e, point):
    return float(e.xreplace(dict(zip(X + [T], [se.RealDouble(v) for v in point], strict=False))))


def test_degrees_are_found_with_time(probe):
    _, rows = probe
    assert rows["position"].degree == 2 and rows["speed"].degree == 1


@pytest.mark.parametrize("name", ["position", "speed"])
def test_time_varying_lie_derivatives_match_symengine_on_the_substituted_h(probe, name):
    kernel, rows = probe
    row = rows[name]
    truth = [expand(kernel, row.lf[0])]
    for _ in range(row.degree):
        truth.append(augmented_lf(truth[-1]))
    truth_lg = lg(truth[row.degree - 1])
    for point in points():
        for k in range(row.degree + 1):
            got, want = value(expand(kernel, row.lf[k]), point), value(truth[k], point)
            assert got == pytest.approx(want, rel=1e-12, abs=1e-12), (name, k, point)
        got = value(expand(kernel, row.lg[0]), point)
        assert got == pytest.approx(value(truth_lg, point), rel=1e-12, abs=1e-12)


def _flow(point, tau, steps=8):
    """RK4 of the augmented drift (u = 0) from ``point`` = (p, v, th, t) for time tau."""
    f = se.Lambdify(X + [T], F)

    def rate(z):
        return np.concatenate([np.asarray(f(*z), dtype=float).ravel(), [1.0]])

    z, h = np.array(point, dtype=float), tau / steps
    for _ in range(steps):
        k1 = rate(z)
        k2 = rate(z + h / 2 * k1)
        k3 = rate(z + h / 2 * k2)
        k4 = rate(z + h * k3)
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return z


@pytest.mark.parametrize("name", ["position", "speed"])
def test_time_varying_lie_derivatives_match_a_finite_difference_along_the_flow(probe, name):
    kernel, rows = probe
    row = rows[name]
    eps = 1e-4
    for point in points(20):
        before, after = _flow(point, -eps), _flow(point, eps)
        for k in range(row.degree):  # d/dtau L_f^k h along the flow = L_f^(k+1) h (u = 0)
            e = expand(kernel, row.lf[k])
            fd = (value(e, after) - value(e, before)) / (2 * eps)
            want = value(expand(kernel, row.lf[k + 1]), point)
            assert fd == pytest.approx(want, rel=1e-6, abs=1e-6), (name, k, point)


def test_a_time_only_let_has_the_clock_rate():
    k = Kernel("clock", "clock")
    k.array_input("x", ["p", "v", "th"], "state")
    t = k.scalar_input("t", "time")
    eng = LieEngine(k, X, F, G, time=t)
    s = eng.let_("s", se.sin(t))
    row = eng.row(P - s, "above sin t")
    assert row.degree == 2
    point = [0.3, -0.7, 0.2, 1.1]
    assert value(expand(k, row.lf[1]), point) == pytest.approx(-0.7 * np.cos(0.2) - np.cos(1.1), rel=1e-14)
    # Without the time symbol, t is a parameter: no dh/dt term.
    k2 = Kernel("frozen", "frozen")
    k2.array_input("x", ["p", "v", "th"], "state")
    t2 = k2.scalar_input("t", "time")
    frozen = LieEngine(k2, X, F, G)
    s2 = frozen.let_("s", se.sin(t2))
    assert value(expand(k2, frozen.row(P - s2, "frozen").lf[1]), point) == pytest.approx(-0.7 * np.cos(0.2))
