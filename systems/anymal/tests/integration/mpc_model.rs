//! The MPC's generated model against finite differences: every Jacobian of `flow`, `feet`
//! and `orientation` against central differences of the generated values themselves; the
//! flow against the control-affine kernels `drift` and `input_matrix`; each foot's
//! velocity against the time derivative of its position along the flow; and the Euler
//! rates against the rotation's own motion, R' = R [w]x. (Pinocchio's side — mass, centre
//! of mass, inertia, feet — is in python/tests/test_anymal_mpc.py.)

// Index loops mirror the formulas.
#![allow(clippy::needless_range_loop)]

use cbfgen_anymal::mpc_generated::{self as gen, NU, NX};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A state a walking robot can be in: any heading, a tilted trunk, joints within limits,
/// moderate rates; and forces and joint velocities of a trot's size.
fn random_point(rng: &mut ChaCha8Rng) -> ([f64; NX], [f64; NU]) {
    let mut x = [0.0; NX];
    x[0] = rng.random_range(-0.4..0.4);
    x[1] = rng.random_range(-0.4..0.4);
    x[2] = rng.random_range(-3.1..3.1);
    for i in 3..12 {
        x[i] = rng.random_range(-1.0..1.0);
    }
    for j in 0..12 {
        x[12 + j] = rng.random_range(gen::Q_MIN[j]..gen::Q_MAX[j]);
    }
    let mut u = [0.0; NU];
    for i in 0..12 {
        u[i] = rng.random_range(-300.0..300.0);
    }
    for j in 0..12 {
        u[12 + j] = rng.random_range(-3.0..3.0);
    }
    (x, u)
}

/// The worst difference between `analytic[r][c]` and the central difference of
/// `value(x)[r]` in `x[c]`, relative to the larger of 1 and the entry.
fn worst_against_differences<const R: usize, const C: usize>(
    analytic: &[[f64; C]; R],
    at: &[f64; C],
    value: impl Fn(&[f64; C]) -> [f64; R],
) -> f64 {
    let mut worst = 0.0_f64;
    for c in 0..C {
        let h = 1e-6 * (1.0 + at[c].abs());
        let (mut plus, mut minus) = (*at, *at);
        plus[c] += h;
        minus[c] -= h;
        let (vp, vm) = (value(&plus), value(&minus));
        for r in 0..R {
            let difference = (vp[r] - vm[r]) / (2.0 * h);
            worst = worst.max((difference - analytic[r][c]).abs() / (1.0 + analytic[r][c].abs()));
        }
    }
    worst
}

fn flat<const R: usize, const C: usize>(m: [[f64; C]; R]) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

#[test]
fn the_flow_and_its_jacobians_agree_with_finite_differences_and_the_affine_kernels() {
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    for _ in 0..200 {
        let (x, u) = random_point(&mut rng);
        let (xdot, a, b) = gen::flow(&x, &u);
        let worst_a = worst_against_differences(&a, &x, |x| gen::flow(x, &u).0);
        let worst_b = worst_against_differences(&b, &u, |u| gen::flow(&x, u).0);
        assert!(worst_a < 1e-6 && worst_b < 1e-6, "flow Jacobians: {worst_a:e} {worst_b:e}");
        let (f, g) = (gen::drift(&x), gen::input_matrix(&x));
        for i in 0..NX {
            let affine = f[i] + (0..NU).map(|j| g[i][j] * u[j]).sum::<f64>();
            assert!((affine - xdot[i]).abs() <= 1e-9 * (1.0 + affine.abs()), "x'[{i}]: {affine} vs {}", xdot[i]);
            for j in 0..NU {
                assert_eq!(g[i][j], b[i][j], "g[{i}][{j}]");
            }
        }
    }
}

#[test]
fn the_feet_and_their_jacobians_agree_with_finite_differences_and_the_flow() {
    let mut rng = ChaCha8Rng::seed_from_u64(19);
    let positions = |x: &[f64; NX]| -> [f64; 12] { flat(gen::feet(x, &[0.0; NU]).0).try_into().unwrap() };
    for _ in 0..200 {
        let (x, u) = random_point(&mut rng);
        let (_, jp, velocities, jvx, jvu) = gen::feet(&x, &u);
        let worst_p = worst_against_differences(&jp, &x, positions);
        let velocity_of = |x: &[f64; NX], u: &[f64; NU]| -> [f64; 12] { flat(gen::feet(x, u).2).try_into().unwrap() };
        let worst_vx = worst_against_differences(&jvx, &x, |x| velocity_of(x, &u));
        let worst_vu = worst_against_differences(&jvu, &u, |u| velocity_of(&x, u));
        assert!(worst_p < 1e-6 && worst_vx < 1e-6 && worst_vu < 1e-6, "{worst_p:e} {worst_vx:e} {worst_vu:e}");
        // A foot's velocity is its position's rate along the flow.
        let xdot = gen::flow(&x, &u).0;
        let h = 1e-6;
        let (mut ahead, mut behind) = (x, x);
        for i in 0..NX {
            ahead[i] += h * xdot[i];
            behind[i] -= h * xdot[i];
        }
        let (pa, pb) = (positions(&ahead), positions(&behind));
        for (k, v) in flat(velocities).iter().enumerate() {
            let rate = (pa[k] - pb[k]) / (2.0 * h);
            assert!((rate - v).abs() < 1e-6 * (1.0 + v.abs()), "foot coordinate {k}: {rate} vs {v}");
        }
    }
}

#[test]
fn the_euler_rates_turn_the_rotation_as_the_angular_velocity_does() {
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    for _ in 0..200 {
        let (x, u) = random_point(&mut rng);
        let (rotation, derivatives) = gen::orientation(&x);
        let xdot = gen::flow(&x, &u).0;
        // R' from the Euler rates, against R [w]x.
        let w = [x[6], x[7], x[8]];
        let skew = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
        for i in 0..3 {
            for j in 0..3 {
                let from_euler: f64 = (0..3).map(|a| derivatives[a][3 * i + j] * xdot[a]).sum();
                let from_w: f64 = (0..3).map(|k| rotation[i][k] * skew[k][j]).sum();
                assert!((from_euler - from_w).abs() < 1e-9 * (1.0 + from_w.abs()), "R'[{i}][{j}]");
            }
        }
        let flat_rotation = |x: &[f64; NX]| -> [f64; 9] { flat(gen::orientation(x).0).try_into().unwrap() };
        let mut jacobian = [[0.0; NX]; 9];
        for r in 0..9 {
            for a in 0..3 {
                jacobian[r][a] = derivatives[a][r];
            }
        }
        assert!(worst_against_differences(&jacobian, &x, flat_rotation) < 1e-6);
    }
}
