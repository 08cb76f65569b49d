//! Certified interval arithmetic: the [`Scalar`] that encloses a generated kernel's value
//! over a box of states.
//!
//! Between two control samples the plant can reach a whole box of states; the
//! sampled-data certificate runs the same generated straight line that the filter runs on
//! `f64` on [`Interval`]s instead, and gets an interval that holds the kernel's exact value
//! at **every** real point of the box.
//!
//! * **Every operation rounds outward.** `+` and `−` round each end exactly outward (an
//!   error-free TwoSum tells whether, and which way, the nearest sum was rounded). `× ÷ √`
//!   are correctly rounded in IEEE 754, so each end is computed to nearest and moved one
//!   step outward (`f64::next_down`, `f64::next_up`). The libm functions (`exp`, `ln`, `sin`, …, `powf`) are not correctly
//!   rounded: their ends move [`LIBM_ULPS`] steps outward. The [`crate::lanes`] functions
//!   move by their stated bounds ([`crate::lanes::EXP_MAX_ULP`], …) with a margin.
//! * **[`Interval::ENTIRE`] means nothing is known.** An operation whose exact result is
//!   undefined somewhere on its input (`√` or `ln` of an interval reaching below 0, `÷` by
//!   an interval holding 0, `asin` outside `[-1, 1]`, …), or that meets NaN, returns
//!   `(−∞, +∞)`; and every operation maps `ENTIRE` to `ENTIRE` (`sin(ENTIRE)` is `ENTIRE`,
//!   not `[-1, 1]`), so an undefined value is never laundered into a finite-looking bound.
//!   A caller reads `ENTIRE` as "cannot certify".
//! * **Calls, not inlined code.** No operation is `#[inline]`: a system crate instantiates
//!   every barrier kernel on intervals, and inlining each operation's outward rounding into
//!   those long straight lines made the Panda's one-number edit take 96 s to rebuild
//!   instead of 7.6 s (and the certificate ran slower, 293 µs a Tachyon 3 update instead
//!   of 151 µs).
//! * **Enclosures are wider than the true range, never narrower.** Each operation sees its
//!   operands as independent (the *dependency problem*): `x * x` on `[-1, 2]` gives
//!   `[-2, 4]`, not `[0, 4]`, and `x - x` is not `0`. That costs tightness, not
//!   correctness; narrower boxes give tighter enclosures.
//!
//! ```
//! use cbfgen::interval::Interval;
//! use cbfgen::scalar::Scalar;
//!
//! // A generated kernel: straight-line code over any scalar.
//! fn h<S: Scalar>(q: S, qd: S) -> S {
//!     S::from(2.0) * q - qd.sin()
//! }
//! // Every state the plant may reach before the next sample…
//! let (q, qd) = (Interval::new(0.9, 1.1), Interval::new(0.4, 0.6));
//! let enclosure = h(q, qd);
//! // …maps inside the enclosure.
//! for (a, b) in [(0.9, 0.4), (1.0, 0.5), (1.1, 0.6), (0.95, 0.45)] {
//!     assert!(enclosure.contains(h(a, b)));
//! }
//! // An undefined operation knows nothing, and neither does anything computed from it.
//! let undefined = Interval::new(-1.0, 4.0).sqrt();
//! assert!(undefined.is_entire());
//! assert!(undefined.sin().is_entire());
//! ```

use core::f64::consts::{FRAC_PI_2, PI, TAU};
use core::fmt;
use core::ops::{Add, Div, Mul, Neg, Sub};

use crate::ops::OpCount;
use crate::scalar::Scalar;

/// Steps outward (`next_down`/`next_up`) for a libm function's result: the platform libm is
/// assumed within 2 ulps of the exact value for the functions used here (glibc's on x86-64
/// is within 1 step of the correctly rounded value for each, 2 for `sinh` and `tanh`); 4
/// steps leave a margin. The tests check the enclosures against CORE-MATH's correctly
/// rounded values.
pub const LIBM_ULPS: u32 = 4;

/// Steps outward for a [`crate::lanes`] result: its stated bound from the correctly
/// rounded value, plus the half ulp from there to the exact value, doubled as a margin
/// (a step below a power of two is half an ulp of it).
const fn lanes_steps(max_ulp: u64) -> u32 {
    2 * (max_ulp as u32) + 2
}
const EXP_LANE_STEPS: u32 = lanes_steps(crate::lanes::EXP_MAX_ULP);
const TANH_LANE_STEPS: u32 = lanes_steps(crate::lanes::TANH_MAX_ULP);
const LN_LANE_STEPS: u32 = lanes_steps(crate::lanes::LN_MAX_ULP);

/// A closed interval `[lo, hi]` of real numbers that holds an unknown exact value.
///
/// Infinite ends mean unbounded on that side (an overflow, or an unbounded input): the
/// interval still holds only real numbers. [`Interval::ENTIRE`] is special: it also stands
/// for "undefined" and "unknown", and every operation keeps it (see the
/// [module documentation](crate::interval)).
///
/// Construct with [`Interval::new`], [`Interval::point`], `Interval::from(x)` or
/// [`Interval::hull`]. The fields are public for reading; an interval built by hand must
/// keep `lo <= hi` (an end that is NaN makes every operation return `ENTIRE`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// The lower end (may be `−∞`).
    pub lo: f64,
    /// The upper end (may be `+∞`).
    pub hi: f64,
}

/// `[-1, 1]`: the range of `sin` and `cos`.
const UNIT: Interval = Interval { lo: -1.0, hi: 1.0 };

impl Interval {
    /// `(−∞, +∞)`: nothing is known — the result of an operation that is undefined
    /// somewhere on its input or met NaN. Every operation maps it to itself.
    pub const ENTIRE: Interval = Interval { lo: f64::NEG_INFINITY, hi: f64::INFINITY };

    /// `[lo, hi]`. Debug builds assert `lo <= hi`; a NaN end gives [`Interval::ENTIRE`].
    pub fn new(lo: f64, hi: f64) -> Self {
        debug_assert!(lo.is_nan() || hi.is_nan() || lo <= hi, "Interval::new: lo {lo} > hi {hi}");
        finish(lo, hi)
    }

    /// `[x, x]`: an exactly known value (NaN gives [`Interval::ENTIRE`]).
    pub fn point(x: f64) -> Self {
        finish(x, x)
    }

    /// The smallest interval holding both `a` and `b` ([`Interval::ENTIRE`] if either is).
    pub fn hull(a: Self, b: Self) -> Self {
        if a.unknown() || b.unknown() {
            return Self::ENTIRE;
        }
        Interval { lo: a.lo.min(b.lo), hi: a.hi.max(b.hi) }
    }

    /// The smallest interval holding `self` and `other`: [`Interval::hull`] as a method.
    pub fn union(self, other: Self) -> Self {
        Self::hull(self, other)
    }

    /// `hi − lo`, rounded up (so never less than the true width); `0` for a point, `+∞`
    /// when unbounded, NaN for a NaN end.
    pub fn width(self) -> f64 {
        add_up(self.hi, -self.lo)
    }

    /// A point of the interval near its centre: `(lo + hi)/2` when both ends are finite,
    /// `0` for [`Interval::ENTIRE`], `±f64::MAX` when unbounded on one side only; NaN for a
    /// NaN end.
    pub fn mid(self) -> f64 {
        match (self.lo == f64::NEG_INFINITY, self.hi == f64::INFINITY) {
            (true, true) => 0.0,
            (true, false) => -f64::MAX,
            (false, true) => f64::MAX,
            // Kept in [lo, hi] after rounding; NaN-preserving, and no panic (`f64::clamp`
            // would panic on a NaN end).
            (false, false) => at_most(at_least(f64::midpoint(self.lo, self.hi), self.lo), self.hi),
        }
    }

    /// Whether `x` lies in `[lo, hi]` (false for NaN).
    pub fn contains(self, x: f64) -> bool {
        (self.lo..=self.hi).contains(&x)
    }

    /// Whether both ends are finite.
    pub fn is_finite(self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }

    /// Whether this is [`Interval::ENTIRE`] (nothing known) or has a NaN end (also nothing
    /// known: every operation turns it into `ENTIRE`).
    pub fn is_entire(self) -> bool {
        self.unknown()
    }

    /// `self ∩ other`, for two enclosures of the same values (so the values lie in
    /// both): the tighter enclosure. `other` where rounding left them apart, or either is
    /// unknown.
    ///
    /// ```
    /// use cbfgen::interval::Interval;
    /// assert_eq!(Interval::new(0.0, 2.0).meet(Interval::new(1.0, 3.0)), Interval::new(1.0, 2.0));
    /// ```
    pub fn meet(self, other: Self) -> Self {
        let (lo, hi) = (self.lo.max(other.lo), self.hi.min(other.hi));
        if lo <= hi && !self.unknown() {
            Interval { lo, hi }
        } else {
            other
        }
    }

    /// The largest magnitude in the interval, `max(|lo|, |hi|)` (exact); `+∞` when
    /// unbounded, for [`Interval::ENTIRE`] and for a NaN end.
    pub fn mag(self) -> f64 {
        if self.unknown() {
            return f64::INFINITY;
        }
        self.lo.abs().max(self.hi.abs())
    }

