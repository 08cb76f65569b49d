//! `cbfgen::lanes` against CORE-MATH, a correctly rounded libm: every result within the
//! stated ulp bound at over 10⁶ points per function spanning its whole domain (ends,
//! subnormal arguments and results, special values), and every lane width giving the
//! bits of the one-argument form.

use cbfgen::lanes;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Doubles in order as integers, so that adjacent doubles differ by 1 (−0 and +0 both 0).
fn ordinal(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    if bits < 0 {
        -(bits & i64::MAX)
    } else {
        bits
    }
}

/// Steps between `got` and the correctly rounded `want` (0 for equal specials, `u64::MAX`
/// for a NaN where a number was due, or the reverse).
fn ulps(got: f64, want: f64) -> u64 {
    match (got.is_nan(), want.is_nan()) {
        (true, true) => 0,
        (false, false) => ordinal(got).abs_diff(ordinal(want)),
        _ => u64::MAX,
    }
}

/// The largest error over `points` and the argument where it occurred; every point is
/// checked through the batched call (in chunks of an odd width, so that remainders run
/// too) and through the one-argument form, which must agree to the bit.
fn worst(
    points: &[f64],
    batched: fn([f64; 37]) -> [f64; 37],
    one: fn(f64) -> f64,
    reference: fn(f64) -> f64,
) -> (u64, f64) {
    let mut worst = (0, f64::NAN);
    for chunk in points.chunks(37) {
        let mut x = [1.0; 37];
        x[..chunk.len()].copy_from_slice(chunk);
        let y = batched(x);
        for (&xi, &yi) in x.iter().zip(&y) {
            assert_eq!(yi.to_bits(), one(xi).to_bits(), "lanes and one-argument form differ at {xi:e}");
            let e = ulps(yi, reference(xi));
            if e > worst.0 {
                worst = (e, xi);
            }
        }
    }
    worst
}

fn uniform(rng: &mut ChaCha8Rng, n: usize, lo: f64, hi: f64) -> Vec<f64> {
    (0..n).map(|_| rng.random_range(lo..=hi)).collect()
}

/// `±10^u` with `u` uniform: every binade from `lo` to `hi` alike.
fn log_uniform(rng: &mut ChaCha8Rng, n: usize, lo: f64, hi: f64) -> Vec<f64> {
    let (a, b) = (lo.log10(), hi.log10());
    (0..n)
        .map(|_| {
            let m = 10f64.powf(rng.random_range(a..=b));
            if rng.random() {
                m
            } else {
                -m
            }
        })
        .collect()
}

/// Random bit patterns: every double alike, whatever its exponent.
fn any_bits(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| f64::from_bits(rng.random())).collect()
}

/// Values a test of any libm should try.
fn specials() -> Vec<f64> {
    let mut v = vec![
        0.0,
        -0.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        f64::MIN_POSITIVE,
        f64::MAX,
        f64::MIN,
        f64::EPSILON,
        1.0,
        -1.0,
        2.0,
        0.5,
    ];
    for k in 0..=52 {
        let sub = f64::from_bits(1u64 << k); // every power-of-two subnormal
        v.extend([sub, -sub, f64::from_bits((1u64 << k) + 1), f64::from_bits((1u64 << 52) - 1 - k)]);
    }
    v
}

/// Every neighbour within `k` steps of each of `centres`.
fn around(centres: &[f64], k: i64) -> Vec<f64> {
    centres.iter().flat_map(|&c| (-k..=k).map(move |d| f64::from_bits((c.to_bits() as i64 + d) as u64))).collect()
}

#[test]
fn exp_is_within_its_bound_over_its_whole_domain() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut x = uniform(&mut rng, 600_000, -746.0, 710.0);
    x.extend(uniform(&mut rng, 200_000, -1.0, 1.0));
    x.extend(log_uniform(&mut rng, 200_000, 1e-320, 1.0));
    x.extend(any_bits(&mut rng, 100_000));
    x.extend(specials());
    // Overflow (709.78), the start of the subnormal results (−708.40), the last result that
    // is not 0 (−745.13), the reduction's rounding points (±ln(2)/2) and 0.
    x.extend(around(
        &[709.782712893384, -708.3964185322641, -745.1332191019411, 0.34657359027997264, -0.34657359027997264, 0.0],
        2_000,
    ));
    assert!(x.len() > 1_000_000);
    let (e, at) = worst(&x, lanes::exp, lanes::exp1, core_math::exp);
    assert!(e <= lanes::EXP_MAX_ULP, "exp: {e} ulp at {at:e}");
}

