//! The ECBF filter against independent truths: Clarabel (an interior-point solver) on the
//! same problem written out directly in original units, stage by stage (each tier's least
//! largest violation, then the closest input), hand-solved projections, and the
//! documented fault behaviour.

// Index loops mirror the formulas (rows × inputs) in this file.
#![allow(clippy::needless_range_loop)]

use crate::kkt;
use cbfgen_tachyon3::catalog::Tachyon3FilterExt;
use cbfgen_testkit::boxes as common;

use cbfgen::filter::{
    Backend, EcbfFilter, EcbfQp, FilterSettings, InputSource, QpStatus, RowSpec, Solver, SolverSettings,
};
use cbfgen::system::{Gains, Poles};
use cbfgen::CbfError;
use cbfgen_tachyon3::approach::Approach;
use cbfgen_tachyon3::catalog::{self, Capacity, Environment, Row, Tachyon3Filter};
use cbfgen_tachyon3::model::{self, Input, State, NU, NX, TOE_BLOCK};
use cbfgen_tachyon3::terrain::Stairs;
use kkt::{check, clarabel_reference, cost};
use rand::Rng;

const CAPACITY: Capacity = Capacity::PAPER_WORST_CASE;

/// States along the scripted drive into the stairs (approach, contact, pushing), plus
/// random perturbations of them, with random nominal inputs for the latter.
fn instances(seed: u64) -> Vec<(State, Input, Environment)> {
    let mut out = Vec::new();
    let mut drive = Approach::new(CAPACITY, Stairs::HARDWARE, 0.3, 0.4).expect("drive");
    let mut filter = EcbfFilter::with_capacity(CAPACITY, catalog::default_settings()).expect("filter");
    for k in 0..3000 {
        let u_ref = drive.nominal_input();
        if k % 20 == 0 {
            out.push((drive.x, u_ref, drive.env.clone()));
        }
        let u = filter.update(&drive.x, &u_ref, &drive.env).expect("finite").u;
        drive.advance(&u, 1e-3);
    }
    let scenario = out.len();
    let mut rng = common::rng(seed);
    for k in 0..120 {
        let (mut x, _, env) = out[k % scenario].clone();
        recoverable_perturbation(&mut rng, &mut x);
        let u_ref: Input = std::array::from_fn(|j| 0.8 * model::INPUT_LIMITS[j] * rng.random_range(-1.0..1.0));
        out.push((x, u_ref, env));
    }
    out
}

/// Velocities ±0.1 (m or rad)/s, body ±1 cm / ±0.02 rad, toes up to 1 cm higher or
/// ±1 cm along x: states the filter can bring back within the input limits.
fn recoverable_perturbation(rng: &mut impl Rng, x: &mut State) {
    for (i, v) in x.iter_mut().enumerate().skip(4) {
        let toe = i.checked_sub(TOE_BLOCK).map(|k| k % 4);
        *v += match (i, toe) {
            (4 | 5 | 9 | 10 | 11, _) | (_, Some(2 | 3)) => rng.random_range(-0.1..0.1),
            (_, Some(1)) => rng.random_range(0.0..0.01),
            _ => rng.random_range(-0.01..0.01),
        };
    }
}

#[test]
fn every_backend_agrees_with_clarabel_stage_by_stage_on_scenario_and_random_instances() {
    let cases = instances(11);
    assert!(cases.len() >= 200);
    for backend in Solver::ALL {
        agrees_with_clarabel(&cases, backend);
    }
}