    /// `ENTIRE` or a NaN end: what every operation maps to `ENTIRE`.
    fn unknown(self) -> bool {
        (self.lo == f64::NEG_INFINITY && self.hi == f64::INFINITY) || self.lo.is_nan() || self.hi.is_nan()
    }

    /// `f` increasing on the whole interval, within `ulps` steps at each end.
    fn increasing(self, f: fn(f64) -> f64, ulps: u32) -> Self {
        if self.unknown() {
            return Self::ENTIRE;
        }
        finish(down(f(self.lo), ulps), up(f(self.hi), ulps))
    }
}

/// `[lo, hi]`, or [`Interval::ENTIRE`] if either end is NaN.
fn finish(lo: f64, hi: f64) -> Interval {
    if lo.is_nan() || hi.is_nan() {
        Interval::ENTIRE
    } else {
        Interval { lo, hi }
    }
}

/// `x` moved `n` steps toward `−∞` (NaN stays NaN, `−∞` stays `−∞`).
fn down(mut x: f64, n: u32) -> f64 {
    for _ in 0..n {
        x = x.next_down();
    }
    x
}

/// `x` moved `n` steps toward `+∞`.
fn up(mut x: f64, n: u32) -> f64 {
    for _ in 0..n {
        x = x.next_up();
    }
    x
}

/// `max(x, m)`, but NaN stays NaN (`f64::max` would drop it).
fn at_least(x: f64, m: f64) -> f64 {
    if x < m {
        m
    } else {
        x
    }
}

/// `min(x, m)`, but NaN stays NaN.
fn at_most(x: f64, m: f64) -> f64 {
    if x > m {
        m
    } else {
        x
    }
}

/// The smaller of two, NaN if either is.
fn min_nan(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.min(b)
    }
}

/// The larger of two, NaN if either is.
fn max_nan(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Whether `[a, b]` is at least `w` wide (or its width is NaN: both ends the same infinity).
fn wider_than(a: f64, b: f64, w: f64) -> bool {
    let width = b - a;
    width >= w || width.is_nan()
}

/// The rounding error of `s = x + y` (finite): `x + y = s + e` exactly (Knuth's TwoSum,
/// exact in round-to-nearest without overflow).
fn two_sum_err(x: f64, y: f64, s: f64) -> f64 {
    let y_part = s - x;
    let x_part = s - y_part;
    (x - x_part) + (y - y_part)
}

/// The largest f64 `≤ x + y` (exact directed rounding; `+∞` from an overflow becomes
/// `f64::MAX`).
fn add_down(x: f64, y: f64) -> f64 {
    let s = x + y;
    if !s.is_finite() {
        return s.next_down();
    }
    // A NaN error (an intermediate overflow near f64::MAX) rounds outward too.
    if two_sum_err(x, y, s) >= 0.0 {
        s
    } else {
        s.next_down()
    }
}

/// The smallest f64 `≥ x + y`.
fn add_up(x: f64, y: f64) -> f64 {
    let s = x + y;
    if !s.is_finite() {
        return s.next_up();
    }
    if two_sum_err(x, y, s) <= 0.0 {
        s
    } else {
        s.next_up()
    }
}

/// A lower bound of the exact `x · y`; `0 · ±∞ = 0` (IEEE 1788: an infinite end is a bound,
/// not a member, so a zero factor makes the product exactly 0).
fn mul_down(x: f64, y: f64) -> f64 {
    if x == 0.0 || y == 0.0 {
        0.0
    } else {
        (x * y).next_down()
    }
}

/// An upper bound of the exact `x · y`; `0 · ±∞ = 0`.
fn mul_up(x: f64, y: f64) -> f64 {
    if x == 0.0 || y == 0.0 {
        0.0
    } else {
        (x * y).next_up()
    }
}

/// A lower bound of the exact `x / y`, for `y ≠ 0` (`±∞/±∞` is NaN).
fn div_down(x: f64, y: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else {
        (x / y).next_down()
    }
}

/// An upper bound of the exact `x / y`, for `y ≠ 0`.
fn div_up(x: f64, y: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else {
        (x / y).next_up()
    }
}

/// Whether `[a, b]` may hold a point `offset + k·period` for an integer `k`: true whenever
/// it does, and possibly when an end is within about `10⁻¹²` (relative) of such a point.
/// The arithmetic below errs by a few `10⁻¹⁶` relative to `|t| + 1` (the rounding of
/// `offset`, `period`, the subtraction and the division), far inside the margin `eps`.
fn may_hold_periodic(a: f64, b: f64, offset: f64, period: f64) -> bool {
    let ta = (a - offset) / period;
    let tb = (b - offset) / period;
    let eps = 1e-12 * (ta.abs().max(tb.abs()) + 1.0);
    let first = (ta - eps).ceil();
    // A NaN (unreachable: callers pass finite ends) answers "may".
    first <= tb + eps || first.is_nan() || tb.is_nan()
}

/// The f64 just above the real `π` (`PI`, its nearest f64, lies below it): the bound of
/// `atan2`'s range.
const PI_UP: f64 = f64::from_bits(PI.to_bits() + 1);

impl From<f64> for Interval {
    /// [`Interval::point`]: `[x, x]`, or [`Interval::ENTIRE`] for NaN.
    fn from(x: f64) -> Self {
        Self::point(x)
    }
}

impl fmt::Display for Interval {
    /// `[lo, hi]`; a precision (`{:.3}`) applies to both ends, rounded for display only.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match f.precision() {
            Some(p) => write!(f, "[{:.*}, {:.*}]", p, self.lo, p, self.hi),
            None => write!(f, "[{}, {}]", self.lo, self.hi),
        }
    }
}

impl Neg for Interval {
    type Output = Self;
    /// `[-hi, -lo]`, exact.
    fn neg(self) -> Self {
        if self.unknown() {
            return Self::ENTIRE;
        }
        Interval { lo: -self.hi, hi: -self.lo }
    }
}

impl Add for Interval {
    type Output = Self;
    /// `[lo + lo', hi + hi']`, rounded outward.
    fn add(self, rhs: Self) -> Self {
        if self.unknown() || rhs.unknown() {
            return Self::ENTIRE;
        }
        finish(add_down(self.lo, rhs.lo), add_up(self.hi, rhs.hi))
    }
}

impl Sub for Interval {
    type Output = Self;
    /// `[lo − hi', hi − lo']`, rounded outward.
    fn sub(self, rhs: Self) -> Self {
        if self.unknown() || rhs.unknown() {
            return Self::ENTIRE;
        }
        finish(add_down(self.lo, -rhs.hi), add_up(self.hi, -rhs.lo))
    }
}

impl Mul for Interval {
    type Output = Self;
    /// The extremes of the four end products, rounded outward; `0 · ±∞ = 0`.
    fn mul(self, rhs: Self) -> Self {
        if self.unknown() || rhs.unknown() {
            return Self::ENTIRE;
        }
        let (a, b, c, d) = (self.lo, self.hi, rhs.lo, rhs.hi);
        // By the operands' signs, the two end products that are the extremes (two
        // products instead of eight: the certificate's rigid-body dynamics are mostly
        // products). `x ≥ 0` holds for −0 too, whose products are ±0 all the same.
        let (lo, hi) = match (a >= 0.0, b <= 0.0, c >= 0.0, d <= 0.0) {
            (true, _, true, _) => (mul_down(a, c), mul_up(b, d)),
            (true, _, _, true) => (mul_down(b, c), mul_up(a, d)),
            (true, _, _, _) => (mul_down(b, c), mul_up(b, d)),
            (_, true, true, _) => (mul_down(a, d), mul_up(b, c)),
            (_, true, _, true) => (mul_down(b, d), mul_up(a, c)),
            (_, true, _, _) => (mul_down(a, d), mul_up(a, c)),
            (_, _, true, _) => (mul_down(a, d), mul_up(b, d)),
            (_, _, _, true) => (mul_down(b, c), mul_up(a, c)),
            _ => (min_nan(mul_down(a, d), mul_down(b, c)), max_nan(mul_up(a, c), mul_up(b, d))),
        };
        finish(lo, hi)
    }
}

impl Div for Interval {
    type Output = Self;
    /// [`Interval::ENTIRE`] when the divisor holds 0 (the quotient is undefined there);
    /// otherwise the extremes of the four end quotients, rounded outward (`ENTIRE` if one
    /// is `±∞/±∞`).
    fn div(self, rhs: Self) -> Self {
        if self.unknown() || rhs.unknown() || rhs.contains(0.0) {
            return Self::ENTIRE;
        }
        let (a, b, c, d) = (self.lo, self.hi, rhs.lo, rhs.hi);
        let lo = min_nan(min_nan(div_down(a, c), div_down(a, d)), min_nan(div_down(b, c), div_down(b, d)));
        let hi = max_nan(max_nan(div_up(a, c), div_up(a, d)), max_nan(div_up(b, c), div_up(b, d)));
        finish(lo, hi)
    }
}

