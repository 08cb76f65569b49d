//! Regression tests for the filter's output contract (issue 12): each input below once
//! gave NaN labelled as solved, a panic, an abort or an hours-long update. Now each is
//! a typed error or a flagged fallback, and the cycles after it are exactly those of a
//! filter that never saw it.

use cbfgen_tachyon3::catalog::Tachyon3FilterExt;
use std::time::Duration;

use crate::singular;

use cbfgen::filter::{domain, EcbfFilter, EcbfQp, FilterSettings, InputSource, RowSpec, SolverSettings};
use cbfgen::system::{Gains, Poles};
use cbfgen::CbfError;
use cbfgen_multilayer::{CbfQpSettings, IdCbfQp};
use cbfgen_tachyon3::approach::Approach;
use cbfgen_tachyon3::catalog::{self, Capacity, Catalog, Environment, HalfPlane, Row, Tachyon3Filter};
use cbfgen_tachyon3::model::{self, Input, NU};
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};
use cbfgen_tachyon3::terrain::Stairs;

const CAPACITY: Capacity = Capacity::PAPER_WORST_CASE;

/// `cycles` updates along the scripted drive into the stairs: every output, in order.
fn drive(filter: &mut Tachyon3Filter, cycles: usize) -> Vec<(Input, InputSource)> {
    let mut drive = Approach::new(CAPACITY, Stairs::HARDWARE, 0.3, 0.4).expect("drive");
    (0..cycles)
        .map(|_| {
            let out = *filter.update(&drive.x, &drive.nominal_input(), &drive.env).expect("update");
            drive.advance(&out.u, 1e-3);
            (out.u, out.source)
        })
        .collect()
}

/// After `poison` ran on a filter, its next 300 drive cycles equal a fresh filter's,
/// bit for bit, and every one is a finite QP solution.
fn assert_not_poisoned(poison: impl FnOnce(&mut Tachyon3Filter)) {
    let mut exposed = EcbfFilter::with_capacity(CAPACITY, catalog::default_settings()).expect("filter");
    poison(&mut exposed);
    let mut fresh = EcbfFilter::with_capacity(CAPACITY, catalog::default_settings()).expect("filter");
    let (after, reference) = (drive(&mut exposed, 300), drive(&mut fresh, 300));
    assert_eq!(after, reference, "the filter's later cycles changed");
    assert!(after.iter().all(|(u, s)| *s == InputSource::Qp && u.iter().all(|v| v.is_finite())));
}

#[test]
fn a_nominal_input_of_f64_max_is_an_error_and_poisons_nothing() {
    // Before: u = NaN labelled `qp`/solved, then NaN on 10–39 % of ordinary cycles.
    let x = model::standard_posture();
    let env = Environment::new(CAPACITY).expect("env");
    for bad in [f64::MAX, -f64::MAX, 1e300, 2.0 * domain::MAX_INPUT] {
        assert_not_poisoned(|filter| {
            let mut u_ref = [0.0; NU];
            u_ref[3] = bad;
            let err = filter.update(&x, &u_ref, &env).expect_err("out of domain");
            assert!(matches!(err, CbfError::OutOfRange { what: "nominal input", .. }), "{err}");
            let fallback = filter.fallback_input(&[0.0; NU]);
            assert!(fallback.iter().all(|v| v.is_finite()));
        });
    }
    // The edge of the domain itself is served.
    let mut filter = EcbfFilter::with_capacity(CAPACITY, catalog::default_settings()).expect("filter");
    let out = filter.update(&x, &[domain::MAX_INPUT; NU], &env).expect("in domain");
    let s = catalog::default_settings();
    assert!((0..NU).all(|j| out.u[j].is_finite() && out.u[j] >= s.input_min[j] && out.u[j] <= s.input_max[j]));
}

#[test]
fn the_fallback_input_is_finite_even_for_a_nan_nominal_input() {
    // Before: with nothing solved yet, fallback_input([NaN, ..]) returned NaN (clamp
    // passes NaN through), the one input a caller reaches for after an Err.
    let filter = EcbfFilter::with_capacity(CAPACITY, catalog::default_settings()).expect("filter");
    let mut u_ref = [1.0; NU];
    u_ref[0] = f64::NAN;
    u_ref[1] = f64::INFINITY;
    let u = filter.fallback_input(&u_ref);
    assert_eq!((u[0], u[1], u[2]), (0.0, catalog::default_settings().input_max[1], 1.0));
}

#[test]
fn input_limits_beyond_the_domain_are_rejected() {
    // Before: accepted, and every update returned NaN labelled `qp`.
    let s = FilterSettings { input_min: [1e307; NU], input_max: [1e307; NU], ..catalog::default_settings() };
    assert!(matches!(EcbfFilter::with_capacity(CAPACITY, s), Err(CbfError::OutOfRange { what: "input limit", .. })));
    let mut s = catalog::default_settings();
    s.input_weights[0] = 1e300;
    assert!(EcbfFilter::with_capacity(CAPACITY, s).is_err());
    s = catalog::default_settings();
    s.families[0].poles = Poles::from([1e300, 1.0]);
    assert!(EcbfFilter::with_capacity(CAPACITY, s).is_err());
}

