//! `exp`, `tanh` and `ln` of many independent arguments at once, in SIMD lanes.
//!
//! Generated kernels call these on arrays: every transcendental call of one kind whose
//! argument does not depend on another such call is gathered into one call here (the
//! SSAT value's 24 `tanh`, then its 15 `exp`). A scalar libm call cannot overlap with
//! its neighbours; here each function is a branch-free polynomial that the compiler
//! runs 2 (SSE2), 4 (AVX2) or 8 (AVX-512) lanes wide, picked at run time.
//!
//! # Accuracy
//! Each result is within a stated number of units in the last place (ulp: the step
//! between adjacent doubles at the result) of the **correctly rounded** value, over the
//! whole `f64` domain: [`EXP_MAX_ULP`], [`TANH_MAX_ULP`], [`LN_MAX_ULP`]. The tests
//! measure that against CORE-MATH (a correctly rounded libm) at over 10⁶ points per
//! function, ends of the domain, subnormal results and arguments included. Special values
//! follow IEEE 754: `exp(±∞) = ∞, 0`; `tanh(±∞) = ±1`, `tanh(±0) = ±0`; `ln(0) = −∞`,
//! `ln(x < 0) = NaN`, `ln(∞) = ∞`; NaN in, NaN out. The SSAT and sphere–box certificates
//! count these bounds in their rounding guards ([`crate::ssat#rounding-guard`]).
//!
//! # Determinism
//! Every lane runs the same sequence of IEEE-754 additions, multiplications and divisions
//! (no fused multiply–add, which Rust never forms on its own), so a result does not depend
//! on the lane width, the instruction set picked, or the array's length: it is the same
//! bit pattern on every x86-64 machine, and the same as [`exp1`], [`tanh1`] and [`ln1`],
//! the one-argument forms.
//!
//! ```
//! let [a, b] = cbfgen::lanes::tanh([0.5, -2.0]);
//! assert!((a - 0.5f64.tanh()).abs() <= 2.0 * f64::EPSILON * a.abs());
//! assert_eq!(b, -cbfgen::lanes::tanh1(2.0));
//! ```

/// Largest distance of [`exp`] from the correctly rounded `eˣ`, in ulps of the result.
pub const EXP_MAX_ULP: u64 = 1;
/// Largest distance of [`tanh`] from the correctly rounded `tanh x`, in ulps.
pub const TANH_MAX_ULP: u64 = 2;
/// Largest distance of [`ln`] from the correctly rounded `ln x`, in ulps.
pub const LN_MAX_ULP: u64 = 1;

/// `log2(e)`, to pick the power of two nearest `eˣ`.
const LOG2_E: f64 = std::f64::consts::LOG2_E;
/// `ln 2` split in two: the high part has 32 significant bits, so `k·LN2_HI` is exact for
/// every `|k| < 2²¹`, and the reduced argument `x − k·ln 2` keeps its low bits.
const LN2_HI: f64 = f64::from_bits(0x3FE6_2E42_FEE0_0000);
/// `ln 2 − LN2_HI`, rounded.
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// `1.5·2⁵²`: adding it rounds a double below 2⁵¹ in magnitude to the nearest integer,
/// which then sits in the low bits of the sum.
const ROUND_SHIFT: f64 = 6_755_399_441_055_744.0;
/// Beyond these, `eˣ` overflows to `∞` or rounds to `0`; clamping first keeps the
/// exponent arithmetic in range.
const EXP_ARG_MAX: f64 = 710.0;
const EXP_ARG_MIN: f64 = -746.0;
/// `tanh(x)` rounds to `±1` for `|x| ≥ 19.07`; `2|x|` is clamped here.
const TANH_DOUBLED_ARG_MAX: f64 = 40.0;