/// The interval functions. Each returns [`Interval::ENTIRE`] for an `ENTIRE` (or NaN)
/// argument, and where the function is undefined somewhere on the argument:
///
/// | function | enclosure | `ENTIRE` when |
/// |---|---|---|
/// | `sqrt` | ends, 1 step out | `lo < 0` |
/// | `exp`, `sinh`, `tanh`, `atan`, `asin` | increasing: ends, [`LIBM_ULPS`] out (`tanh` kept in `[-1, 1]`) | `asin`: outside `[-1, 1]` |
/// | `ln` | ends, [`LIBM_ULPS`] out | `lo ≤ 0` |
/// | `acos` | decreasing: ends swapped | outside `[-1, 1]` |
/// | `abs` | exact; `[0, max(-lo, hi)]` across 0 | — |
/// | `cosh` | `[1, …]` across 0 | — |
/// | `sin`, `cos` | ends, or `±1` where the interval may hold an extremum; `[-1, 1]` if wider than `2π` or unbounded | — |
/// | `tan` | increasing between poles | it may hold a pole, or is wider than `π` |
/// | `atan2(y, x)` | extremes over the box's corners; `[-π, π]` (widened a step) when the box touches `x ≤ 0, y = 0` (the origin or the branch cut) or is unbounded | — |
/// | `powf(x, e)` | extremes over the four corners | `x.lo < 0`, or `x.lo = 0` with `e.lo ≤ 0` |
/// | `max` | `[max(lo, lo'), max(hi, hi')]` | — |
/// | `exp_lane`, `tanh_lane`, `ln_lane` (and `_lanes`) | [`crate::lanes`] at the ends, their stated bounds out | `ln`: `lo ≤ 0` |
impl Scalar for Interval {
    fn sqr(self) -> Self {
        let a = self.abs();
        if a.unknown() {
            return Self::ENTIRE;
        }
        finish(mul_down(a.lo, a.lo), mul_up(a.hi, a.hi))
    }

    fn sqrt(self) -> Self {
        if self.unknown() || self.lo < 0.0 {
            return Self::ENTIRE;
        }
        finish(at_least(self.lo.sqrt().next_down(), 0.0), self.hi.sqrt().next_up())
    }

    fn exp(self) -> Self {
        let r = self.increasing(f64::exp, LIBM_ULPS);
        if r.unknown() {
            return r;
        }
        Interval { lo: at_least(r.lo, 0.0), hi: r.hi }
    }

    fn ln(self) -> Self {
        if self.unknown() || self.lo <= 0.0 {
            return Self::ENTIRE;
        }
        self.increasing(f64::ln, LIBM_ULPS)
    }

    fn abs(self) -> Self {
        if self.unknown() {
            Self::ENTIRE
        } else if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            Interval { lo: -self.hi, hi: -self.lo }
        } else {
            Interval { lo: 0.0, hi: self.hi.max(-self.lo) }
        }
    }

    fn sin(self) -> Self {
        if self.unknown() {
            return Self::ENTIRE;
        }
        let (a, b) = (self.lo, self.hi);
        // Also catches an infinite end (the width is then ∞ or NaN).
        if wider_than(a, b, TAU) {
            return UNIT;
        }
        let (sa, sb) = (a.sin(), b.sin());
        let lo = if may_hold_periodic(a, b, -FRAC_PI_2, TAU) { -1.0 } else { down(min_nan(sa, sb), LIBM_ULPS) };
        let hi = if may_hold_periodic(a, b, FRAC_PI_2, TAU) { 1.0 } else { up(max_nan(sa, sb), LIBM_ULPS) };
        finish(at_least(lo, -1.0), at_most(hi, 1.0))
    }

    fn cos(self) -> Self {
        if self.unknown() {
            return Self::ENTIRE;
        }
        let (a, b) = (self.lo, self.hi);
        if wider_than(a, b, TAU) {
            return UNIT;
        }
        let (ca, cb) = (a.cos(), b.cos());
        let lo = if may_hold_periodic(a, b, PI, TAU) { -1.0 } else { down(min_nan(ca, cb), LIBM_ULPS) };
        let hi = if may_hold_periodic(a, b, 0.0, TAU) { 1.0 } else { up(max_nan(ca, cb), LIBM_ULPS) };
        finish(at_least(lo, -1.0), at_most(hi, 1.0))
    }

    fn tan(self) -> Self {
        if self.unknown() {
            return Self::ENTIRE;
        }
        let (a, b) = (self.lo, self.hi);
        if wider_than(a, b, PI) || may_hold_periodic(a, b, FRAC_PI_2, PI) {
            return Self::ENTIRE;
        }
        self.increasing(f64::tan, LIBM_ULPS)
    }

    fn asin(self) -> Self {
        if self.unknown() || self.lo < -1.0 || self.hi > 1.0 {
            return Self::ENTIRE;
        }
        self.increasing(f64::asin, LIBM_ULPS)
    }

    fn acos(self) -> Self {
        if self.unknown() || self.lo < -1.0 || self.hi > 1.0 {
            return Self::ENTIRE;
        }
        finish(at_least(down(self.hi.acos(), LIBM_ULPS), 0.0), up(self.lo.acos(), LIBM_ULPS))
    }

    fn atan(self) -> Self {
        self.increasing(f64::atan, LIBM_ULPS)
    }

    fn atan2(self, x: Self) -> Self {
        let y = self;
        if y.unknown() || x.unknown() {
            return Self::ENTIRE;
        }
        // The box touches the origin or the branch cut (the closed negative x-axis, where
        // the angle jumps between π and −π), or is unbounded: every angle.
        if (y.contains(0.0) && x.lo <= 0.0) || !(y.is_finite() && x.is_finite()) {
            return Interval { lo: -PI_UP, hi: PI_UP };
        }
        // Otherwise the angle is continuous on the box and the box sees the origin under
        // less than π: the extreme rays from the origin touch it at corners.
        let c = [y.lo.atan2(x.lo), y.lo.atan2(x.hi), y.hi.atan2(x.lo), y.hi.atan2(x.hi)];
        let lo = min_nan(min_nan(c[0], c[1]), min_nan(c[2], c[3]));
        let hi = max_nan(max_nan(c[0], c[1]), max_nan(c[2], c[3]));
        finish(at_least(down(lo, LIBM_ULPS), -PI_UP), at_most(up(hi, LIBM_ULPS), PI_UP))
    }

    fn sinh(self) -> Self {
        self.increasing(f64::sinh, LIBM_ULPS)
    }

    fn cosh(self) -> Self {
        if self.unknown() {
            return Self::ENTIRE;
        }
        let (ca, cb) = (self.lo.cosh(), self.hi.cosh());
        let (lo, hi) = if self.lo >= 0.0 {
            (ca, cb)
        } else if self.hi <= 0.0 {
            (cb, ca)
        } else {
            (1.0, max_nan(ca, cb))
        };
        finish(at_least(down(lo, LIBM_ULPS), 1.0), up(hi, LIBM_ULPS))
    }

    fn tanh(self) -> Self {
        let r = self.increasing(f64::tanh, LIBM_ULPS);
        if r.unknown() {
            return r;
        }
        Interval { lo: at_least(r.lo, -1.0), hi: at_most(r.hi, 1.0) }
    }

    fn powf(self, e: Self) -> Self {
        let x = self;
        if x.unknown() || e.unknown() || x.lo < 0.0 || (x.lo == 0.0 && e.lo <= 0.0) {
            return Self::ENTIRE;
        }
        // xᵉ = exp(e·ln x) and e·ln x is bilinear in (e, ln x): its extremes over the box,
        // and so those of xᵉ, lie at corners (0ᵉ = 0 for e > 0 is the limit there).
        let c = [x.lo.powf(e.lo), x.lo.powf(e.hi), x.hi.powf(e.lo), x.hi.powf(e.hi)];
        let lo = min_nan(min_nan(c[0], c[1]), min_nan(c[2], c[3]));
        let hi = max_nan(max_nan(c[0], c[1]), max_nan(c[2], c[3]));
        finish(at_least(down(lo, LIBM_ULPS), 0.0), up(hi, LIBM_ULPS))
    }

    fn max(self, other: Self) -> Self {
        if self.unknown() || other.unknown() {
            return Self::ENTIRE;
        }
        Interval { lo: self.lo.max(other.lo), hi: self.hi.max(other.hi) }
    }

    fn exp_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        let lo = crate::lanes::exp(x.map(|v| v.lo));
        let hi = crate::lanes::exp(x.map(|v| v.hi));
        core::array::from_fn(|i| exp_lane_from(x[i], lo[i], hi[i]))
    }

    fn tanh_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        let lo = crate::lanes::tanh(x.map(|v| v.lo));
        let hi = crate::lanes::tanh(x.map(|v| v.hi));
        core::array::from_fn(|i| tanh_lane_from(x[i], lo[i], hi[i]))
    }

    fn ln_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        // ln of the ends that are out of the domain is NaN or −∞, discarded below.
        let lo = crate::lanes::ln(x.map(|v| v.lo));
        let hi = crate::lanes::ln(x.map(|v| v.hi));
        core::array::from_fn(|i| ln_lane_from(x[i], lo[i], hi[i]))
    }

    fn exp_lane(self) -> Self {
        exp_lane_from(self, crate::lanes::exp1(self.lo), crate::lanes::exp1(self.hi))
    }

    fn tanh_lane(self) -> Self {
        tanh_lane_from(self, crate::lanes::tanh1(self.lo), crate::lanes::tanh1(self.hi))
    }

    fn ln_lane(self) -> Self {
        ln_lane_from(self, crate::lanes::ln1(self.lo), crate::lanes::ln1(self.hi))
    }
}