#[test]
fn solver_settings_that_could_spin_for_hours_are_rejected() {
    // Before: max_iter = 2³²−1 with tolerances of 5e-324 ran one update for hours.
    type Spoil = fn(&mut SolverSettings);
    let spinning: [(&str, Spoil); 9] = [
        ("max_iter", |s| s.max_iter = u32::MAX),
        ("eps_abs", |s| s.eps_abs = 5e-324),
        ("eps_rel", |s| s.eps_rel = 5e-324),
        ("alpha", |s| s.alpha = 1e-300),
        ("rho", |s| s.rho = 1e300),
        ("sigma", |s| s.sigma = 5e-324),
        ("check_termination", |s| s.check_termination = u32::MAX),
        ("adaptive_rho_interval", |s| s.adaptive_rho_interval = u32::MAX),
        ("time limit", |s| s.time_limit = Some(Duration::from_secs(3600))),
    ];
    for (name, spoil) in spinning {
        let mut s = catalog::default_settings();
        spoil(&mut s.solver);
        let err = EcbfFilter::with_capacity(CAPACITY, s).expect_err(name);
        assert!(err.to_string().contains(name.split(' ').next().unwrap_or(name)), "{name}: {err}");
    }
    // The largest accepted budget is a bounded one.
    let mut s = catalog::default_settings();
    s.solver.max_iter = SolverSettings::MAX_ITERATIONS;
    s.solver.eps_abs = SolverSettings::MIN_TOLERANCE;
    s.solver.eps_rel = SolverSettings::MIN_TOLERANCE;
    assert!(EcbfFilter::with_capacity(CAPACITY, s).is_ok());
}

#[test]
fn a_time_limit_from_seconds_never_panics() {
    // Before: Duration::from_secs_f64(1e20) panicked across the Python boundary.
    for secs in [1e20, f64::MAX, f64::INFINITY, f64::NAN, -1.0, 0.0, 1.5] {
        assert!(SolverSettings::time_limit_from_secs(secs).is_err(), "{secs}");
    }
    assert_eq!(SolverSettings::time_limit_from_secs(1e-3), Ok(Duration::from_millis(1)));
    assert_eq!(SolverSettings::time_limit_from_secs(5e-324), Ok(Duration::from_nanos(1)));
}

#[test]
fn absurd_capacities_are_typed_errors_not_aborts() {
    // Before: capacity overflow panics, and allocation failures that killed the process.
    let huge = [1_000_000, 1_000_000_000, 1 << 62, usize::MAX / 7 + 1, usize::MAX];
    for edges in huge {
        let capacity = Capacity::edges(edges, [1; 6]);
        assert!(matches!(Environment::new(capacity), Err(CbfError::TooLarge { .. })), "edges {edges}");
        assert!(matches!(Catalog::new(capacity), Err(CbfError::TooLarge { .. })), "edges {edges}");
        assert!(matches!(
            EcbfFilter::with_capacity(capacity, catalog::default_settings()),
            Err(CbfError::TooLarge { .. })
        ));
        let capacity = Capacity::edges(1, [edges; 6]);
        assert!(matches!(
            EcbfFilter::with_capacity(capacity, catalog::default_settings()),
            Err(CbfError::TooLarge { .. })
        ));
        assert!(capacity.rows() >= edges, "the row count saturates instead of wrapping");
    }
    let largest = Capacity::edges(Capacity::MAX_EDGES, [Capacity::MAX_FOOTHOLD_EDGES; 6]);
    assert!(Environment::new(largest).is_ok());
}

#[test]
fn a_simulation_longer_than_the_maximum_is_refused_before_it_reserves_anything() {
    // Before: max_time = 1e300 panicked (capacity overflow) and 1e4 reserved 4 GB.
    for max_time in [1e300, 1e4, sim::MAX_SIM_TIME * 1.01, f64::NAN, 0.0, -1.0] {
        let mut config = SimConfig::new(Scenario::Step, true);
        config.max_time = max_time;
        assert!(matches!(sim::run(&config, |_| {}), Err(CbfError::OutOfRange { .. } | CbfError::NonFinite { .. })));
    }
}

#[test]
fn the_qp_refuses_negative_or_absurd_gains() {
    // Before: EcbfQp::new accepted negative gains (a barrier that may grow towards 0).
    let s = catalog::default_settings();
    for gains in [[-1.0, 5.0], [6.0, -5.0], [1e300, 1.0]] {
        let spec = RowSpec { columns: &[0, 1], gains: Gains::new(&gains).expect("two gains"), priority: 0 };
        let qp = EcbfQp::new(&[spec], &s.input_weights, &s.input_min, &s.input_max, s.solver);
        assert!(matches!(qp, Err(CbfError::OutOfRange { what: "ECBF gain", .. })), "{gains:?}");
    }
}