#[test]
fn tanh_is_within_its_bound_over_its_whole_domain() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut x = uniform(&mut rng, 500_000, -20.0, 20.0);
    x.extend(log_uniform(&mut rng, 400_000, 1e-320, 1e3));
    x.extend(any_bits(&mut rng, 100_000));
    x.extend(specials());
    // Where the reduction's integer changes (ln(2)/4), where tanh rounds to 1, the clamp.
    x.extend(around(&[0.17328679513998632, 0.5198603854199589, 19.061547465398498, 20.0, 1e-8], 2_000));
    assert!(x.len() > 1_000_000);
    let (e, at) = worst(&x, lanes::tanh, lanes::tanh1, core_math::tanh);
    assert!(e <= lanes::TANH_MAX_ULP, "tanh: {e} ulp at {at:e}");
}

#[test]
fn ln_is_within_its_bound_over_its_whole_domain() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    // Positive bit patterns span every binade, subnormals included; then near 1, where ln
    // is small, the SSAT's [1, 15] and a few negatives.
    let mut x: Vec<f64> = any_bits(&mut rng, 500_000).into_iter().map(f64::abs).collect();
    x.extend(uniform(&mut rng, 200_000, 0.5, 2.0));
    x.extend(log_uniform(&mut rng, 100_000, 1e-16, 1e-2).into_iter().map(|d| 1.0 + d));
    x.extend(uniform(&mut rng, 200_000, 1.0, 15.0));
    x.extend(any_bits(&mut rng, 10_000));
    x.extend(specials());
    x.extend(around(&[1.0, std::f64::consts::SQRT_2, std::f64::consts::FRAC_1_SQRT_2, f64::MIN_POSITIVE, 15.0], 2_000));
    assert!(x.len() > 1_000_000);
    let (e, at) = worst(&x, lanes::ln, lanes::ln1, core_math::log);
    assert!(e <= lanes::LN_MAX_ULP, "ln: {e} ulp at {at:e}");
}

#[test]
fn special_values_follow_ieee_754() {
    assert_eq!(lanes::exp([f64::INFINITY, f64::NEG_INFINITY, 0.0]), [f64::INFINITY, 0.0, 1.0]);
    assert!(lanes::exp1(f64::NAN).is_nan() && lanes::tanh1(f64::NAN).is_nan() && lanes::ln1(f64::NAN).is_nan());
    assert_eq!(lanes::tanh([f64::INFINITY, f64::NEG_INFINITY]), [1.0, -1.0]);
    assert!(lanes::tanh1(-0.0).is_sign_negative() && lanes::tanh1(-0.0) == 0.0);
    assert_eq!(lanes::ln([0.0, -0.0, f64::INFINITY, 1.0]), [f64::NEG_INFINITY, f64::NEG_INFINITY, f64::INFINITY, 0.0]);
    assert!(lanes::ln1(-1.0).is_nan() && lanes::ln1(f64::NEG_INFINITY).is_nan());
}

/// The bits of `batched` on every element equal `one`'s, whatever width picks the path.
fn same_bits<const N: usize>(x: &[f64], batched: fn([f64; N]) -> [f64; N], one: fn(f64) -> f64) {
    for chunk in x.chunks(N) {
        let mut lanes = [0.5; N];
        lanes[..chunk.len()].copy_from_slice(chunk);
        for (xi, yi) in lanes.iter().zip(batched(lanes)) {
            assert_eq!(yi.to_bits(), one(*xi).to_bits(), "width {N} at {xi:e}");
        }
    }
}

#[test]
fn every_width_gives_the_bits_of_the_one_argument_form() {
    // Widths 1-2 run the baseline (SSE2) code, 3-7 the AVX2 code and 8 up the AVX-512 code
    // where the processor has them: one result whatever the machine picks.
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let mut x = uniform(&mut rng, 20_000, -30.0, 30.0);
    x.extend(any_bits(&mut rng, 20_000));
    x.extend(specials());
    let positive: Vec<f64> = x.iter().map(|v| v.abs()).collect();
    same_bits::<1>(&x, lanes::exp, lanes::exp1);
    same_bits::<2>(&x, lanes::exp, lanes::exp1);
    same_bits::<5>(&x, lanes::exp, lanes::exp1);
    same_bits::<8>(&x, lanes::exp, lanes::exp1);
    same_bits::<1>(&x, lanes::tanh, lanes::tanh1);
    same_bits::<3>(&x, lanes::tanh, lanes::tanh1);
    same_bits::<24>(&x, lanes::tanh, lanes::tanh1);
    same_bits::<2>(&positive, lanes::ln, lanes::ln1);
    same_bits::<7>(&positive, lanes::ln, lanes::ln1);
    same_bits::<16>(&positive, lanes::ln, lanes::ln1);
}