fn agrees_with_clarabel(cases: &[(State, Input, Environment)], backend: Solver) {
    let mut settings = catalog::default_settings();
    settings.solver.backend = backend;
    let mut filter = EcbfFilter::with_capacity(CAPACITY, settings).expect("filter");
    let (mut worst_du, mut corrected, mut continued, mut polished, mut dense) = (0.0f64, 0, 0, 0, 0);
    for (k, (x, u_ref, env)) in cases.iter().enumerate() {
        // Each instance starts from the previous one's warm start. One that needs more
        // than the per-cycle iteration budget is handed back flagged; repeating the cycle
        // continues from that iterate, as the next control cycle would.
        let mut out = *filter.update(x, u_ref, env).expect("finite instance");
        for _ in 0..20 {
            if out.source != InputSource::Unconverged {
                break;
            }
            continued += 1;
            out = *filter.update(x, u_ref, env).expect("finite instance");
        }
        assert_eq!(out.source, InputSource::Qp, "{backend:?} instance {k}: {:?}", out.status);
        if backend != Solver::Osqp {
            assert_eq!(out.backend, Some(Backend::Dense), "{backend:?} instance {k}: the dense solve must verify");
        }
        // Every tier as good as Clarabel finds possible, and the input closest to u_ref.
        let relaxed = check(&filter, &out.u, u_ref).unwrap_or_else(|e| panic!("{backend:?} instance {k}: {e}"));
        assert_eq!(relaxed, !out.safety.is_met(), "{backend:?} instance {k}: the verdict must match");
        let (reference, theirs) = clarabel_reference(&filter, &out.u, u_ref);
        let ours = cost(&filter, &out.u, u_ref);
        assert!(ours <= theirs + 1e-7 * (1.0 + theirs), "{backend:?} instance {k}: cost {ours} > Clarabel's {theirs}");
        let s = filter.settings();
        let du = (0..NU)
            .map(|j| (out.u[j] - reference[j]).abs() / (1.0 + s.input_min[j].abs().max(s.input_max[j].abs())))
            .fold(0.0, f64::max);
        assert!(du <= 1e-5, "{backend:?} instance {k}: |u - u_clarabel| = {du:.2e} of the input scale");
        worst_du = worst_du.max(du);
        corrected += usize::from((0..NU).any(|j| (out.u[j] - u_ref[j]).abs() > 1e-2));
        polished += usize::from(out.polished);
        dense += usize::from(out.backend == Some(Backend::Dense));
    }
    // The instances must exercise the constraints, not just return u_ref.
    assert!(corrected >= cases.len() / 4, "only {corrected} of {} instances bent the input", cases.len());
    eprintln!(
        "{backend:?}: {} instances, {corrected} corrected, {dense} dense, {polished} polished, {continued} extra cycles: max |du| {worst_du:.2e}",
        cases.len()
    );
}

/// A QP of a single ECBF row over all 17 inputs.
fn single_row_qp(columns: &[usize], weights: &[f64; NU], limits: f64) -> EcbfQp<NU> {
    let spec = RowSpec { columns, gains: Gains::from_poles(&Poles::from([2.0, 3.0])), priority: 0 };
    EcbfQp::new(&[spec], weights, &[-limits; NU], &[limits; NU], SolverSettings::default()).expect("qp")
}

#[test]
fn one_row_is_the_weighted_projection_onto_its_half_space_by_hand() {
    // min Σ w_j (u_j − r_j)²  s.t.  a·u ≥ −b: if a·r + b < 0, u = r + λ a/w with
    // λ = −(a·r + b) / Σ a_j²/w_j; the row then holds exactly.
    let mut rng = common::rng(5);
    for case in 0..20 {
        let columns: Vec<usize> = (0..NU).collect();
        let weights: [f64; NU] = std::array::from_fn(|_| rng.random_range(0.5..4.0));
        let mut qp = single_row_qp(&columns, &weights, 1e3);
        let lg: [f64; NU] = std::array::from_fn(|_| rng.random_range(-2.0..2.0));
        let lie = [rng.random_range(-0.1..0.3), rng.random_range(-1.0..1.0), rng.random_range(-3.0..3.0)];
        let u_ref: Input = std::array::from_fn(|_| rng.random_range(-3.0..3.0));
        let b = lie[2] + 5.0 * lie[1] + 6.0 * lie[0];
        let a_r = (0..NU).map(|j| lg[j] * u_ref[j]).sum::<f64>() + b;
        let lambda = (-a_r).max(0.0) / (0..NU).map(|j| lg[j] * lg[j] / weights[j]).sum::<f64>();
        let row = Row { lie: [lie[0], lie[1], lie[2], 0.0, 0.0], lg, active: true, culled: false };
        assert_eq!(qp.solve(&u_ref, &[row], &[true]), Ok(QpStatus::Solved));
        for j in 0..NU {
            let want = u_ref[j] + lambda * lg[j] / weights[j];
            assert!((qp.u()[j] - want).abs() <= 1e-9, "case {case}, u[{j}]: {} vs {want}", qp.u()[j]);
        }
        let u = *qp.u();
        assert_eq!(qp.assess(&u), 0, "case {case}: the row holds");
    }
}

