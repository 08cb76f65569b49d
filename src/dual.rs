//! A number with its rate along one direction: forward-mode differentiation over any
//! [`Scalar`].
//!
//! `Dual { v, d }` carries a value `v` and its derivative `d` along a direction chosen by
//! the caller (seed each input's `d` with its rate); every operation applies the chain
//! rule. Over [`Interval`](crate::interval::Interval)s it encloses a function's rate of
//! change over a box: the sampled-data certificate seeds a state box with the velocities
//! the plant can have in it, so that `d` encloses `d/dt` of the rigid-body dynamics along
//! every trajectory in the box (a first-order form in time, far tighter over a control
//! period than the dynamics' own enclosure: [`crate::torque`]).
//!
//! ```
//! use cbfgen::dual::Dual;
//! use cbfgen::scalar::Scalar;
//!
//! // d/dx (x sin x) at x = 2: sin 2 + 2 cos 2.
//! let x = Dual { v: 2.0, d: 1.0 };
//! let y = x * x.sin();
//! assert!((y.d - (2f64.sin() + 2.0 * 2f64.cos())).abs() < 1e-15);
//! ```

use core::ops::{Add, Div, Mul, Neg, Sub};

use crate::ops::OpCount;
use crate::scalar::Scalar;

/// A value and its derivative along one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dual<S> {
    /// The value.
    pub v: S,
    /// Its derivative.
    pub d: S,
}

impl<S: Scalar> Dual<S> {
    /// `f(v)` with derivative `f'(v) · d`.
    fn chain(self, value: S, slope: S) -> Self {
        Dual { v: value, d: slope * self.d }
    }
}

impl<S: Scalar> From<f64> for Dual<S> {
    /// A constant: derivative 0.
    fn from(x: f64) -> Self {
        Dual { v: S::from(x), d: S::from(0.0) }
    }
}

impl<S: Scalar> Add for Dual<S> {
    type Output = Self;
    fn add(self, rhs: Self) -> Self {
        Dual { v: self.v + rhs.v, d: self.d + rhs.d }
    }
}

impl<S: Scalar> Sub for Dual<S> {
    type Output = Self;
    fn sub(self, rhs: Self) -> Self {
        Dual { v: self.v - rhs.v, d: self.d - rhs.d }
    }
}

impl<S: Scalar> Mul for Dual<S> {
    type Output = Self;
    fn mul(self, rhs: Self) -> Self {
        Dual { v: self.v * rhs.v, d: self.v * rhs.d + self.d * rhs.v }
    }
}

impl<S: Scalar> Div for Dual<S> {
    type Output = Self;
    fn div(self, rhs: Self) -> Self {
        let v = self.v / rhs.v;
        Dual { v, d: (self.d - v * rhs.d) / rhs.v }
    }
}

impl<S: Scalar> Neg for Dual<S> {
    type Output = Self;
    fn neg(self) -> Self {
        Dual { v: -self.v, d: -self.d }
    }
}

/// At most what a straight line that performs `plain` on numbers performs on [`Dual`]
/// numbers, in operations on the numbers underneath: each operation of `plain` replaced by
/// its chain rule's, the costliest of its kind (an `add` is 2, a `mul` 3 multiplications
/// and an addition; an `elementary` call is bounded by `powf`'s 3 calls, 4
/// multiplications and 2 additions, where `sin` needs 2 calls and 1 multiplication).
/// Checked against every operation run on dual counting numbers.
pub const fn dual_ops(plain: OpCount) -> OpCount {
    const Z: OpCount = OpCount::ZERO;
    let add = OpCount { add: 2, ..Z };
    let neg = OpCount { neg: 2, ..Z };
    let mul = OpCount { add: 1, mul: 3, ..Z };
    let div = OpCount { add: 1, mul: 1, div: 2, ..Z };
    let sqrt = OpCount { mul: 1, div: 1, sqrt: 1, ..Z };
    let elementary = OpCount { add: 2, neg: 1, mul: 4, div: 1, sqrt: 1, elementary: 3, ..Z };
    let lanes = OpCount { add: 1, mul: 2, div: 1, lanes: 1, ..Z };
    let compare = OpCount { add: 4, mul: 2, div: 1, compare: 2, ..Z };
    add.times(plain.add)
        .plus(neg.times(plain.neg))
        .plus(mul.times(plain.mul))
        .plus(div.times(plain.div))
        .plus(sqrt.times(plain.sqrt))
        .plus(elementary.times(plain.elementary))
        .plus(lanes.times(plain.lanes))
        .plus(compare.times(plain.compare))
}