/// `exp` of `x` from [`crate::lanes`]' values at its ends (increasing).
fn exp_lane_from(x: Interval, at_lo: f64, at_hi: f64) -> Interval {
    if x.unknown() {
        return Interval::ENTIRE;
    }
    finish(at_least(down(at_lo, EXP_LANE_STEPS), 0.0), up(at_hi, EXP_LANE_STEPS))
}

/// `tanh` of `x` from [`crate::lanes`]' values at its ends (increasing).
fn tanh_lane_from(x: Interval, at_lo: f64, at_hi: f64) -> Interval {
    if x.unknown() {
        return Interval::ENTIRE;
    }
    finish(down(at_lo, TANH_LANE_STEPS), up(at_hi, TANH_LANE_STEPS))
}

/// `ln` of `x` from [`crate::lanes`]' values at its ends (increasing; `ENTIRE` for
/// `lo ≤ 0`).
fn ln_lane_from(x: Interval, at_lo: f64, at_hi: f64) -> Interval {
    if x.unknown() || x.lo <= 0.0 {
        return Interval::ENTIRE;
    }
    finish(down(at_lo, LN_LANE_STEPS), up(at_hi, LN_LANE_STEPS))
}

/// Every solution of `A x = b` for any `A` in `a` and `b` in `b`, enclosed; `None` when
/// the enclosure cannot prove every such `A` regular (too wide, or not finite).
///
/// How (Krawczyk's preconditioned residual form): with `C` an approximate inverse of
/// `A`'s midpoint and `x̃ = C·mid(b)` (plain `f64`: any `C` and `x̃` are sound, good ones
/// only make the result tight), the error `e = x − x̃` of every solution satisfies
/// `e = C (b − A x̃) + (I − C A) e`. With `R ⊇ C (b − A x̃)` and `E ⊇ I − C A` in interval
/// arithmetic and `δ ≥ ‖E‖∞ < 1`, `‖e‖∞ ≤ ‖R‖∞ / (1 − δ) =: ε` (and every `A` in `a` is
/// regular), and then `e ∈ (R + E·[−ε, ε]) ∩ [−ε, ε]`. What the certificate uses for a
/// torque-controlled robot's accelerations `M(q)⁻¹ (τ − b(q, q̇))` over a box of states.
///
/// ```
/// use cbfgen::interval::{solve_linear, Interval};
///
/// // [[2, 0], [0, 4]] x = [2, 4], each matrix entry ±1 %: x stays near (1, 1).
/// let entry = |v: f64| Interval::new(0.99 * v, 1.01 * v);
/// let a = [[entry(2.0), Interval::point(0.0)], [Interval::point(0.0), entry(4.0)]];
/// let x = solve_linear(&a, &[Interval::point(2.0), Interval::point(4.0)]).unwrap();
/// assert!(x[0].contains(1.0 / 1.01) && x[0].contains(1.0 / 0.99) && x[0].width() < 0.03);
/// // A matrix that may be singular has no enclosure.
/// let wide = [[Interval::new(-1.0, 1.0)]];
/// assert!(solve_linear(&wide, &[Interval::point(1.0)]).is_none());
/// ```
pub fn solve_linear<const N: usize>(a: &[[Interval; N]; N], b: &[Interval; N]) -> Option<[Interval; N]> {
    krawczyk(a, b)
}

/// What one [`solve_linear`] of size `n` performs at most, in interval operations (the
/// midpoint's inverse, plain `f64`, counted as if on intervals): `C`, `x̃`, the residual,
/// `I − C A` (the `n³` term), the norms and the refined error. Checked against the solve
/// run on counting numbers, with `C` by Gauss–Jordan elimination (`~1.5 n³`
/// multiplications and additions each). The solve runs nalgebra's LU inverse, which
/// performs fewer in all at every `n` (the factor and `2n` triangular solves: `~4/3 n³`
/// each, `n² + n` divisions; 875 against 1 036 at `n = 7`), so the total, which the time
/// bound multiplies by one rate, is a bound.
pub const fn solve_linear_ops(n: usize) -> OpCount {
    let n = n as u64;
    let (square, cube) = (n * n, n * n * n);
    // Gauss–Jordan on [A | I]: the pivot's column searched (|·| of the rows below), its
    // row scaled (the entries from the pivot on, and the inverse's row), every other row
    // eliminated (the same entries).
    let triangle = n * (n + 1) / 2;
    let sweep = triangle + square;
    let invert = OpCount {
        add: n.saturating_sub(1) * sweep,
        mul: sweep + n.saturating_sub(1) * sweep,
        div: n,
        compare: triangle,
        ..OpCount::ZERO
    };
    // x̃ = C·mid(b), the defect b − A x̃, R = C·defect, E = I − C A: each a product.
    let products = OpCount { add: 3 * square + cube, mul: 3 * square + cube, ..OpCount::ZERO };
    // ‖E‖∞ (each entry's magnitude summed, the rows' largest), ‖R‖∞, ε = ρ / (1 − δ).
    let norms = OpCount { add: square + 1, div: 1, compare: square + 3 * n, ..OpCount::ZERO };
    // Each x̃ᵢ + (Rᵢ + Eᵢ·[−ε, ε]) ∩ [−ε, ε].
    let refined = OpCount { add: square + n, mul: square, compare: n, ..OpCount::ZERO };
    invert.plus(products).plus(norms).plus(refined)
}

/// What [`krawczyk`] needs of its numbers beyond arithmetic: [`Interval`]s, and in the
/// tests [`Counted`](crate::ops::Counted) numbers (point intervals that count what they
/// do), so that [`solve_linear_ops`] is checked against the solve itself.
trait Enclosing: Scalar {
    /// A point's numbers (the midpoint, the approximate inverse): `f64` for intervals.
    type Point: Scalar + PartialOrd;
    /// A point near the centre.
    fn centre(self) -> Self::Point;
    /// The point as an enclosure of itself.
    fn at(p: Self::Point) -> Self;
    /// The largest magnitude, exact.
    fn magnitude(self) -> Self::Point;
    /// The upper end.
    fn upper(self) -> Self::Point;
    /// `[−r, r]`.
    fn ball(r: Self::Point) -> Self;
    /// [`Interval::meet`].
    fn meet_with(self, other: Self) -> Self;
    /// Whether `p` is finite.
    fn finite(p: Self::Point) -> bool;
    /// An approximate inverse of the midpoint matrix `m` (`None` when it is singular).
    fn approximate_inverse<const N: usize>(m: &[[Self::Point; N]; N]) -> Option<[[Self::Point; N]; N]>;
}

impl Enclosing for Interval {
    type Point = f64;
    fn centre(self) -> f64 {
        self.mid()
    }
    fn at(p: f64) -> Self {
        Interval::point(p)
    }
    fn magnitude(self) -> f64 {
        self.mag()
    }
    fn upper(self) -> f64 {
        self.hi
    }
    fn ball(r: f64) -> Self {
        Interval::new(-r, r)
    }
    fn meet_with(self, other: Self) -> Self {
        self.meet(other)
    }
    fn finite(p: f64) -> bool {
        p.is_finite()
    }
    /// nalgebra's LU with partial pivoting, at every size (what its `try_inverse` does
    /// from n = 5; its closed forms below that take more operations than the count says).
    fn approximate_inverse<const N: usize>(m: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
        let mut c = nalgebra::SMatrix::<f64, N, N>::zeros();
        if !nalgebra::linalg::try_invert_to(nalgebra::SMatrix::<f64, N, N>::from_fn(|i, j| m[i][j]), &mut c) {
            return None;
        }
        Some(core::array::from_fn(|i| core::array::from_fn(|j| c[(i, j)])))
    }
}