#[test]
fn without_binding_rows_the_input_box_is_a_clip_by_hand() {
    let mut qp = single_row_qp(&[0, 3], &[1.0; NU], 2.0);
    let u_ref: Input = std::array::from_fn(|j| 4.0 * ((j as f64) / 8.0 - 1.0)); // −4 … 4
    let row = Row { lie: [1.0, 0.0, 0.0, 0.0, 0.0], lg: [0.0; NU], active: true, culled: false };
    assert_eq!(qp.solve(&u_ref, &[row], &[false]), Ok(QpStatus::Solved));
    for j in 0..NU {
        assert!((qp.u()[j] - u_ref[j].clamp(-2.0, 2.0)).abs() <= 1e-6, "u[{j}]");
    }
}

#[test]
fn a_nominal_input_that_satisfies_every_row_passes_unchanged() {
    let mut filter = EcbfFilter::with_capacity(CAPACITY, catalog::default_settings()).expect("filter");
    let drive = Approach::new(CAPACITY, Stairs::HARDWARE, 0.4, 0.2).expect("drive");
    let mut rng = common::rng(9);
    let mut checked = 0;
    for _ in 0..50 {
        // Small accelerations, toes lifting (they stand on the floor, h = 0).
        let u_ref: Input = std::array::from_fn(|j| {
            let lifting = j >= 5 && (j - 5) % 2 == 1;
            0.1 * model::INPUT_LIMITS[j]
                * if lifting { rng.random_range(0.2..1.0) } else { rng.random_range(-1.0..1.0) }
        });
        let mut out = *filter.update(&drive.x, &u_ref, &drive.env).expect("finite");
        for _ in 0..5 {
            if out.source == InputSource::Qp {
                break;
            }
            out = *filter.update(&drive.x, &u_ref, &drive.env).expect("finite");
        }
        // Independent check that u_ref satisfies every active ECBF row with margin.
        let s = filter.settings();
        let satisfied = filter.rows().iter().zip(filter.active()).zip(filter.slots()).all(|((row, &on), slot)| {
            let b = kkt::ecbf_bound(&row.lie, s.family(slot.family.index()).poles.as_slice());
            !on || (0..NU).map(|j| row.lg[j] * u_ref[j]).sum::<f64>() + b > 1e-3
        });
        if !satisfied {
            continue;
        }
        checked += 1;
        assert_eq!(out.source, InputSource::Qp);
        for j in 0..NU {
            assert!((out.u[j] - u_ref[j]).abs() <= 1e-3, "u[{j}] = {} vs u_ref {}", out.u[j], u_ref[j]);
        }
        let max_slack = filter.delta().iter().fold(0.0f64, |m, d| m.max(d.abs()));
        assert!(max_slack <= 1e-6, "slack {max_slack:.2e}");
    }
    assert!(checked >= 25, "only {checked} nominal inputs satisfied every row");
}

fn drive_and_filter(settings: FilterSettings<NU>) -> (Approach, Tachyon3Filter) {
    let drive = Approach::new(CAPACITY, Stairs::HARDWARE, 0.05, 0.3).expect("drive");
    (drive, EcbfFilter::with_capacity(CAPACITY, settings).expect("filter"))
}

/// Update on the drive's state until the QP converges (a cold start may take a few
/// cycles' iteration budgets).
fn converged_update(filter: &mut Tachyon3Filter, drive: &Approach) -> cbfgen::filter::FilterOutput<NU> {
    for _ in 0..20 {
        let out = *filter.update(&drive.x, &drive.nominal_input(), &drive.env).expect("finite");
        if out.source == InputSource::Qp {
            return out;
        }
    }
    panic!("the QP did not converge in 20 cycles");
}

#[test]
fn nan_or_infinite_state_and_nominal_input_are_errors_that_change_nothing() {
    let (drive, mut filter) = drive_and_filter(catalog::default_settings());
    let u_ref = drive.nominal_input();
    let before = converged_update(&mut filter, &drive);
    for i in [0, 7, 13, NX - 1] {
        for bad in [f64::NAN, f64::INFINITY] {
            let mut x = drive.x;
            x[i] = bad;
            assert!(matches!(filter.update(&x, &u_ref, &drive.env), Err(CbfError::NonFinite { .. })));
        }
    }
    let mut bad_u = u_ref;
    bad_u[3] = f64::NEG_INFINITY;
    assert!(matches!(filter.update(&drive.x, &bad_u, &drive.env), Err(CbfError::NonFinite { .. })));
    assert_eq!(*filter.output(), before, "a rejected update must leave the last output");
    assert_eq!(filter.fallback_input(&bad_u), before.u);
    let other = Environment::new(Capacity::edges(1, [1; 6])).unwrap();
    assert_eq!(filter.update(&drive.x, &u_ref, &other).err(), Some(CbfError::CapacityMismatch));
}