/// `f` of every lane, with `slope(x, f(x))` as each lane's derivative factor.
fn lanes<S: Scalar, const N: usize>(x: [Dual<S>; N], f: fn([S; N]) -> [S; N], slope: fn(S, S) -> S) -> [Dual<S>; N] {
    let values = f(x.map(|e| e.v));
    core::array::from_fn(|i| x[i].chain(values[i], slope(x[i].v, values[i])))
}

impl<S: Scalar> Scalar for Dual<S> {
    fn sqr(self) -> Self {
        self.chain(self.v.sqr(), S::from(2.0) * self.v)
    }
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, S::from(0.5) / r)
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    fn ln(self) -> Self {
        self.chain(self.v.ln(), S::from(1.0) / self.v)
    }
    /// The slope is `v / |v|`: undefined (NaN, or an interval holding 0 gives
    /// everything) at 0, where `|x|` has none.
    fn abs(self) -> Self {
        let a = self.v.abs();
        self.chain(a, self.v / a)
    }
    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }
    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }
    fn tan(self) -> Self {
        let t = self.v.tan();
        self.chain(t, S::from(1.0) + t.sqr())
    }
    fn asin(self) -> Self {
        self.chain(self.v.asin(), S::from(1.0) / (S::from(1.0) - self.v.sqr()).sqrt())
    }
    fn acos(self) -> Self {
        self.chain(self.v.acos(), -(S::from(1.0) / (S::from(1.0) - self.v.sqr()).sqrt()))
    }
    fn atan(self) -> Self {
        self.chain(self.v.atan(), S::from(1.0) / (S::from(1.0) + self.v.sqr()))
    }
    fn atan2(self, x: Self) -> Self {
        let r2 = x.v.sqr() + self.v.sqr();
        Dual { v: self.v.atan2(x.v), d: (x.v * self.d - self.v * x.d) / r2 }
    }
    fn sinh(self) -> Self {
        self.chain(self.v.sinh(), self.v.cosh())
    }
    fn cosh(self) -> Self {
        self.chain(self.v.cosh(), self.v.sinh())
    }
    fn tanh(self) -> Self {
        let t = self.v.tanh();
        self.chain(t, S::from(1.0) - t.sqr())
    }
    /// `d(xᵉ) = e xᵉ⁻¹ dx + xᵉ ln x de`; the second term only where the exponent moves
    /// (a constant exponent of a negative base has no logarithm to take).
    fn powf(self, e: Self) -> Self {
        let p = self.v.powf(e.v);
        let mut d = e.v * self.v.powf(e.v - S::from(1.0)) * self.d;
        if e.d != S::from(0.0) {
            d = d + p * self.v.ln() * e.d;
        }
        Dual { v: p, d }
    }
    /// `max(a, b) = (a + b + |a − b|) / 2`: the slope of the larger, and undefined where
    /// they tie (an interval `a − b` holding 0 gives everything).
    fn max(self, other: Self) -> Self {
        let gap = self.v - other.v;
        let sign = gap / gap.abs();
        let d = S::from(0.5) * (self.d + other.d + sign * (self.d - other.d));
        Dual { v: self.v.max(other.v), d }
    }
    fn exp_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        lanes(x, S::exp_lanes, |_, e| e)
    }
    fn tanh_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        lanes(x, S::tanh_lanes, |_, t| S::from(1.0) - t.sqr())
    }
    fn ln_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        lanes(x, S::ln_lanes, |v, _| S::from(1.0) / v)
    }
    fn exp_lane(self) -> Self {
        let e = self.v.exp_lane();
        self.chain(e, e)
    }
    fn tanh_lane(self) -> Self {
        let t = self.v.tanh_lane();
        self.chain(t, S::from(1.0) - t.sqr())
    }
    fn ln_lane(self) -> Self {
        self.chain(self.v.ln_lane(), S::from(1.0) / self.v)
    }
}