/// `1/k!` for `k = 2..=13`: the Taylor series of `eʳ − 1 − r`, exact to below `2⁻⁵⁸` of
/// `eʳ` on the reduced range `|r| ≤ ln(2)/2`.
const INV_FACTORIAL: [f64; 12] = [
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// `2/(2j + 1)` for `j = 1..=9`: `ln(1+f) = 2 atanh(s) = 2s + s·Σ_j 2s²ʲ/(2j+1)` with
/// `s = f/(2+f)`, `|s| ≤ 0.172`; the first term left out is below `2⁻⁵⁵` of the sum.
const ATANH_SERIES: [f64; 9] =
    [2.0 / 3.0, 2.0 / 5.0, 2.0 / 7.0, 2.0 / 9.0, 2.0 / 11.0, 2.0 / 13.0, 2.0 / 15.0, 2.0 / 17.0, 2.0 / 19.0];

/// `2ⁿ` for `−1022 ≤ n ≤ 1023`, from the exponent bits.
#[inline(always)]
fn pow2(n: i64) -> f64 {
    f64::from_bits((n.wrapping_add(1023) as u64) << 52)
}

/// `x = k·ln 2 + r` with `k` an integer (returned as a double and as an integer) and
/// `|r| ≤ ln(2)/2` (slightly more after rounding). `x` must lie in `[−746, 710]` or be
/// NaN (then `r` is NaN).
#[inline(always)]
fn reduce(x: f64) -> (f64, i64, f64) {
    let shifted = x * LOG2_E + ROUND_SHIFT;
    let k = shifted - ROUND_SHIFT;
    let k_int = (shifted.to_bits() as i64).wrapping_sub(ROUND_SHIFT.to_bits() as i64);
    let r = (x - k * LN2_HI) - k * LN2_LO;
    (k, k_int, r)
}

/// `eʳ − 1` for a reduced `r`, to within an ulp: `r + r²·(1/2 + r/6 + …)`.
#[inline(always)]
fn expm1_reduced(r: f64) -> f64 {
    let mut p = INV_FACTORIAL[11];
    for &c in INV_FACTORIAL[..11].iter().rev() {
        p = p * r + c;
    }
    r + (r * r) * p
}

/// `eˣ` of one argument (the same bits as one lane of [`exp`]).
#[inline(always)]
pub fn exp1(x: f64) -> f64 {
    // Comparisons, not `f64::min`/`max`, so that NaN passes through.
    let x = if x > EXP_ARG_MAX { EXP_ARG_MAX } else { x };
    let x = if x < EXP_ARG_MIN { EXP_ARG_MIN } else { x };
    let (_, k, r) = reduce(x);
    let mantissa = 1.0 + expm1_reduced(r);
    // 2ᵏ in two halves, each a normal double for every k in [−1076, 1025]; the first
    // product is exact, the second rounds once, into the subnormals or to ∞ when the
    // result lies there.
    let k_half = k >> 1;
    mantissa * pow2(k_half) * pow2(k.wrapping_sub(k_half))
}

/// `tanh x` of one argument (the same bits as one lane of [`tanh`]).
#[inline(always)]
pub fn tanh1(x: f64) -> f64 {
    // tanh|x| = e/(e + 2) with e = exp(2|x|) − 1: relative accuracy from |x| = 0 (where
    // e = 2|x| exactly) to where tanh rounds to 1; the sign is put back exactly.
    let doubled = 2.0 * x.abs();
    let doubled = if doubled > TANH_DOUBLED_ARG_MAX { TANH_DOUBLED_ARG_MAX } else { doubled };
    let (_, k, r) = reduce(doubled);
    let scale = pow2(k); // k ∈ [0, 58]
    let e = scale * expm1_reduced(r) + (scale - 1.0);
    (e / (e + 2.0)).copysign(x)
}

/// `ln x` of one argument (the same bits as one lane of [`ln`]).
#[inline(always)]
pub fn ln1(x: f64) -> f64 {
    const MANTISSA_BITS: u64 = (1 << 52) - 1;
    const TWO_POW_52: f64 = 4_503_599_627_370_496.0;
    // Subnormals (and 0, negatives, which are replaced below) are scaled into the normals.
    let subnormal = x < f64::MIN_POSITIVE;
    let scaled = if subnormal { x * TWO_POW_52 } else { x };
    let bits = scaled.to_bits();
    let exponent = ((bits >> 52) & 0x7FF) as i64 - 1023 - if subnormal { 52 } else { 0 };
    // x = 2^k · m with m in [√½, √2), so that f = m − 1 is small and exact (Sterbenz).
    let m = f64::from_bits((bits & MANTISSA_BITS) | (1023 << 52));
    let high = m > std::f64::consts::SQRT_2;
    let m = if high { 0.5 * m } else { m };
    let k = (exponent + i64::from(high)) as f64;
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let s2 = s * s;
    let mut series = ATANH_SERIES[8];
    for &c in ATANH_SERIES[..8].iter().rev() {
        series = series * s2 + c;
    }
    let series = series * s2;
    // ln(1+f) = f − (f²/2 − s·(f²/2 + series)): the identity 2s = f − s·f leaves s's
    // rounding only in the small correction, not in the leading f.
    let half_f2 = 0.5 * f * f;
    let low = k * LN2_LO + s * (half_f2 + series);
    let y = k * LN2_HI + (f - (half_f2 - low));
    let y = if x == 0.0 { f64::NEG_INFINITY } else { y };
    let y = if x < 0.0 { f64::NAN } else { y };
    if x == f64::INFINITY || x.is_nan() {
        x
    } else {
        y
    }
}

/// `f` on every lane, in a loop the compiler vectorises for the instruction set this
/// function is compiled for.
#[inline(always)]
fn map_lanes<const N: usize>(x: [f64; N], f: impl Fn(f64) -> f64) -> [f64; N] {
    let mut out = [0.0; N];
    for (o, &xi) in out.iter_mut().zip(&x) {
        *o = f(xi);
    }
    out
}

/// One function of the three, compiled three times: baseline x86-64 (SSE2), AVX2 and
/// AVX-512F, the widest the processor has picked at run time (a cached feature check).
/// The lanes compute the same bits whichever runs (see [Determinism](self#determinism)).
macro_rules! lanes_fn {
    ($(#[$doc:meta])* $name:ident, $scalar:ident) => {
        $(#[$doc])*
        #[inline]
        pub fn $name<const N: usize>(x: [f64; N]) -> [f64; N] {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                fn avx512<const N: usize>(x: [f64; N]) -> [f64; N] {
                    map_lanes(x, $scalar)
                }
                #[target_feature(enable = "avx2")]
                fn avx2<const N: usize>(x: [f64; N]) -> [f64; N] {
                    map_lanes(x, $scalar)
                }
                if N >= 8 && std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the processor has AVX-512F, checked just above.
                    return unsafe { avx512(x) };
                }
                if N >= 3 && std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the processor has AVX2, checked just above.
                    return unsafe { avx2(x) };
                }
            }
            map_lanes(x, $scalar)
        }
    };
}

lanes_fn!(
    /// `eˣ` of every element, within [`EXP_MAX_ULP`] of the correctly rounded value.
    exp,
    exp1
);
lanes_fn!(
    /// `tanh x` of every element, within [`TANH_MAX_ULP`] of the correctly rounded value.
    tanh,
    tanh1
);
lanes_fn!(
    /// `ln x` of every element, within [`LN_MAX_ULP`] of the correctly rounded value.
    ln,
    ln1
);
