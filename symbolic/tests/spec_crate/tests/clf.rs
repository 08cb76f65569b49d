//! Issue 36's CLF–CBF problem (adaptive cruise, Ames et al. 2014): the headway and a
//! standstill gap (its last term with α(s) = 10 tanh(s/10)) at priority 0, the speed CLF below them.
//! With one input the lexicographic QP has an exact answer by interval arithmetic, written
//! here from the model's formulas (not the generated kernels): the filter must agree with
//! it to 1e-6 of the input range at thousands of states. Then closed loops: convergence to
//! the desired speed when the road is free, and the headway kept — with the CLF reported
//! relaxed, never the safety verdict — behind a slower car.

use cbfgen::filter::{Cause, InputSource, Verdict};
use cbfgen::system::{ClassK, ControlAffine, FamilyKind};
use spec_crate::adaptive_cruise as acc;

mod common;
use common::Samples;

const MASS: f64 = 1650.0;
const G: f64 = 9.81;
const TIME_HEADWAY: f64 = 1.8;
const Z_MIN: f64 = 5.0;
const V_DESIRED: f64 = 24.0;
const U_MAX: f64 = 0.3 * MASS * G;
const BRAKING: f64 = 0.3 * G;

fn resistance(v: f64) -> f64 {
    0.1 + 5.0 * v + 0.25 * v * v
}

/// Each family's row `a·u + b ≥ 0` by hand, with the spec's poles (headway 1; gap 2, 2
/// and α(s) = 10 tanh(s/10) in the last term; CLF rate 2): [headway, standstill gap, speed goal].
fn rows_by_hand(x: &[f64; 3], tanh_gap: bool) -> [(f64, f64); 3] {
    let (v, z, v_lead) = (x[0], x[1], x[2]);
    let fr = resistance(v);
    // h = z − T_h v − (v_lead − v)²/(2 c g): ḣ = (v_lead − v) + k v̇ with
    // k = −T_h + (v_lead − v)/(c g), v̇ = (u − F_r)/m; the row ḣ + 1 · h ≥ 0.
    let k = -TIME_HEADWAY + (v_lead - v) / BRAKING;
    let h = z - TIME_HEADWAY * v - (v_lead - v).powi(2) / (2.0 * BRAKING);
    let headway = (k / MASS, (v_lead - v) - k * fr / MASS + h);
    // ψ = ḣ + 2h, ψ̇ = ḧ + 2ḣ with ḧ = −(u − F_r)/m; row ψ̇ + 2 α(ψ) ≥ 0.
    let psi = (v_lead - v) + 2.0 * (z - Z_MIN);
    let alpha = if tanh_gap { 10.0 * (psi / 10.0).tanh() } else { psi };
    let gap = (-1.0 / MASS, fr / MASS + 2.0 * (v_lead - v) + 2.0 * alpha);
    // −V̇ − 2V ≥ 0 with V = (v − v_d)², V̇ = 2 (v − v_d)(u − F_r)/m.
    let e = v - V_DESIRED;
    let goal = (-2.0 * e / MASS, 2.0 * e * fr / MASS - 2.0 * e * e);
    [headway, gap, goal]
}

/// The lexicographic QP with one input, exactly: the tiers' rows cut the input interval in
/// turn (a tier that does not fit is met as nearly as the interval allows: its one row's
/// best end), then the input closest to `u_ref`. `None` when tier 0's rows do not fit
/// (not this test's question).
fn exact(tiers: &[&[(f64, f64)]], u_ref: f64) -> Option<f64> {
    let (mut lo, mut hi) = (-U_MAX, U_MAX);
    for (tier, rows) in tiers.iter().enumerate() {
        let (mut l, mut h) = (lo, hi);
        for &(a, b) in *rows {
            if a > 0.0 {
                l = l.max(-b / a);
            } else if a < 0.0 {
                h = h.min(-b / a);
            }
        }
        if l <= h {
            (lo, hi) = (l, h);
        } else if tier == 0 || rows.len() != 1 {
            return None;
        } else {
            let u = if rows[0].0 > 0.0 { hi } else { lo };
            (lo, hi) = (u, u);
        }
    }
    Some(u_ref.clamp(lo, hi))
}

fn params() -> acc::Params {
    let mut p = acc::Params::new(acc::Capacity::default()).unwrap();
    p.standstill_gap[0].z_min = Z_MIN;
    p.speed_goal[0].v_desired = V_DESIRED;
    p
}

#[test]
fn the_generated_families_are_what_the_spec_declared() {
    let families = &acc::FAMILIES;
    assert_eq!(families[acc::family::SPEED_GOAL].kind, FamilyKind::Lyapunov);
    assert_eq!(families[acc::family::SPEED_GOAL].relative_degree, 1);
    assert_eq!(families[acc::family::SPEED_GOAL].defaults.priority, 15);
    assert_eq!(families[acc::family::HEADWAY].kind, FamilyKind::Barrier);
    let alpha = families[acc::family::STANDSTILL_GAP].defaults.class_k;
    assert!(!alpha.is_linear() && alpha.name().contains("tanh"), "{alpha:?}");
    for s in [-400.0, -30.0, -2.0, 0.0, 1e-7, 7.0, 50.0, 400.0] {
        assert!((alpha.eval(s) - 10.0 * f64::tanh(s / 10.0)).abs() <= 1e-14 * 10.0, "α({s})");
    }
}