#[test]
fn a_degenerate_leg_falls_back_to_the_last_safe_input_with_a_flag() {
    let (drive, mut filter) = drive_and_filter(catalog::default_settings());
    // Toe exactly at its hip: knee length 0, whose derivative is 0/0.
    let mut broken = drive.x;
    let hip = model::HIP_POSITIONS[0];
    broken[TOE_BLOCK] = broken[model::BODY_X] + hip[0];
    broken[TOE_BLOCK + 1] = broken[model::BODY_Z] + hip[2];
    let nominal = [50.0; NU]; // beyond every limit: the clipped fallback is visible
    let first = *filter.update(&broken, &nominal, &drive.env).expect("ok with a fallback");
    assert_eq!(first.source, InputSource::NominalClipped);
    assert_eq!(first.status, None);
    assert!(first.nonfinite_row.is_some());
    assert_eq!(first.u, model::INPUT_LIMITS);

    let good = converged_update(&mut filter, &drive);
    let slot = filter.slot(first.nonfinite_row.expect("flagged"));
    assert_eq!(slot.leg, Some(0), "the flagged row is one of leg 0's");
    let fallback = *filter.update(&broken, &nominal, &drive.env).expect("ok with a fallback");
    assert_eq!((fallback.source, fallback.u, fallback.consecutive_fallbacks), (InputSource::LastSafe, good.u, 1));
    let again = *filter.update(&broken, &nominal, &drive.env).expect("ok with a fallback");
    assert_eq!(again.consecutive_fallbacks, 2);
}

#[test]
fn an_iteration_or_time_limit_hands_back_the_clipped_iterate_flagged() {
    // OSQP alone (no polish): its iterate is handed on flagged, inside the box, never as
    // an optimum, at an iteration limit and at a time limit alike.
    let mut settings = catalog::default_settings();
    settings.solver.backend = Solver::Osqp;
    settings.solver.max_iter = 25;
    settings.solver.polish = false;
    let (drive, mut filter) = drive_and_filter(settings);
    let nominal = [50.0; NU]; // beyond every input limit: many bounds and rows bind
    let out = *filter.update(&drive.x, &nominal, &drive.env).expect("ok, flagged");
    assert_eq!((out.status, out.source), (Some(QpStatus::MaxIterations), InputSource::Unconverged));
    let s = filter.settings();
    assert!((0..NU).all(|j| (s.input_min[j]..=s.input_max[j]).contains(&out.u[j])), "clipped to the box");
    assert!(out.consecutive_fallbacks >= 1);

    let mut settings = catalog::default_settings();
    settings.solver.backend = Solver::Osqp;
    settings.solver.time_limit = Some(std::time::Duration::from_nanos(1));
    settings.solver.polish = false;
    let (drive, mut filter) = drive_and_filter(settings);
    let out = *filter.update(&drive.x, &[50.0; NU], &drive.env).expect("ok, flagged");
    assert_eq!((out.status, out.source), (Some(QpStatus::TimeLimit), InputSource::Unconverged));
}

#[test]
fn the_polish_turns_a_cut_short_iterate_into_the_verified_optimum() {
    // Two ADMM iterations from a cold start are far from tolerance; the dense solve started
    // from the face they suggest verifies the optimum, which Clarabel confirms.
    let mut settings = catalog::default_settings();
    settings.solver.backend = Solver::Osqp;
    settings.solver.max_iter = 2;
    let (drive, mut filter) = drive_and_filter(settings);
    let u_ref = [50.0; NU];
    let out = *filter.update(&drive.x, &u_ref, &drive.env).expect("finite");
    assert_eq!((out.status, out.source, out.polished), (Some(QpStatus::Solved), InputSource::Qp, true));
    check(&filter, &out.u, &u_ref).expect("the verified optimum");
    let (reference, _) = clarabel_reference(&filter, &out.u, &u_ref);
    let du = (0..NU).map(|j| (out.u[j] - reference[j]).abs()).fold(0.0, f64::max);
    assert!(du <= 1e-5, "|u - u_clarabel| = {du:.2e}");
}