#[cfg(test)]
mod tests {
    use super::Dual;
    use crate::interval::Interval;
    use crate::scalar::Scalar;

    /// Every operation on dual counting numbers performs no more than [`dual_ops`] states
    /// for it from its count on plain counting numbers, and the sums of ops stay within
    /// the sum of their bounds.
    #[test]
    fn every_operation_stays_within_its_dual_count() {
        use super::dual_ops;
        use crate::ops::{Counted, OpCount};
        type Case = (&'static str, fn(Counted, Counted) -> Counted, fn(Dual<Counted>, Dual<Counted>) -> Dual<Counted>);
        macro_rules! cases {
            ($($name:literal: |$a:ident, $b:ident| $e:expr),* $(,)?) => {
                [$(($name, |$a: Counted, $b: Counted| $e, |$a: Dual<Counted>, $b: Dual<Counted>| $e)),*]
            };
        }
        let cases: [Case; 27] = cases! {
            "add": |a, b| a + b, "sub": |a, b| a - b, "mul": |a, b| a * b, "div": |a, b| a / b,
            "neg": |a, _b| -a, "sqr": |a, _b| a.sqr(), "sqrt": |a, _b| a.sqrt(), "exp": |a, _b| a.exp(),
            "ln": |a, _b| a.ln(), "abs": |a, _b| a.abs(), "sin": |a, _b| a.sin(), "cos": |a, _b| a.cos(),
            "tan": |a, _b| a.tan(), "asin": |a, _b| a.asin(), "acos": |a, _b| a.acos(),
            "atan": |a, _b| a.atan(), "atan2": |a, b| a.atan2(b), "sinh": |a, _b| a.sinh(),
            "cosh": |a, _b| a.cosh(), "tanh": |a, _b| a.tanh(), "powf": |a, b| a.powf(b),
            "max": |a, b| a.max(b), "exp_lane": |a, _b| a.exp_lane(), "tanh_lane": |a, _b| a.tanh_lane(),
            "ln_lane": |a, _b| a.ln_lane(), "exp_lanes": |a, b| Scalar::exp_lanes([a, b])[0],
            "mixed": |a, b| a * b.sin() - a.exp() / (b + a.sqrt()),
        };
        let (a, b) = (Counted(0.4), Counted(0.3));
        // Both arguments moving: the exponent of `powf` too (its costliest branch).
        let (da, db) = (Dual { v: a, d: Counted(0.7) }, Dual { v: b, d: Counted(-0.2) });
        let mut total = (OpCount::ZERO, OpCount::ZERO);
        for (name, plain, dual) in cases {
            let on_numbers = Counted::measure(|| plain(a, b)).1;
            let on_duals = Counted::measure(|| dual(da, db)).1;
            let bound = dual_ops(on_numbers);
            for (kind, got, most) in [
                ("add", on_duals.add, bound.add),
                ("neg", on_duals.neg, bound.neg),
                ("mul", on_duals.mul, bound.mul),
                ("div", on_duals.div, bound.div),
                ("sqrt", on_duals.sqrt, bound.sqrt),
                ("elementary", on_duals.elementary, bound.elementary),
                ("lanes", on_duals.lanes, bound.lanes),
                ("compare", on_duals.compare, bound.compare),
            ] {
                assert!(got <= most, "{name}: {got} {kind} on duals, {most} stated ({on_numbers} on numbers)");
            }
            total = (total.0 + on_numbers, total.1 + on_duals);
        }
        assert!(total.1.total() <= dual_ops(total.0).total());
        // The common operations are exact: a bound, not a guess.
        assert_eq!(dual_ops(OpCount { add: 1, ..OpCount::ZERO }), Counted::measure(|| da + db).1);
        assert_eq!(dual_ops(OpCount { mul: 1, ..OpCount::ZERO }), Counted::measure(|| da * db).1);
    }

    /// Every operation's derivative against a central difference of its value, at
    /// points inside each function's domain.
    #[test]
    fn every_derivative_is_its_central_difference() {
        type Unary = (&'static str, fn(Dual<f64>) -> Dual<f64>, f64);
        let unary: [Unary; 20] = [
            ("sqr", Scalar::sqr, 0.7),
            ("sqrt", Scalar::sqrt, 1.3),
            ("exp", Scalar::exp, 0.4),
            ("ln", Scalar::ln, 1.7),
            ("abs", Scalar::abs, -0.6),
            ("sin", Scalar::sin, 0.9),
            ("cos", Scalar::cos, 0.9),
            ("tan", Scalar::tan, 0.5),
            ("asin", Scalar::asin, 0.3),
            ("acos", Scalar::acos, -0.4),
            ("atan", Scalar::atan, 1.2),
            ("sinh", Scalar::sinh, 0.8),
            ("cosh", Scalar::cosh, -0.8),
            ("tanh", Scalar::tanh, 0.6),
            ("exp_lane", Scalar::exp_lane, -0.3),
            ("tanh_lane", Scalar::tanh_lane, 0.2),
            ("ln_lane", Scalar::ln_lane, 2.5),
            ("recip", |x| Dual::from(1.0) / x, 1.4),
            ("mixed", |x| x * x.sin() - x.exp() / (x + Dual::from(3.0)), 0.6),
            ("exp_lanes", |x| Scalar::exp_lanes([x, x])[1], 0.35),
        ];
        let h = 1e-6;
        for (name, f, x) in unary {
            let at = |v: f64| f(Dual { v, d: 0.0 }).v;
            let want = (at(x + h) - at(x - h)) / (2.0 * h);
            let got = f(Dual { v: x, d: 1.0 }).d;
            assert!((got - want).abs() < 1e-7 * (1.0 + want.abs()), "{name}: {got} vs {want}");
        }
        type Binary = (&'static str, fn(Dual<f64>, Dual<f64>) -> Dual<f64>);
        let binary: [Binary; 4] =
            [("atan2", Scalar::atan2), ("powf", Scalar::powf), ("max", Scalar::max), ("div", |a, b| a / b)];
        // Along a direction that moves both arguments.
        let (a, b, da, db) = (1.3, 0.8, 0.7, -0.4);
        for (name, f) in binary {
            let at = |t: f64| f(Dual { v: a + da * t, d: 0.0 }, Dual { v: b + db * t, d: 0.0 }).v;
            let want = (at(h) - at(-h)) / (2.0 * h);
            let got = f(Dual { v: a, d: da }, Dual { v: b, d: db }).d;
            assert!((got - want).abs() < 1e-7 * (1.0 + want.abs()), "{name}: {got} vs {want}");
        }
        // A constant negative base to a constant exponent: no logarithm taken.
        let p = Dual { v: -2.0, d: 1.0 }.powf(Dual::from(3.0));
        assert!((p.v + 8.0).abs() < 1e-12 && (p.d - 12.0).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn on_intervals_the_rate_encloses_every_derivative_over_the_box() {
        // f(x) = x sin x over [1, 1.2], rate seeded with [0.5, 1]: d holds f'(x)·r for
        // every x and r in their intervals.
        let x = Dual { v: Interval::new(1.0, 1.2), d: Interval::new(0.5, 1.0) };
        let y = x * x.sin();
        for i in 0..=20 {
            let xv = 1.0 + 0.01 * f64::from(i);
            let slope = xv.sin() + xv * xv.cos();
            for r in [0.5, 0.75, 1.0] {
                assert!(y.d.contains(slope * r), "{} outside {}", slope * r, y.d);
            }
            assert!(y.v.contains(xv * xv.sin()));
        }
    }
}
