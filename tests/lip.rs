//! The 3D-LIP navigation stack against independent truths: numerical integration for the
//! step matrices, hand-computed frames, exact point–rectangle distances for safety, and
//! every MPC row recomputed from the applied plan.

use cbfgen::lip::{Frame, Lip};

/// `p̈ = β²(p − f)` integrated over `T` with classical RK4 in 20 000 sub-steps.
fn integrate_axis(beta: f64, t: f64, p0: f64, v0: f64, f: f64) -> (f64, f64) {
    let steps = 20_000;
    let h = t / steps as f64;
    let deriv = |p: f64, v: f64| (v, beta * beta * (p - f));
    let (mut p, mut v) = (p0, v0);
    for _ in 0..steps {
        let k1 = deriv(p, v);
        let k2 = deriv(p + 0.5 * h * k1.0, v + 0.5 * h * k1.1);
        let k3 = deriv(p + 0.5 * h * k2.0, v + 0.5 * h * k2.1);
        let k4 = deriv(p + h * k3.0, v + h * k3.1);
        p += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        v += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }
    (p, v)
}

#[test]
fn closed_form_step_matches_numerical_integration_of_the_pendulum() {
    for (height, t) in [(1.0, 0.4), (0.8, 0.3), (1.1, 0.5)] {
        let lip = Lip::new(height, t).expect("lip");
        assert!((lip.beta - (9.81f64 / height).sqrt()).abs() < 1e-15);
        for &(p0, v0, f) in &[(0.0, 0.0, 0.1), (0.05, 0.4, -0.1), (-0.2, -0.3, 0.25), (1.3, 0.6, 1.45)] {
            let (p, v) = integrate_axis(lip.beta, t, p0, v0, f);
            let (pc, vc) = lip.axis_step(p0, v0, f);
            assert!((p - pc).abs() < 1e-9 && (v - vc).abs() < 1e-9, "H {height} T {t}: ({pc}, {vc}) vs RK4 ({p}, {v})");
        }
        // The full step applies the same per axis and integrates the heading.
        let x = lip.step(&[0.05, 0.4, -0.2, -0.3, 0.3], &[0.1, -0.1, 0.5]);
        let (px, vx) = integrate_axis(lip.beta, t, 0.05, 0.4, 0.1);
        let (py, vy) = integrate_axis(lip.beta, t, -0.2, -0.3, -0.1);
        for (got, want) in x.iter().zip([px, vx, py, vy, 0.3 + 0.5 * t]) {
            assert!((got - want).abs() < 1e-9, "{x:?}");
        }
    }
    assert!(Lip::new(f64::NAN, 0.4).is_err() && Lip::new(1.0, 0.0).is_err());
}

#[test]
fn frames_match_a_hand_computed_case_and_round_trip() {
    // Frame at (1, 2) turned by 90°: local +x is global +y.
    let frame = Frame::new([1.0, 2.0], std::f64::consts::FRAC_PI_2).expect("frame");
    let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12;
    assert!(close(frame.point_to_global([1.0, 0.0]), [1.0, 3.0]));
    assert!(close(frame.point_to_global([0.5, -2.0]), [3.0, 2.5]));
    assert!(close(frame.vector_to_global([0.3, 0.0]), [0.0, 0.3]), "velocities rotate, never shift");
    let x = frame.state_to_global(&[1.0, 0.3, 0.0, 0.1, 0.2]);
    for (got, want) in x.iter().zip([1.0, -0.1, 3.0, 0.3, std::f64::consts::FRAC_PI_2 + 0.2]) {
        assert!((got - want).abs() < 1e-12, "{x:?}");
    }
    // The next frame sits at the new CoM with the accumulated heading.
    let next = frame.following(&[1.0, 0.3, 0.0, 0.1, 0.2]);
    assert!(close(next.origin, [1.0, 3.0]) && (next.heading - (std::f64::consts::FRAC_PI_2 + 0.2)).abs() < 1e-12);

    // Round trips in a skewed frame.
    let frame = Frame::new([-0.7, 3.1], 2.3).expect("frame");
    let state = [0.4, -0.2, 1.7, 0.6, -0.9];
    let back = frame.state_to_local(&frame.state_to_global(&state));
    assert!(back.iter().zip(state).all(|(a, b)| (a - b).abs() < 1e-12), "{back:?}");
    assert!(close(frame.point_to_local(frame.point_to_global([2.0, -1.0])), [2.0, -1.0]));
    assert!(Frame::new([f64::NAN, 0.0], 0.0).is_err());
}