#[test]
fn an_unpolished_osqp_answer_is_never_reported_as_the_optimum() {
    // Issue 32: with eps_rel = 1 OSQP calls its first iterate solved. Without the polish
    // that iterate is handed on flagged, never as `Qp`.
    let mut settings = catalog::default_settings();
    settings.solver.backend = Solver::Osqp;
    settings.solver.eps_rel = 1.0;
    settings.solver.polish = false;
    let (drive, mut filter) = drive_and_filter(settings);
    for _ in 0..5 {
        let out = *filter.update(&drive.x, &drive.nominal_input(), &drive.env).expect("finite");
        assert_ne!(out.source, InputSource::Qp, "an unverified OSQP answer was labelled qp: {:?}", out.status);
        assert_eq!(out.source, InputSource::Unconverged);
    }
}

#[test]
fn after_an_absurd_cycle_no_unverified_answer_is_labelled_qp() {
    // Issue 32's reproducer: eps_rel = 1 (OSQP calls almost anything solved), a dense
    // budget of 2, a box of ±1e6; one cycle at an absurd state inside the domain, then
    // ordinary ones. The old filter labelled OSQP's unpolished iterate `qp` for 15 cycles
    // (cost 1.7e13 against an optimum of 0). Every `qp` answer must be the optimum.
    let mut settings = catalog::default_settings();
    settings.solver.eps_rel = 1.0;
    settings.solver.dense_max_steps = 2;
    settings.input_min = [-1e6; NU];
    settings.input_max = [1e6; NU];
    let (drive, mut filter) = drive_and_filter(settings);
    let mut absurd = drive.x;
    for v in absurd.iter_mut().skip(4) {
        *v *= 1e3;
    }
    let u_ref = drive.nominal_input();
    let out = *filter.update(&absurd, &[1e5; NU], &drive.env).expect("in the domain");
    assert!(out.u.iter().all(|v| v.is_finite()));
    let mut qp = 0;
    for _ in 0..30 {
        let out = *filter.update(&drive.x, &u_ref, &drive.env).expect("finite");
        if out.source == InputSource::Qp {
            qp += 1;
            check(&filter, &out.u, &u_ref).unwrap_or_else(|e| panic!("a qp answer that is not the optimum: {e}"));
        }
    }
    assert!(qp >= 25, "the filter recovered in {} of 30 cycles", qp);
}

#[test]
fn an_exhausted_dense_budget_falls_back_to_osqp_flagged_or_hands_back_its_iterate() {
    // A full command against the stairs from a cold start: one row added per stage cannot
    // find the rows and saturated inputs that bind.
    let u_ref = [50.0; NU];
    let mut settings = catalog::default_settings();
    settings.solver.dense_max_steps = 1;
    let (drive, mut filter) = drive_and_filter(settings.clone());
    let out = *filter.update(&drive.x, &u_ref, &drive.env).expect("finite");
    assert!(out.dense_fallback, "one step must not verify here");
    assert_eq!(out.backend, Some(Backend::Osqp));
    // Verified from OSQP's face (under the same budget), the optimum; else flagged.
    if out.polished {
        assert_eq!(out.source, InputSource::Qp);
        check(&filter, &out.u, &u_ref).expect("the verified optimum");
    } else {
        assert_eq!(out.source, InputSource::Unconverged);
    }

    settings.solver.backend = Solver::Dense;
    let (drive, mut filter) = drive_and_filter(settings);
    let out = *filter.update(&drive.x, &u_ref, &drive.env).expect("finite");
    assert_eq!(
        (out.backend, out.status, out.source),
        (Some(Backend::Dense), Some(QpStatus::MaxIterations), InputSource::Unconverged)
    );
    assert_eq!(out.iterations, 0, "OSQP must not run under Solver::Dense");
    let s = filter.settings();
    assert!((0..NU).all(|j| (s.input_min[j]..=s.input_max[j]).contains(&out.u[j])), "inside the box");
    // The verdict is measured at the unverified point, not assumed.
    let relaxed_here = check(&filter, &out.u, &u_ref).is_err() || !out.safety.is_met();
    assert!(relaxed_here || out.safety.is_met());
    // With the same budget, each cycle continues from where the last stopped.
    let mut cycles = 1;
    while filter.update(&drive.x, &u_ref, &drive.env).expect("finite").source != InputSource::Qp {
        cycles += 1;
        assert!(cycles < 100, "a budget of one row per stage made no progress in 100 cycles");
    }
    check(&filter, &filter.output().u, &u_ref).expect("the verified optimum");
}

