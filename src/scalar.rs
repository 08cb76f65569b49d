//! The number type generated kernels compute in.
//!
//! Every generated kernel is generic over [`Scalar`]: the filter runs it on `f64` (the
//! same machine code as a kernel written for `f64`: each method below is the `f64`
//! function of the same name, inlined), and the sampled-data certificate runs the same
//! straight line on [`Interval`](crate::interval::Interval)s, to enclose a row over every
//! state the plant can reach between two samples ([`crate::filter::between_samples`]).
//! One source for each formula, whatever it is evaluated on.
//!
//! ```
//! use cbfgen::scalar::Scalar;
//!
//! // What a generated kernel looks like: straight-line code over any scalar.
//! fn h<S: Scalar>(q: S, qd: S) -> S {
//!     S::from(2.0) * q - qd.sin()
//! }
//! assert_eq!(h(1.0, 0.5), 2.0 - 0.5f64.sin());
//! ```

use core::fmt::Debug;
use core::ops::{Add, Div, Mul, Neg, Sub};

/// What a generated kernel needs of its numbers: the field operations, `f64` constants
/// (`S::from(2.0)`), and the functions the generator emits. The batched forms
/// (`*_lanes`, `*_lane`) are the runtime's [`crate::lanes`] on `f64`: whose stated error
/// bounds the SSAT and sphere–box certificates count.
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + From<f64>
    + PartialEq
    + Debug
    + 'static
{
    /// `x²`: `x * x` on `f64` (the same bits), and on intervals the square's true range
    /// (`[-1, 2]` squares to `[0, 4]`, where `x * x` would give `[-2, 4]`).
    fn sqr(self) -> Self;
    /// `√x`.
    fn sqrt(self) -> Self;
    /// `eˣ` (libm's; the batched calls are [`Scalar::exp_lanes`]).
    fn exp(self) -> Self;
    /// `ln x` (libm's).
    fn ln(self) -> Self;
    /// `|x|`.
    fn abs(self) -> Self;
    /// `sin x`.
    fn sin(self) -> Self;
    /// `cos x`.
    fn cos(self) -> Self;
    /// `tan x`.
    fn tan(self) -> Self;
    /// `asin x`.
    fn asin(self) -> Self;
    /// `acos x`.
    fn acos(self) -> Self;
    /// `atan x`.
    fn atan(self) -> Self;
    /// `atan2(self, x)`: the angle of `(x, self)`.
    fn atan2(self, x: Self) -> Self;
    /// `sinh x`.
    fn sinh(self) -> Self;
    /// `cosh x`.
    fn cosh(self) -> Self;
    /// `tanh x` (libm's; the batched calls are [`Scalar::tanh_lanes`]).
    fn tanh(self) -> Self;
    /// `xᵉ` for a non-integer, non-half exponent.
    fn powf(self, e: Self) -> Self;
    /// The larger of two (a runtime max of the spec's).
    fn max(self, other: Self) -> Self;
    /// [`crate::lanes::exp`] of every element.
    fn exp_lanes<const N: usize>(x: [Self; N]) -> [Self; N];
    /// [`crate::lanes::tanh`] of every element.
    fn tanh_lanes<const N: usize>(x: [Self; N]) -> [Self; N];
    /// [`crate::lanes::ln`] of every element.
    fn ln_lanes<const N: usize>(x: [Self; N]) -> [Self; N];
    /// [`crate::lanes::exp1`].
    fn exp_lane(self) -> Self;
    /// [`crate::lanes::tanh1`].
    fn tanh_lane(self) -> Self;
    /// [`crate::lanes::ln1`].
    fn ln_lane(self) -> Self;
}

impl Scalar for f64 {
    #[inline(always)]
    fn sqr(self) -> Self {
        self * self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        f64::ln(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline(always)]
    fn tan(self) -> Self {
        f64::tan(self)
    }
    #[inline(always)]
    fn asin(self) -> Self {
        f64::asin(self)
    }
    #[inline(always)]
    fn acos(self) -> Self {
        f64::acos(self)
    }
    #[inline(always)]
    fn atan(self) -> Self {
        f64::atan(self)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn sinh(self) -> Self {
        f64::sinh(self)
    }
    #[inline(always)]
    fn cosh(self) -> Self {
        f64::cosh(self)
    }
    #[inline(always)]
    fn tanh(self) -> Self {
        f64::tanh(self)
    }
    #[inline(always)]
    fn powf(self, e: Self) -> Self {
        f64::powf(self, e)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f64::max(self, other)
    }
    #[inline(always)]
    fn exp_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        crate::lanes::exp(x)
    }
    #[inline(always)]
    fn tanh_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        crate::lanes::tanh(x)
    }
    #[inline(always)]
    fn ln_lanes<const N: usize>(x: [Self; N]) -> [Self; N] {
        crate::lanes::ln(x)
    }
    #[inline(always)]
    fn exp_lane(self) -> Self {
        crate::lanes::exp1(self)
    }
    #[inline(always)]
    fn tanh_lane(self) -> Self {
        crate::lanes::tanh1(self)
    }
    #[inline(always)]
    fn ln_lane(self) -> Self {
        crate::lanes::ln1(self)
    }
}