/// [`solve_linear`] on any [`Enclosing`] numbers.
fn krawczyk<S: Enclosing, const N: usize>(a: &[[S; N]; N], b: &[S; N]) -> Option<[S; N]> {
    let zero = S::from(0.0);
    let origin = S::Point::from(0.0);
    let c = S::approximate_inverse(&a.map(|row| row.map(S::centre)))?;
    if !c.iter().flatten().all(|v| S::finite(*v)) {
        return None;
    }
    let x: [S::Point; N] = core::array::from_fn(|i| (0..N).fold(origin, |s, k| s + c[i][k] * b[k].centre()));
    let defect: [S; N] = core::array::from_fn(|i| (0..N).fold(b[i], |s, k| s - a[i][k] * S::at(x[k])));
    let r: [S; N] = core::array::from_fn(|i| (0..N).fold(zero, |s, k| s + S::at(c[i][k]) * defect[k]));
    let e: [[S; N]; N] = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            let unit = S::from(if i == j { 1.0 } else { 0.0 });
            (0..N).fold(unit, |s, k| s - S::at(c[i][k]) * a[k][j])
        })
    });
    // ‖E‖∞ and ‖R‖∞, rounded up; ∞ (an unknown entry's magnitude) fails the test below.
    let delta =
        e.iter().map(|row| row.iter().fold(zero, |s, v| s + S::at(v.magnitude())).upper()).fold(origin, S::Point::max);
    // NaN fails it too.
    if delta.partial_cmp(&S::Point::from(1.0)) != Some(core::cmp::Ordering::Less) {
        return None;
    }
    let rho = r.iter().fold(origin, |m, v| m.max(v.magnitude()));
    let eps = (S::at(rho) / (S::from(1.0) - S::at(delta))).upper();
    if !S::finite(eps) {
        return None;
    }
    let ball = S::ball(eps);
    Some(core::array::from_fn(|i| {
        let refined = (0..N).fold(r[i], |s, j| s + e[i][j] * ball);
        // Both hold the error; their overlap does too.
        S::at(x[i]) + refined.meet_with(ball)
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lanes;

    /// splitmix64: a small deterministic generator, no dependency.
    struct Rng(u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in `[0, 1)`.
        fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
        }
        fn range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.unit()
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next_u64() % n
        }
        fn sign(&mut self) -> f64 {
            if self.below(2) == 0 {
                -1.0
            } else {
                1.0
            }
        }
        /// `10^u` with `u` uniform in `[a, b)`.
        fn log_uniform(&mut self, a: f64, b: f64) -> f64 {
            10f64.powf(self.range(a, b))
        }
    }

    /// Where a test draws its intervals from.
    #[derive(Clone, Copy, Debug)]
    enum Kind {
        /// Centres in `[-100, 100]`, around 0, straddling 0, near multiples of `π/2`, points.
        General,
        /// Mostly positive (the domain of `sqrt`, `ln`, a `powf` base), sometimes general.
        Positive,
        /// Mostly inside `[-1, 1]` (`asin`, `acos`), sometimes general.
        Unit,
        /// Exponents for `powf`: points half the time.
        Exponent,
    }

    fn centred(c: f64, w: f64) -> Interval {
        let iv = Interval::new(c - 0.5 * w, c + 0.5 * w);
        assert!(iv.lo <= iv.hi);
        iv
    }

    fn general(rng: &mut Rng) -> Interval {
        let w = if rng.below(8) == 0 { 0.0 } else { rng.log_uniform(-12.0, 1.0) };
        match rng.below(6) {
            0 | 1 => centred(rng.range(-100.0, 100.0), w),
            // Straddling 0.
            2 => Interval::new(-rng.log_uniform(-12.0, 1.0), rng.log_uniform(-12.0, 1.0)),
            // Near 0, on one side or across.
            3 => centred(rng.sign() * rng.log_uniform(-15.0, 0.0), w.min(1.0)),
            // Near an extremum, zero or pole of sin, cos, tan, or of atan2's axes.
            4 => {
                let k = rng.below(201) as f64 - 100.0;
                let c = k * FRAC_PI_2 + rng.sign() * rng.log_uniform(-17.0, -1.0);
                centred(c, if w == 0.0 { 0.0 } else { rng.log_uniform(-13.0, 0.0) })
            }
            // Large arguments for the periodic functions.
            _ => centred(rng.sign() * rng.log_uniform(2.0, 8.0), w),
        }
    }

    fn draw(rng: &mut Rng, kind: Kind) -> Interval {
        match kind {
            Kind::General => general(rng),
            Kind::Positive if rng.below(5) != 0 => {
                let lo = if rng.below(10) == 0 { 0.0 } else { rng.log_uniform(-10.0, 2.0) };
                let w = if rng.below(8) == 0 { 0.0 } else { rng.log_uniform(-12.0, 1.0) };
                Interval::new(lo, lo + w)
            }
            Kind::Unit if rng.below(5) != 0 => {
                let mut a = rng.range(-1.0, 1.0);
                let mut b = if rng.below(4) == 0 { a + rng.log_uniform(-12.0, -2.0) } else { rng.range(-1.0, 1.0) };
                match rng.below(6) {
                    0 => a = -1.0,
                    1 => b = 1.0,
                    _ => {}
                }
                let (a, b) = (a.min(b), a.max(b).min(1.0));
                Interval::new(a, b)
            }
            Kind::Exponent => {
                let c = rng.range(-3.0, 3.0);
                if rng.below(2) == 0 {
                    Interval::point(c)
                } else {
                    centred(c, rng.log_uniform(-12.0, 0.0))
                }
            }
            Kind::Positive | Kind::Unit => general(rng),
        }
    }

    /// A point of `iv`: an end a quarter of the time, else uniform inside.
    fn point_in(rng: &mut Rng, iv: Interval) -> f64 {
        match rng.below(8) {
            0 => iv.lo,
            1 => iv.hi,
            _ => (iv.lo + (iv.hi - iv.lo) * rng.unit()).clamp(iv.lo, iv.hi),
        }
    }

    const INTERVALS: usize = 1_500;
    const POINTS: usize = 50;

    /// The f64 value `v` at a point of the input is inside `enc`; a NaN value (the point is
    /// outside the function's domain) requires `ENTIRE`.
    fn check_value(name: &str, inputs: &dyn fmt::Debug, point: &dyn fmt::Debug, enc: Interval, v: f64) {
        if v.is_nan() {
            assert!(enc.is_entire(), "{name}{inputs:?}: NaN at {point:?} but the enclosure is {enc}");
        } else {
            assert!(enc.contains(v), "{name}{inputs:?} = {enc} misses {v:e} at {point:?}");
        }
    }

    /// What is known of the exact real value of an operation at a point, independently of
    /// the code under test: `(c, e)` with `c` an f64 near it and `e` the sign of
    /// `exact − c` (`0`: `c` is exact; from an error-free transformation), or NaN when only
    /// `|exact − c| < ½ ulp` is known (`c` correctly rounded, from CORE-MATH).
    type Truth = (f64, f64);

    fn correctly_rounded(c: f64) -> Truth {
        (c, f64::NAN)
    }
    fn exact(c: f64) -> Truth {
        (c, 0.0)
    }
    /// `p + q = s + e` exactly (TwoSum).
    fn sum_truth(p: f64, q: f64) -> Truth {
        let s = p + q;
        let q_part = s - p;
        (s, (p - (s - q_part)) + (q - q_part))
    }
    /// `p·q = s + e` exactly (FMA; no underflow at the scales drawn).
    fn product_truth(p: f64, q: f64) -> Truth {
        let s = p * q;
        (s, p.mul_add(q, -s))
    }
    /// `p/q − s = r/q` with the remainder `r = p − s·q` exact (FMA).
    fn quotient_truth(p: f64, q: f64) -> Truth {
        let s = p / q;
        (s, (-s).mul_add(q, p) / q)
    }
    /// `√p − s` has the sign of `p − s²` (exact by FMA).
    fn sqrt_truth(p: f64) -> Truth {
        let s = p.sqrt();
        (s, (-s).mul_add(s, p))
    }

    /// The exact value at a point of the input (known through `truth`) is inside `enc`:
    /// `c` strictly inside proves it (the exact value is within half a gap of a correctly
    /// rounded `c`); `c` on an end proves it only when `e` points inward or the end is a
    /// bound of the function's `range` (`sin ≤ 1`).
    fn check_truth(name: &str, at: &dyn fmt::Debug, enc: Interval, (c, e): Truth, range: (f64, f64)) {
        if c.is_nan() {
            assert!(enc.is_entire(), "{name}{at:?}: undefined but the enclosure is {enc}");
            return;
        }
        let lo_ok = c > enc.lo || (c == enc.lo && (e >= 0.0 || c <= range.0 || c == f64::NEG_INFINITY));
        let hi_ok = c < enc.hi || (c == enc.hi && (e <= 0.0 || c >= range.1 || c == f64::INFINITY));
        assert!(lo_ok && hi_ok, "{name}{at:?}: the exact value {c:e} (error sign {e:e}) may lie outside {enc}");
    }

    /// No bound known beyond the f64 range.
    const ANY: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);
    const NON_NEGATIVE: (f64, f64) = (0.0, f64::INFINITY);
    const PLUS_MINUS_ONE: (f64, f64) = (-1.0, 1.0);

    /// A unary operation under test: name, where its intervals are drawn, the interval
    /// form, the f64 function it encloses, the truth at a point, the function's range.
    type UnaryCase = (&'static str, Kind, fn(Interval) -> Interval, fn(f64) -> f64, fn(f64) -> Truth, (f64, f64));
    /// A binary operation under test, likewise.
    type BinaryCase = (
        &'static str,
        (Kind, Kind),
        fn(Interval, Interval) -> Interval,
        fn(f64, f64) -> f64,
        fn(f64, f64) -> Truth,
        (f64, f64),
    );

    /// Checks a unary operation at `POINTS` points of each of `INTERVALS` intervals, against
    /// the f64 function and the truth; returns (points checked, enclosures not `ENTIRE`).
    fn check_unary(seed: u64, (name, kind, op, f, truth, range): UnaryCase) -> (usize, usize) {
        let mut rng = Rng(seed);
        let (mut checks, mut known) = (0, 0);
        for _ in 0..INTERVALS {
            let x = draw(&mut rng, kind);
            let enc = op(x);
            assert!(enc.lo <= enc.hi, "{name}({x}) = {enc} is reversed");
            known += usize::from(!enc.is_entire());
            for _ in 0..POINTS {
                let p = point_in(&mut rng, x);
                check_value(name, &(x,), &p, enc, f(p));
                check_truth(name, &(x, p), enc, truth(p), range);
                checks += 1;
            }
        }
        (checks, known)
    }

    fn check_binary(seed: u64, (name, kinds, op, f, truth, range): BinaryCase) -> (usize, usize) {
        let mut rng = Rng(seed);
        let (mut checks, mut known) = (0, 0);
        for _ in 0..INTERVALS {
            let (x, y) = (draw(&mut rng, kinds.0), draw(&mut rng, kinds.1));
            let enc = op(x, y);
            assert!(enc.lo <= enc.hi, "{name}({x}, {y}) = {enc} is reversed");
            known += usize::from(!enc.is_entire());
            for _ in 0..POINTS {
                let (p, q) = (point_in(&mut rng, x), point_in(&mut rng, y));
                check_value(name, &(x, y), &(p, q), enc, f(p, q));
                check_truth(name, &(x, y, p, q), enc, truth(p, q), range);
                checks += 1;
            }
        }
        (checks, known)
    }

    /// Within `n` steps outward of `[lo, hi]`.
    fn near(enc: Interval, lo: f64, hi: f64, n: u32) -> bool {
        enc.lo <= lo && hi <= enc.hi && down(lo, n) <= enc.lo && enc.hi <= up(hi, n)
    }

    #[test]
    fn hand_computed_cases() {
        let iv = Interval::new;
        // Sums are rounded exactly outward: exact when representable.
        assert_eq!(iv(1.0, 2.0) + iv(3.0, 4.0), iv(4.0, 6.0));
        assert_eq!(iv(1.0, 2.0) - iv(3.0, 4.0), iv(-3.0, -1.0));
        let tenths = Interval::point(0.1) + Interval::point(0.2);
        assert!(tenths.lo < tenths.hi && tenths.hi == tenths.lo.next_up(), "0.1 + 0.2 is inexact: {tenths}");
        assert!(near(iv(-1.0, 2.0) * iv(-3.0, 4.0), -6.0, 8.0, 1));
        assert!(near(Interval::point(1.0) / iv(2.0, 4.0), 0.25, 0.5, 1));
        assert!(near(iv(4.0, 9.0).sqrt(), 2.0, 3.0, 1));
        assert!(near(-iv(1.0, 2.0), -2.0, -1.0, 0));

        let s = iv(0.0, PI).sin();
        assert!(s.contains(0.0) && s.hi == 1.0 && s.lo > -1e-300, "sin([0, π]) = {s}");
        let c = iv(-0.1, 0.1).cos();
        assert!(c.hi == 1.0 && near(c, 0.1f64.cos(), 1.0, LIBM_ULPS), "cos([-0.1, 0.1]) = {c}");
        assert_eq!(iv(-100.0, 100.0).sin(), UNIT);
        assert_eq!(iv(PI, 2.0 * PI).cos().hi, 1.0);
        assert_eq!(iv(0.5, 2.5).sin().hi, 1.0);
        assert!(iv(1.0, 2.0).tan().is_entire(), "tan over π/2");
        assert!(near(iv(-1.0, 1.0).tan(), -(1f64.tan()), 1f64.tan(), LIBM_ULPS));

        assert!((Interval::point(1.0) / iv(-1.0, 1.0)).is_entire());
        assert!((Interval::point(1.0) / iv(0.0, 1.0)).is_entire());
        assert!((Interval::point(1.0) / iv(-1.0, -0.0)).is_entire());
        assert!(iv(-1.0, 4.0).sqrt().is_entire());
        assert!(near(iv(0.0, 4.0).sqrt(), 0.0, 2.0, 1));
        assert!(iv(0.0, 4.0).ln().is_entire() && iv(-1.0, 4.0).ln_lane().is_entire());
        assert!(iv(-1.5, 0.0).asin().is_entire() && iv(0.0, 1.0 + 1e-15).acos().is_entire());
        assert!(near(iv(-1.0, 1.0).acos(), 0.0, PI, LIBM_ULPS));
        assert!(iv(-1.0, 2.0).powf(Interval::point(0.5)).is_entire());
        assert!(iv(0.0, 2.0).powf(Interval::point(-0.5)).is_entire());
        assert!(near(iv(0.0, 4.0).powf(Interval::point(0.5)), 0.0, 2.0, LIBM_ULPS));
        assert!(near(iv(4.0, 9.0).powf(Interval::point(-0.5)), 1.0 / 3.0, 0.5, LIBM_ULPS));

        assert_eq!(iv(-3.0, 2.0).abs(), iv(0.0, 3.0));
        assert_eq!(iv(-3.0, -2.0).abs(), iv(2.0, 3.0));
        assert!(near(iv(-1.0, 2.0).cosh(), 1.0, 2f64.cosh(), LIBM_ULPS));
        assert_eq!(iv(-1.0, 2.0).max(iv(0.0, 1.0)), iv(0.0, 2.0));

        let around_origin = iv(-1.0, 1.0).atan2(iv(-1.0, 1.0));
        assert!(around_origin.lo <= -PI && around_origin.hi >= PI && around_origin.contains(0.0));
        let cut = iv(-1e-9, 1e-9).atan2(iv(-2.0, -1.0));
        assert!(cut.contains(PI) && cut.contains(-PI), "branch cut: {cut}");
        let quadrant = iv(1.0, 2.0).atan2(iv(1.0, 2.0));
        assert!(near(quadrant, 0.5f64.atan(), 2f64.atan(), 2 * LIBM_ULPS), "{quadrant}");
    }

    #[test]
    fn zero_times_infinity_and_entire() {
        let iv = Interval::new;
        let e = Interval::ENTIRE;
        // IEEE 1788: an infinite end bounds, a zero factor gives exactly 0.
        assert_eq!(iv(0.0, 1.0) * iv(1.0, f64::INFINITY), iv(0.0, f64::INFINITY));
        assert_eq!(Interval::point(0.0) * iv(f64::NEG_INFINITY, 2.0), Interval::point(0.0));
        // ENTIRE is sticky: it also means "undefined", which a zero must not hide.
        assert!((Interval::point(0.0) * e).is_entire());
        for r in [e.sin(), e.cos(), e.tanh(), e.atan(), e.abs(), e.exp(), e.max(iv(1.0, 2.0)), e + iv(1.0, 1.0), -e] {
            assert!(r.is_entire(), "{r}");
        }
        assert!(Interval::hull(e, iv(0.0, 1.0)).is_entire());
        // A NaN end is ENTIRE.
        assert!(Interval::point(f64::NAN).is_entire() && Interval::from(f64::NAN) == e);
        let nan = Interval { lo: f64::NAN, hi: 1.0 };
        assert!((nan + iv(0.0, 1.0)).is_entire() && nan.sqrt().is_entire() && nan.max(iv(0.0, 1.0)).is_entire());
        assert!((iv(1.0, f64::INFINITY) / iv(1.0, f64::INFINITY)).is_entire(), "∞/∞");
        // Unbounded on one side is not ENTIRE, and stays informative.
        assert_eq!(iv(0.0, f64::INFINITY).sin(), UNIT);
        assert_eq!(iv(f64::NEG_INFINITY, 0.0).exp().lo, 0.0);
        // Overflow rounds outward to ±∞ / ±MAX, never inward.
        let big = Interval::point(f64::MAX) + Interval::point(f64::MAX);
        assert_eq!(big, iv(f64::MAX, f64::INFINITY));
    }

    #[test]
    fn helpers_and_display() {
        let iv = Interval::new;
        assert_eq!(Interval::hull(iv(0.0, 1.0), iv(3.0, 4.0)), iv(0.0, 4.0));
        assert_eq!(iv(3.0, 4.0).union(iv(-1.0, 0.0)), iv(-1.0, 4.0));
        assert_eq!(Interval::from(2.5), iv(2.5, 2.5));
        assert_eq!(iv(1.0, 3.0).width(), 2.0);
        assert!(iv(0.1, 0.3).width() >= 0.3 - 0.1);
        assert_eq!(Interval::point(7.0).width(), 0.0);
        assert_eq!(Interval::ENTIRE.width(), f64::INFINITY);
        assert_eq!(iv(1.0, 3.0).mid(), 2.0);
        assert_eq!(iv(-f64::MAX, f64::MAX).mid(), 0.0);
        assert_eq!(Interval::ENTIRE.mid(), 0.0);
        assert!(Interval { lo: f64::NAN, hi: 1.0 }.mid().is_nan(), "no panic on a NaN end");
        let adjacent = iv(0.1, 0.1f64.next_up());
        assert!(adjacent.contains(adjacent.mid()));
        assert_eq!(iv(1.0, f64::INFINITY).mid(), f64::MAX);
        assert!(iv(1.0, 2.0).contains(1.0) && iv(1.0, 2.0).contains(2.0) && !iv(1.0, 2.0).contains(f64::NAN));
        assert!(iv(1.0, 2.0).is_finite() && !iv(1.0, f64::INFINITY).is_finite());
        assert!(!iv(1.0, f64::INFINITY).is_entire());
        assert_eq!(iv(0.25, 1.5).to_string(), "[0.25, 1.5]");
        assert_eq!(format!("{:.2}", iv(1.0 / 3.0, 2.0)), "[0.33, 2.00]");
        assert_eq!(Interval::ENTIRE.to_string(), "[-inf, inf]");
    }

    #[test]
    fn enclosure_unary() {
        use core_math as cm;
        let cases: [UnaryCase; 19] = [
            ("neg", Kind::General, |x| -x, |x| -x, |x| exact(-x), ANY),
            ("sqr", Kind::General, Scalar::sqr, |x| x * x, |x| (x * x, x.mul_add(x, -(x * x))), NON_NEGATIVE),
            ("sqrt", Kind::Positive, Scalar::sqrt, f64::sqrt, sqrt_truth, NON_NEGATIVE),
            ("exp", Kind::General, Scalar::exp, f64::exp, |x| correctly_rounded(cm::exp(x)), NON_NEGATIVE),
            ("ln", Kind::Positive, Scalar::ln, f64::ln, |x| correctly_rounded(cm::log(x)), ANY),
            ("abs", Kind::General, Scalar::abs, f64::abs, |x| exact(x.abs()), NON_NEGATIVE),
            ("sin", Kind::General, Scalar::sin, f64::sin, |x| correctly_rounded(cm::sin(x)), PLUS_MINUS_ONE),
            ("cos", Kind::General, Scalar::cos, f64::cos, |x| correctly_rounded(cm::cos(x)), PLUS_MINUS_ONE),
            ("tan", Kind::General, Scalar::tan, f64::tan, |x| correctly_rounded(cm::tan(x)), ANY),
            ("asin", Kind::Unit, Scalar::asin, f64::asin, |x| correctly_rounded(cm::asin(x)), ANY),
            ("acos", Kind::Unit, Scalar::acos, f64::acos, |x| correctly_rounded(cm::acos(x)), NON_NEGATIVE),
            ("atan", Kind::General, Scalar::atan, f64::atan, |x| correctly_rounded(cm::atan(x)), ANY),
            ("sinh", Kind::General, Scalar::sinh, f64::sinh, |x| correctly_rounded(cm::sinh(x)), ANY),
            ("cosh", Kind::General, Scalar::cosh, f64::cosh, |x| correctly_rounded(cm::cosh(x)), (1.0, f64::INFINITY)),
            ("tanh", Kind::General, Scalar::tanh, f64::tanh, |x| correctly_rounded(cm::tanh(x)), PLUS_MINUS_ONE),
            ("exp_lane", Kind::General, Scalar::exp_lane, lanes::exp1, |x| correctly_rounded(cm::exp(x)), NON_NEGATIVE),
            (
                "tanh_lane",
                Kind::General,
                Scalar::tanh_lane,
                lanes::tanh1,
                |x| correctly_rounded(cm::tanh(x)),
                PLUS_MINUS_ONE,
            ),
            ("ln_lane", Kind::Positive, Scalar::ln_lane, lanes::ln1, |x| correctly_rounded(cm::log(x)), ANY),
            ("sqr", Kind::General, |x| x * x, |x| x * x, |x| product_truth(x, x), ANY),
        ];
        let mut total = 0;
        for (i, case) in cases.into_iter().enumerate() {
            let (checks, known) = check_unary(0x1234_5678 + i as u64, case);
            // Not trivially ENTIRE: the domain-restricted ones draw in their domain 4/5 of
            // the time, tan meets a pole in a minority.
            assert!(known * 2 > INTERVALS, "{}: only {known} of {INTERVALS} enclosures are not ENTIRE", case.0);
            total += checks;
        }
        assert_eq!(total, cases.len() * INTERVALS * POINTS);
    }

    #[test]
    fn enclosure_binary() {
        let g = (Kind::General, Kind::General);
        let cases: [BinaryCase; 7] = [
            ("add", g, |x, y| x + y, |x, y| x + y, sum_truth, ANY),
            ("sub", g, |x, y| x - y, |x, y| x - y, |x, y| sum_truth(x, -y), ANY),
            ("mul", g, |x, y| x * y, |x, y| x * y, product_truth, ANY),
            ("div", g, |x, y| x / y, |x, y| x / y, quotient_truth, ANY),
            ("atan2", g, Scalar::atan2, f64::atan2, |y, x| correctly_rounded(core_math::atan2(y, x)), ANY),
            ("max", g, Scalar::max, f64::max, |x, y| exact(x.max(y)), ANY),
            (
                "powf",
                (Kind::Positive, Kind::Exponent),
                Scalar::powf,
                f64::powf,
                |x, e| correctly_rounded(core_math::pow(x, e)),
                NON_NEGATIVE,
            ),
        ];
        for (i, case) in cases.into_iter().enumerate() {
            let (checks, known) = check_binary(0x9abc_def0 + i as u64, case);
            assert!(known * 2 > INTERVALS, "{}: only {known} of {INTERVALS} enclosures are not ENTIRE", case.0);
            assert_eq!(checks, INTERVALS * POINTS);
        }
    }

    #[test]
    fn atan2_near_the_axes_and_origin() {
        // Boxes hugging the axes, the origin and the branch cut, where atan2 is hardest.
        let mut rng = Rng(77);
        let near_axis = |rng: &mut Rng| {
            let c = match rng.below(3) {
                0 => 0.0,
                1 => rng.sign() * rng.log_uniform(-15.0, -3.0),
                _ => rng.sign() * rng.log_uniform(-1.0, 1.0),
            };
            centred(c, rng.log_uniform(-14.0, 0.0))
        };
        let mut known = 0;
        for _ in 0..INTERVALS {
            let (y, x) = (near_axis(&mut rng), near_axis(&mut rng));
            let enc = y.atan2(x);
            known += usize::from(enc.width() < 6.0);
            for _ in 0..POINTS {
                let (p, q) = (point_in(&mut rng, y), point_in(&mut rng, x));
                check_value("atan2", &(y, x), &(p, q), enc, p.atan2(q));
                check_truth("atan2", &(y, x, p, q), enc, correctly_rounded(core_math::atan2(p, q)), ANY);
            }
        }
        assert!(known * 2 > INTERVALS, "{known}");
    }

    #[test]
    fn batched_lanes_match_one_lane() {
        let mut rng = Rng(5);
        for _ in 0..200 {
            let x: [Interval; 5] = core::array::from_fn(|_| draw(&mut rng, Kind::General));
            let p: [Interval; 5] = core::array::from_fn(|_| draw(&mut rng, Kind::Positive));
            assert_eq!(Interval::exp_lanes(x), x.map(Interval::exp_lane));
            assert_eq!(Interval::tanh_lanes(x), x.map(Interval::tanh_lane));
            assert_eq!(Interval::ln_lanes(p), p.map(Interval::ln_lane));
            let pts = x.map(|iv| point_in(&mut rng, iv));
            for (enc, v) in Interval::exp_lanes(x).iter().zip(crate::lanes::exp(pts)) {
                assert!(enc.contains(v), "{enc} misses {v}");
            }
        }
    }

    #[test]
    fn point_intervals_are_tight() {
        // Not only certified but useful: a point in gives a few ulps out.
        type Case = (fn(Interval) -> Interval, fn(f64) -> f64);
        let cases: [Case; 16] = [
            (Scalar::sqrt, f64::sqrt),
            (Scalar::exp, f64::exp),
            (Scalar::ln, f64::ln),
            (Scalar::abs, f64::abs),
            (Scalar::sin, f64::sin),
            (Scalar::cos, f64::cos),
            (Scalar::tan, f64::tan),
            (Scalar::asin, f64::asin),
            (Scalar::acos, f64::acos),
            (Scalar::atan, f64::atan),
            (Scalar::sinh, f64::sinh),
            (Scalar::cosh, f64::cosh),
            (Scalar::tanh, f64::tanh),
            (Scalar::exp_lane, lanes::exp1),
            (Scalar::tanh_lane, lanes::tanh1),
            (Scalar::ln_lane, crate::lanes::ln1),
        ];
        let mut rng = Rng(99);
        for (i, (op, f)) in cases.into_iter().enumerate() {
            for _ in 0..500 {
                let x = if (7..=8).contains(&i) { rng.range(-1.0, 1.0) } else { rng.range(1e-3, 30.0) };
                let enc = op(Interval::point(x));
                let v = f(x);
                assert!(near(enc, v, v, 2 * LIBM_ULPS), "case {i}: f({x}) = {v}, enclosure {enc}");
            }
        }
    }

    /// The use case: a generic straight line, evaluated on a box, encloses its f64 values.
    fn f1<S: Scalar>(x: S, y: S) -> S {
        (x * y).sin() + (x - y).exp() / (S::from(1.0) + x * x)
    }

    fn f2<S: Scalar>(x: S, y: S) -> S {
        (x * x + y * y + S::from(0.5)).sqrt() * y.atan2(x) - (y.abs() + S::from(1.0)).ln() * x.tanh_lane()
            + x.cos().max(y.cosh() - S::from(2.0))
    }

    fn f3<S: Scalar>(x: S, y: S) -> S {
        let [a, b] = S::exp_lanes([x, -y]);
        (a + b).powf(S::from(0.3)) / (S::from(2.0) + x.tanh()) - (x * y - S::from(0.25)).tan()
    }

    #[test]
    fn composed_expressions_enclose_their_f64_values() {
        type Case = (&'static str, fn(Interval, Interval) -> Interval, fn(f64, f64) -> f64);
        let cases: [Case; 3] = [("f1", f1, f1), ("f2", f2, f2), ("f3", f3, f3)];
        let mut rng = Rng(2024);
        for (name, fi, ff) in cases {
            let mut known = 0;
            for _ in 0..INTERVALS {
                let w = rng.log_uniform(-9.0, -0.5);
                let x = centred(rng.range(-3.0, 3.0), w);
                let y = centred(rng.range(-3.0, 3.0), w * rng.range(0.1, 1.0));
                let enc = fi(x, y);
                known += usize::from(enc.is_finite());
                for _ in 0..POINTS {
                    let (p, q) = (point_in(&mut rng, x), point_in(&mut rng, y));
                    check_value(name, &(x, y), &(p, q), enc, ff(p, q));
                }
            }
            assert!(known * 2 > INTERVALS, "{name}: only {known} finite enclosures");
        }
    }

    #[test]
    fn linear_solutions_are_enclosed_and_tight_and_singular_boxes_refused() {
        // Random well-conditioned 5 × 5 matrices with entries known to a relative width
        // w; every solution at sampled matrices and right sides (nalgebra's LU, another
        // solver) lies in the enclosure, give or take that solve's own rounding.
        const N: usize = 5;
        let mut rng = Rng(77);
        for case in 0..300 {
            let w = rng.log_uniform(-9.0, -3.0);
            let centre: [[f64; N]; N] = core::array::from_fn(|i| {
                core::array::from_fn(|j| if i == j { rng.range(3.0, 6.0) } else { rng.range(-1.0, 1.0) })
            });
            let a = centre.map(|row| row.map(|v| centred(v, w * v.abs().max(0.1))));
            let b: [Interval; N] = core::array::from_fn(|_| centred(rng.range(-10.0, 10.0), w));
            let x = solve_linear(&a, &b).unwrap_or_else(|| panic!("case {case}: no enclosure at width {w}"));
            let mut spread = [(f64::INFINITY, f64::NEG_INFINITY); N];
            for _ in 0..40 {
                let m = nalgebra::SMatrix::<f64, N, N>::from_fn(|i, j| point_in(&mut rng, a[i][j]));
                let v = nalgebra::SVector::<f64, N>::from_fn(|i, _| point_in(&mut rng, b[i]));
                let sol = m.lu().solve(&v).unwrap();
                for i in 0..N {
                    let slack = 1e-13 * (1.0 + sol[i].abs());
                    assert!(
                        x[i].lo - slack <= sol[i] && sol[i] <= x[i].hi + slack,
                        "case {case}: {} outside {}",
                        sol[i],
                        x[i]
                    );
                    spread[i] = (spread[i].0.min(sol[i]), spread[i].1.max(sol[i]));
                }
            }
            // Tight: no more than a few times the sampled spread (and the rounding floor).
            for i in 0..N {
                let sampled = spread[i].1 - spread[i].0;
                assert!(x[i].width() <= 20.0 * sampled + 1e-12, "case {case}: {} for a spread of {sampled}", x[i]);
            }
        }
        // A box that holds a singular matrix, and one not known at all, are refused.
        let unit = Interval::point(1.0);
        assert!(solve_linear(&[[unit, unit], [unit, Interval::new(0.5, 1.5)]], &[unit, unit]).is_none());
        assert!(solve_linear(&[[Interval::ENTIRE]], &[unit]).is_none());
        assert!(solve_linear(&[[unit]], &[Interval::ENTIRE]).is_none());
        assert!(solve_linear(&[[Interval::point(f64::NAN)]], &[unit]).is_none());
    }

    /// `m⁻¹` by Gauss–Jordan elimination with partial pivoting, on any numbers (counting
    /// ones, for the count); `None` when a pivot is 0 or not a number.
    fn invert<P: Scalar + PartialOrd, const N: usize>(m: &[[P; N]; N]) -> Option<[[P; N]; N]> {
        let (zero, one) = (P::from(0.0), P::from(1.0));
        let mut a = *m;
        let mut inverse: [[P; N]; N] =
            core::array::from_fn(|i| core::array::from_fn(|j| if i == j { one } else { zero }));
        for col in 0..N {
            let (mut pivot, mut size) = (col, a[col][col].abs());
            for (r, row) in a.iter().enumerate().skip(col + 1) {
                let s = row[col].abs();
                if s > size {
                    (pivot, size) = (r, s);
                }
            }
            // Refuses a NaN pivot too.
            if size.partial_cmp(&zero) != Some(core::cmp::Ordering::Greater) {
                return None;
            }
            a.swap(col, pivot);
            inverse.swap(col, pivot);
            let scale = one / a[col][col];
            for v in &mut a[col][col..] {
                *v = *v * scale;
            }
            for v in &mut inverse[col] {
                *v = *v * scale;
            }
            let (pivot_row, pivot_inverse) = (a[col], inverse[col]);
            for r in (0..N).filter(|&r| r != col) {
                let factor = a[r][col];
                for k in col..N {
                    a[r][k] = a[r][k] - factor * pivot_row[k];
                }
                for (v, p) in inverse[r].iter_mut().zip(&pivot_inverse) {
                    *v = *v - factor * *p;
                }
            }
        }
        Some(inverse)
    }

    /// Counting numbers as point intervals: what [`solve_linear_ops`] is checked on.
    impl Enclosing for crate::ops::Counted {
        type Point = Self;
        fn centre(self) -> Self {
            self
        }
        fn at(p: Self) -> Self {
            p
        }
        fn magnitude(self) -> Self {
            self.abs()
        }
        fn upper(self) -> Self {
            self
        }
        fn ball(r: Self) -> Self {
            r
        }
        fn meet_with(self, other: Self) -> Self {
            // One comparison per end on intervals; counted as one, as `max`.
            Scalar::max(self, other)
        }
        fn finite(p: Self) -> bool {
            p.0.is_finite()
        }
        /// Gauss–Jordan's: what the count states for nalgebra's inverse, which performs
        /// fewer operations in all (see [`solve_linear_ops`]).
        fn approximate_inverse<const N: usize>(m: &[[Self; N]; N]) -> Option<[[Self; N]; N]> {
            invert(m)
        }
    }

    #[test]
    fn the_stated_solve_count_is_what_the_solve_performs() {
        use crate::ops::Counted;
        fn case<const N: usize>(rng: &mut Rng) {
            let a: [[Counted; N]; N] = core::array::from_fn(|i| {
                core::array::from_fn(|j| Counted(if i == j { rng.range(3.0, 6.0) } else { rng.range(-1.0, 1.0) }))
            });
            let b: [Counted; N] = core::array::from_fn(|_| Counted(rng.range(-10.0, 10.0)));
            let (x, counted) = Counted::measure(|| krawczyk(&a, &b));
            let x = x.unwrap_or_else(|| panic!("{N}: no solution"));
            assert_eq!(counted, solve_linear_ops(N), "size {N}");
            // And it solved: A x = b.
            for i in 0..N {
                let residual: f64 = (0..N).map(|k| a[i][k].0 * x[k].0).sum::<f64>() - b[i].0;
                assert!(residual.abs() < 1e-12, "size {N}: residual {residual}");
            }
        }
        let mut rng = Rng(62);
        case::<1>(&mut rng);
        case::<2>(&mut rng);
        case::<7>(&mut rng);
        case::<18>(&mut rng);
        case::<30>(&mut rng);
        // A pivot not in place is searched for and swapped: the count does not depend on it.
        let swapped = [[Counted(0.0), Counted(2.0)], [Counted(3.0), Counted(1.0)]];
        let (x, counted) = Counted::measure(|| krawczyk(&swapped, &[Counted(2.0), Counted(4.0)]));
        assert_eq!(counted, solve_linear_ops(2));
        let x = x.expect("regular");
        assert!((x[0].0 - 1.0).abs() < 1e-15 && (x[1].0 - 1.0).abs() < 1e-15, "{x:?}");
    }

    #[test]
    fn nalgebra_matrices_of_intervals() {
        use nalgebra::SMatrix;
        let m = SMatrix::<Interval, 2, 2>::new(
            Interval::point(1.0),
            Interval::new(-1.0, 1.0),
            Interval::new(0.0, 2.0),
            Interval::point(3.0),
        );
        assert_eq!(m[(0, 1)], Interval::new(-1.0, 1.0));
        assert_eq!(m[(1, 0)], Interval::new(0.0, 2.0));
        fn kernel<S: Scalar>(m: &SMatrix<S, 2, 2>) -> S {
            m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)]
        }
        let det = kernel(&m);
        assert!(det.contains(3.0) && det.contains(1.0) && det.contains(5.0), "{det}");
        assert_eq!(kernel(&SMatrix::<f64, 2, 2>::new(1.0, 2.0, 3.0, 4.0)), -2.0);
    }
}