#[test]
fn invalid_settings_are_rejected_at_construction() {
    let edits: [fn(&mut FilterSettings<NU>); 6] = [
        |s| s.input_weights[2] = 0.0,
        |s| s.families[1].poles = Poles::from([-1.0, 20.0]),
        |s| s.families[3].priority = 16,
        |s| s.input_min[4] = s.input_max[4] + 1.0,
        |s| s.solver.alpha = 2.5,
        |s| s.solver.eps_abs = 0.0,
    ];
    for (k, edit) in edits.iter().enumerate() {
        let mut s = catalog::default_settings();
        edit(&mut s);
        assert!(EcbfFilter::with_capacity(CAPACITY, s).is_err(), "edit {k} was accepted");
    }
    let bad_row = RowSpec { columns: &[3, 3], gains: Gains::new(&[1.0, 1.0]).expect("two gains"), priority: 0 };
    let err = EcbfQp::new(&[bad_row], &[1.0; NU], &[-1.0; NU], &[1.0; NU], SolverSettings::default());
    assert_eq!(err.err(), Some(CbfError::BadRowPattern { row: 0, column: 3 }));
}

/// One row with relative degree 1, `h = params`, on a single input: the smallest barrier
/// set that can hand the filter a NaN `h` (no built-in family can any more: the toe–edge
/// rows, the last source, are finite for every parameter in the domain).
struct OneRow {
    rows: [cbfgen::system::Row<1>; 1],
}

const ONE_ROW_FAMILY: [cbfgen::system::FamilyInfo; 1] = [cbfgen::system::FamilyInfo {
    name: "one",
    kind: cbfgen::system::FamilyKind::Barrier,
    relative_degree: 1,
    row_names: &["one"],
    members: &[],
    instances: cbfgen::system::InstanceKind::Fixed,
    count: 1,
    params: &[],
    defaults: cbfgen::system::FamilyParams {
        poles: Poles::repeated(10.0, 1),
        priority: 0,
        activation: 1.0,
        class_k: cbfgen::system::ClassK::LINEAR,
    },
}];

const ONE_ROW_LAYOUT: [cbfgen::system::RowLayout; 1] =
    [cbfgen::system::RowLayout { family: 0, member: 0, instance: 0, row: 0, columns: &[0] }];

impl cbfgen::system::BarrierSet<1> for OneRow {
    type State = [f64; 1];
    type Params = f64;

    fn families(&self) -> &[cbfgen::system::FamilyInfo] {
        &ONE_ROW_FAMILY
    }

    fn layout(&self) -> &[cbfgen::system::RowLayout] {
        &ONE_ROW_LAYOUT
    }

    fn rows(&self) -> &[cbfgen::system::Row<1>] {
        &self.rows
    }

    fn evaluate(&mut self, _t: f64, _x: &[f64; 1], h: &f64) -> Result<(), CbfError> {
        self.rows[0] = cbfgen::system::Row { lie: [*h, 0.0, 0.0, 0.0, 0.0], lg: [1.0], active: true, culled: false };
        Ok(())
    }
}

#[test]
fn a_nan_h_takes_part_despite_the_activation_threshold_and_is_reported() {
    // A NaN h compares false against the activation threshold (1.0 here); the filter
    // must not read that as "inactive" and drop the row, but flag it and fall back.
    let settings = FilterSettings::defaults(&ONE_ROW_FAMILY, [-1.0], [1.0]);
    let mut filter = EcbfFilter::new(OneRow { rows: [cbfgen::system::Row::ZERO] }, settings).expect("filter");
    let out = *filter.update(&[0.0], &[0.5], &f64::NAN).expect("a flagged fallback, not an error");
    assert_eq!((out.source, out.nonfinite_row, out.active_rows), (InputSource::NominalClipped, Some(0), 1));
    assert!(out.u.iter().all(|v| v.is_finite()));
    // Above the threshold a finite row leaves the QP; below it, it binds.
    let out = *filter.update(&[0.0], &[-0.5], &2.0).expect("solved");
    assert_eq!((out.source, out.active_rows, out.u), (InputSource::Qp, 0, [-0.5]));
    let out = *filter.update(&[0.0], &[-0.5], &0.01).expect("solved");
    assert_eq!((out.source, out.active_rows), (InputSource::Qp, 1));
    assert!(out.u[0] > -0.5 + 1e-3, "the row must push u up from the nominal: {:?}", out.u);
}