#[test]
fn the_clf_cbf_filter_agrees_with_the_exact_lexicographic_solve() {
    let params = params();
    for tanh_gap in [true, false] {
        let mut settings = acc::default_settings();
        if !tanh_gap {
            settings.families[acc::family::STANDSTILL_GAP].class_k = ClassK::LINEAR;
        }
        let mut filter = acc::Filter::new(acc::Barriers::new(acc::Capacity::default()).unwrap(), settings).unwrap();
        let mut samples = Samples(7);
        let (mut compared, mut clf_relaxed, mut clf_met_off_reference) = (0, 0, 0);
        while compared < 2000 {
            let x = [samples.uniform(0.0, 35.0), samples.uniform(5.0, 120.0), samples.uniform(0.0, 35.0)];
            let u_ref = samples.uniform(-1.2 * U_MAX, 1.2 * U_MAX).clamp(-1e6, 1e6);
            let [headway, gap, goal] = rows_by_hand(&x, tanh_gap);
            let Some(expected) = exact(&[&[headway, gap], &[goal]], u_ref) else { continue };
            let out = *filter.update(&x, &[u_ref], &params).unwrap();
            assert_eq!(out.source, InputSource::Qp, "x = {x:?}");
            let u = out.u[0];
            assert!(
                (u - expected).abs() <= 1e-6 * 2.0 * U_MAX,
                "x = {x:?}, u_ref = {u_ref}: filter {u}, exact {expected} (tanh {tanh_gap})"
            );
            // Safety is met wherever tier 0 fits; the CLF's verdict is its own.
            assert_eq!(out.safety.verdict, Verdict::Met, "x = {x:?}");
            let clf_value = goal.0 * u + goal.1;
            let scale = goal.1.abs() + goal.0.abs() * (1.0 + u.abs());
            if clf_value < -1e-6 * scale {
                assert_eq!(out.convergence.verdict, Verdict::Relaxed, "x = {x:?}: the CLF is missed by {clf_value}");
                let worst = out.convergence.worst.unwrap();
                assert_eq!(worst.family, acc::family::SPEED_GOAL);
                assert!(matches!(worst.cause, Cause::HigherPriority { .. } | Cause::InputLimit { .. }));
                clf_relaxed += 1;
            } else if clf_value > 1e-6 * scale {
                assert_eq!(out.convergence.verdict, Verdict::Met, "x = {x:?}");
            }
            clf_met_off_reference += usize::from(out.convergence.verdict == Verdict::Met && (u - u_ref).abs() > 1.0);
            compared += 1;
        }
        // Both regimes were exercised: the CLF moving the input, and giving way.
        assert!(clf_relaxed > 100 && clf_met_off_reference > 100, "{clf_relaxed} relaxed, {clf_met_off_reference} met");
    }
}

/// 30 s at 1 kHz behind a lead car at `v_lead`, from 20 m/s with a 100 m gap and a coasting
/// nominal input. Returns the final state, the smallest headway and gap margins measured on
/// the integrated state, and the cycles whose convergence was relaxed.
fn drive(v_lead: f64) -> ([f64; 3], f64, f64, usize, usize) {
    let params = params();
    let mut filter =
        acc::Filter::new(acc::Barriers::new(acc::Capacity::default()).unwrap(), acc::default_settings()).unwrap();
    let mut x = [20.0, 100.0, v_lead];
    let (mut headway, mut gap, mut relaxed, mut unsafe_cycles) = (f64::INFINITY, f64::INFINITY, 0, 0);
    for _ in 0..30_000 {
        let out = *filter.update(&x, &[0.0], &params).unwrap();
        unsafe_cycles += usize::from(out.safety.verdict != Verdict::Met);
        relaxed += usize::from(out.convergence.verdict == Verdict::Relaxed);
        let dx = acc::AdaptiveCruise::xdot(&x, &out.u);
        for (s, d) in x.iter_mut().zip(dx) {
            *s += 1e-3 * d;
        }
        headway = headway.min(x[1] - TIME_HEADWAY * x[0]); // the physical headway, not the barrier
        gap = gap.min(x[1] - Z_MIN);
    }
    (x, headway, gap, relaxed, unsafe_cycles)
}

#[test]
fn on_a_free_road_the_clf_brings_the_desired_speed() {
    let (x, headway, _, relaxed, unsafe_cycles) = drive(26.0);
    assert!((x[0] - V_DESIRED).abs() < 0.05, "speed {} after 30 s", x[0]);
    assert!(headway > 0.0 && unsafe_cycles == 0);
    // Only while the force is at its limit can the decrease at rate 2 not be met.
    assert!(relaxed < 3_000, "convergence relaxed in {relaxed} cycles");
}

#[test]
fn behind_a_slower_car_the_headway_holds_and_the_clf_is_reported_giving_way() {
    let (x, headway, gap, relaxed, unsafe_cycles) = drive(14.0);
    assert!(headway >= -1e-6 && gap > 0.0, "headway {headway}, gap {gap}");
    assert_eq!(unsafe_cycles, 0, "the safety verdict is met every cycle");
    assert!((x[0] - 14.0).abs() < 0.1, "follows the lead's speed: {}", x[0]);
    assert!(relaxed > 10_000, "the CLF gives way to the headway, reported: {relaxed} cycles");
}

#[test]
fn a_lyapunov_family_is_never_put_in_tier_zero() {
    let mut settings = acc::default_settings();
    settings.families[acc::family::SPEED_GOAL].priority = 0;
    let refused = acc::Filter::new(acc::Barriers::new(acc::Capacity::default()).unwrap(), settings);
    let Err(cbfgen::CbfError::OutOfRange { what, .. }) = refused else { panic!("a CLF in tier 0 was accepted") };
    assert!(what.contains("Lyapunov"), "{what}");
}