#[test]
fn finite_but_overflowing_rows_never_reach_the_solver() {
    // A row whose values are finite but whose ECBF bound b = L_f² h + k1 L_f h + k0 h
    // overflows is reported like a NaN row; one with huge finite L_g L_f h is normalised
    // without overflow and solved, with a finite answer.
    let s = catalog::default_settings();
    let spec = RowSpec { columns: &[0, 1], gains: Gains::new(&[400.0, 40.0]).expect("two gains"), priority: 0 };
    let mut qp = EcbfQp::new(&[spec], &s.input_weights, &s.input_min, &s.input_max, s.solver).expect("qp");
    let overflowing = Row { lie: [1e307, 1e307, 1e307, 0.0, 0.0], lg: [0.0; NU], active: true, culled: false };
    assert_eq!(qp.solve(&[0.0; NU], &[overflowing], &[true]), Err(CbfError::NonFiniteRow { row: 0 }));
    let mut lg = [0.0; NU];
    (lg[0], lg[1]) = (1e300, -1e300);
    let steep = Row { lie: [-1.0, 0.0, 0.0, 0.0, 0.0], lg, active: true, culled: false };
    let status = qp.solve(&[1.0; NU], &[steep], &[true]).expect("finite row");
    assert!(status.is_solved(), "{status:?}");
    assert!(qp.u().iter().chain(qp.delta()).all(|v| v.is_finite()));
    // h = −1 needs a·u ≥ 400: u0 − u1 ≥ 4e-298, met by u0 = u1 = 1 only by rounding; the
    // optimum keeps u close to u_ref.
    assert!((qp.u()[0] - 1.0).abs() < 1e-3 && (qp.u()[2] - 1.0).abs() < 1e-3, "{:?}", qp.u());
}

#[test]
fn a_toe_at_its_hip_falls_back_flagged_and_the_next_cycle_is_clean() {
    let env = Environment::new(CAPACITY).expect("env");
    assert_not_poisoned(|filter| {
        let out = *filter.update(&singular::toe_at_hip(1), &[0.0; NU], &env).expect("a flagged fallback, not an error");
        assert_eq!(out.source, InputSource::NominalClipped);
        assert!(out.nonfinite_row.is_some() && out.status.is_none() && out.iterations == 0);
        assert!(out.u.iter().all(|v| v.is_finite()));
    });
}

#[test]
fn states_beyond_the_model_domain_are_errors_that_change_nothing() {
    let env = Environment::new(CAPACITY).expect("env");
    for (index, value) in [(0, 1e300), (4, -f64::MAX), (9, 2.0 * model::STATE_LIMIT)] {
        assert_not_poisoned(|filter| {
            let mut x = model::standard_posture();
            x[index] = value;
            let err = filter.update(&x, &[0.0; NU], &env).expect_err("out of domain");
            assert!(matches!(err, CbfError::OutOfRange { what: "state entry", .. }), "{err}");
        });
    }
}

#[test]
fn a_half_plane_of_extreme_scale_is_the_same_half_plane() {
    // Scaling (normal, offset) by any positive factor describes the same set; the stored
    // form is unit-normal, so 1e300 and 1e-300 scales give the same rows.
    let reference = HalfPlane::new([3.0, 4.0], 5.0).expect("plane");
    assert_eq!(reference.normal.as_slice(), &[0.6, 0.8]);
    assert_eq!(reference.offset, 1.0);
    // 1e-310 is subnormal: about 13 significant digits left.
    for scale in [1e300, 1e-300, 1e-310] {
        let p = HalfPlane::new([3.0 * scale, 4.0 * scale], 5.0 * scale).expect("scaled plane");
        assert!((p.normal[0] - 0.6).abs() < 1e-12 && (p.offset - 1.0).abs() < 1e-12, "{scale}: {p:?}");
    }
    // A boundary 1e300 m away is outside the world's domain.
    assert!(HalfPlane::new([1.0, 0.0], 1e300).is_err());
}

#[test]
fn the_multilayer_qp_refuses_unbounded_solver_settings_and_inputs() {
    let barrier = cbfgen_multilayer::SineBarrier::new(0.2, 1.0, 0.0).expect("barrier");
    let mut settings = CbfQpSettings::default();
    settings.solver.max_iter = u32::MAX;
    assert!(IdCbfQp::new(settings, barrier).is_err());
    settings = CbfQpSettings::default();
    settings.solver.eps_abs = 5e-324;
    assert!(IdCbfQp::new(settings, barrier).is_err());
    let mut qp = IdCbfQp::new(CbfQpSettings::default(), barrier).expect("qp");
    assert!(qp.solve(0.0, &[1.0, 0.0], f64::MAX).is_err());
    let out = qp.solve(0.0, &[1.0, 0.0], 0.0).expect("an ordinary cycle after the refused one");
    assert!(out.u.is_finite());
}
