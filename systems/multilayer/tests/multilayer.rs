//! The multi-layer controller against independent truths: the generated row against
//! finite differences of the hand-written barrier, the CBF-QP against its closed-form
//! optimum, the MPC plan against its own constraints, and the paper's qualitative result.

use cbfgen::filter::InputSource;
use cbfgen::CbfError;
use cbfgen_multilayer::scenario::{self, run_all};
use cbfgen_multilayer::{
    CbfQpSettings, IdCbfQp, KinematicMpc, MpcMode, MpcSettings, MultiLayerController, ScenarioConfig, SineBarrier,
};
use rand::{Rng, SeedableRng};

/// h written out by hand, not from the generator.
fn h_by_hand(q: f64, t: f64, [a, w, c]: [f64; 3]) -> f64 {
    q - a * (w * t).sin() - c
}

#[test]
fn generated_row_matches_finite_differences_in_state_and_time() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let tau = 1e-4;
    for _ in 0..500 {
        let p = [rng.random_range(0.0..2.0), rng.random_range(0.1..5.0), rng.random_range(-1.0..1.0)];
        let barrier = SineBarrier::new(p[0], p[1], p[2]).unwrap();
        let (q, v, t) = (rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), rng.random_range(0.0..20.0));
        let row = barrier.row(&[q, v], t);
        // Exact flow of q'' = u over τ, with t advancing alongside (the augmented field).
        let h_along = |s: f64, u: f64| h_by_hand(q + v * s + 0.5 * u * s * s, t + s, p);
        let first = (h_along(tau, 0.0) - h_along(-tau, 0.0)) / (2.0 * tau);
        let second = |u: f64| (h_along(tau, u) - 2.0 * h_along(0.0, u) + h_along(-tau, u)) / (tau * tau);
        let scale = 1.0 + p[0] * p[1] * p[1];
        assert!((row.lie[0] - h_by_hand(q, t, p)).abs() < 1e-12, "h");
        assert!((row.lie[1] - first).abs() < 1e-6 * scale, "L_f h {} vs {first}", row.lie[1]);
        assert!((row.lie[2] - second(0.0)).abs() < 1e-4 * scale, "L_f² h {} vs {}", row.lie[2], second(0.0));
        assert!((row.lg_lf - (second(1.0) - second(0.0))).abs() < 1e-4, "L_g L_f h {}", row.lg_lf);
        // The ∂h/∂t terms are really there: a frozen boundary would give L_f h = q̇.
        let dh_dt = -p[0] * p[1] * (p[1] * t).cos();
        assert!((row.lie[1] - (v + dh_dt)).abs() < 1e-12);
    }
}

#[test]
fn every_variant_keeps_the_position_above_the_boundary() {
    let config = ScenarioConfig::default();
    let results = run_all(&config).unwrap();
    assert_eq!(results.len(), 3);
    for r in &results {
        assert_eq!(r.trace.t.len(), 10_000);
        let worst = r
            .trace
            .t
            .iter()
            .zip(&r.trace.q)
            .map(|(&t, &q)| h_by_hand(q, t, config.barrier.parameters()))
            .fold(f64::INFINITY, f64::min);
        assert!(worst >= -1e-4, "{}: h reaches {worst}", r.mode.name());
        assert!((worst - r.min_h).abs() < 1e-9, "reported min h {} vs {worst}", r.min_h);
        // And it does meet the boundary: the reference q = 0 is below the crests.
        assert!(worst < 0.05, "{}: never came near the boundary (min h {worst})", r.mode.name());
    }
}

#[test]
fn without_barrier_information_the_mpc_leaves_a_large_input_peak_to_the_qp() {
    let config = ScenarioConfig::default();
    let results = run_all(&config).unwrap();
    let (cbf, state, none) = (&results[0], &results[1], &results[2]);
    assert!(matches!(cbf.mode, MpcMode::DiscreteCbf { .. }) && none.mode == MpcMode::Unconstrained);
    assert!(none.peak_u > 2.0 * cbf.peak_u, "peaks: CBF in MPC {}, none {}", cbf.peak_u, none.peak_u);
    assert!(none.peak_u > 1.5 * state.peak_u, "peaks: state constraint {}, none {}", state.peak_u, none.peak_u);
    // The peak is the CBF-QP overriding the MPC near the boundary, not the start.
    let k = none.trace.t.iter().position(|&t| t == none.peak_u_time).unwrap();
    assert!((none.trace.u[k] - none.trace.desired_accel[k]).abs() > 3.0);
    // The boundary rises at up to 2 m/s: the ECBF binds a few tenths of a metre before it.
    assert!(none.trace.h[k] < 0.3, "h at the peak: {}", none.trace.h[k]);
}

#[test]
fn the_cbf_qp_returns_the_closed_form_optimum() {
    // Against the row written out by hand (h = q − A sin ωt − c, L_f h = q̇ − Aω cos ωt,
    // L_f² h = Aω² sin ωt, L_g L_f h = 1) and gains expanded by hand (k0 = p², k1 = 2p):
    // one variable, one half-line, so the optimum is a_des projected onto it.
    let [a, w, c] = [1.0, 2.0, -0.5];
    let mut qp = IdCbfQp::new(CbfQpSettings::default(), SineBarrier::new(a, w, c).unwrap()).unwrap();
    let (k0, k1) = (100.0, 20.0);
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let mut binding = 0;
    for _ in 0..2000 {
        let (q, v, t) = (rng.random_range(-1.5..2.5), rng.random_range(-3.0..3.0), rng.random_range(0.0..20.0));
        let a_des = rng.random_range(-20.0..20.0);
        let out = qp.solve(t, &[q, v], a_des).unwrap();
        let b = a * w * w * (w * t).sin() + k1 * (v - a * w * (w * t).cos()) + k0 * h_by_hand(q, t, [a, w, c]);
        let want = a_des.max(-b);
        binding += usize::from(want != a_des);
        assert_eq!(out.source, InputSource::Qp);
        // Exact but for the slack's give, (want − a_des)/(1 + w_δ) with w_δ = 1e8.
        let give = (want - a_des).abs() / (1.0 + 1e8);
        assert!((out.u - want).abs() <= 1e-9 * (1.0 + want.abs()) + 1.01 * give, "u {} vs {want}", out.u);
        assert!(out.u + b >= -1e-5 * (1.0 + b.abs()), "ECBF row violated");
        assert!(out.slack < 1e-6 * (1.0 + b.abs()), "slack {} on a row the input can meet", out.slack);
    }
    assert!(binding > 200 && binding < 1800, "both cases must occur: {binding} binding");
}

#[test]
fn the_mpc_plan_satisfies_its_dynamics_and_barrier_rows() {
    let barrier = SineBarrier::new(1.0, 2.0, -0.5).unwrap();
    let settings = MpcSettings::default();
    let (dt, n) = (settings.dt, settings.horizon);
    for mode in [MpcMode::DiscreteCbf { gamma: 0.2 }, MpcMode::StateConstraint, MpcMode::Unconstrained] {
        let mut mpc = KinematicMpc::new(settings, mode, barrier).unwrap();
        let mut binding_rows = 0;
        for &(t, x) in &[(2.9, [0.0, -0.3]), (0.0, [1.0, 0.0]), (6.0, [0.1, 0.5])] {
            let out = mpc.solve(t, &x).unwrap();
            let (q, v) = (mpc.planned_positions(), mpc.planned_velocities());
            assert!((q[0] - x[0]).abs() < 1e-5 && (v[0] - x[1]).abs() < 1e-5);
            assert!((out.desired_accel - (v[1] - v[0]) / dt).abs() < 1e-9);
            for k in 0..n {
                assert!((q[k + 1] - q[k] - dt * v[k]).abs() < 1e-5, "dynamics row {k}");
            }
            let h = |k: usize| q[k] - barrier.boundary(t + k as f64 * dt);
            for k in 2..=n {
                let slack = match mode {
                    MpcMode::DiscreteCbf { gamma } => h(k) - (1.0 - gamma) * h(k - 1),
                    MpcMode::StateConstraint => h(k),
                    MpcMode::Unconstrained => f64::INFINITY,
                };
                assert!(slack >= -1e-4, "{}: row {k} at t {t}: {slack}", mode.name());
                binding_rows += usize::from(slack < 1e-3);
            }
        }
        // At t = 2.9 the boundary rises through q = 0: the barrier rows must bind.
        assert_eq!(binding_rows > 0, mode != MpcMode::Unconstrained, "{}", mode.name());
    }
}

#[test]
fn bad_numbers_give_errors_not_panics() {
    let config = ScenarioConfig::default();
    let mut controller =
        MultiLayerController::new(config.barrier, MpcMode::StateConstraint, config.mpc, config.qp, config.cycle_dt)
            .unwrap();
    for (t, x) in [(f64::NAN, [1.0, 0.0]), (0.0, [f64::NAN, 0.0]), (0.0, [1.0, f64::INFINITY])] {
        assert!(matches!(controller.control(t, &x), Err(CbfError::NonFinite { .. })));
    }
    assert!(controller.control(0.0, &[1.0, 0.0]).unwrap().u.is_finite(), "a good cycle still works after bad ones");
    let mut qp = IdCbfQp::new(CbfQpSettings::default(), config.barrier).unwrap();
    assert!(matches!(qp.solve(0.0, &[1.0, 0.0], f64::NAN), Err(CbfError::NonFinite { .. })));
    assert!(matches!(qp.solve(f64::INFINITY, &[1.0, 0.0], 0.0), Err(CbfError::NonFinite { .. })));
    assert!(matches!(qp.solve(0.0, &[1e300, 0.0], 0.0), Err(CbfError::OutOfRange { .. })));
    assert!(IdCbfQp::new(CbfQpSettings::default(), SineBarrier::new(1e300, 1.0, 0.0).unwrap()).is_err());
    assert!(SineBarrier::new(f64::NAN, 1.0, 0.0).is_err());
    let mut mpc = KinematicMpc::new(config.mpc, MpcMode::Unconstrained, config.barrier).unwrap();
    assert!(matches!(mpc.solve(0.0, &[f64::NEG_INFINITY, 0.0]), Err(CbfError::NonFinite { .. })));
}

#[test]
fn an_input_bound_the_barrier_cannot_live_with_brakes_at_the_bound_and_reports_the_slip() {
    let settings = CbfQpSettings { u_max: 1.0, ..CbfQpSettings::default() };
    let mut qp = IdCbfQp::new(settings, SineBarrier::new(0.0, 1.0, 0.0).unwrap()).unwrap();
    // Falling at 2 m/s onto a still boundary 0.1 m below: the ECBF row asks for
    // u ≥ −(k1 L_f h + k0 h) = −(20 · (−2) + 100 · 0.1) = 30, and |u| ≤ 1.
    let out = qp.solve(0.0, &[0.1, -2.0], 0.0).unwrap();
    // At the bound (to rounding: the row's least violation is solved for, not snapped).
    assert!((out.u - 1.0).abs() <= 1e-12 && out.source == InputSource::Qp, "{out:?}");
    assert!((out.slack - 29.0).abs() < 1e-4, "slack {}: the row slips by 30 − 1", out.slack);
    let calm = qp.solve(0.0, &[1.0, 0.0], 0.5).unwrap();
    assert!((calm.u - 0.5).abs() < 1e-5 && calm.slack < 1e-9, "the next feasible cycle solves");
    assert_eq!(qp.solve(0.0, &[1.0, 0.0], 5.0).unwrap().u, 1.0, "the bound holds");
}

#[test]
fn the_figures_show_every_variant_and_the_boundary() {
    let config = ScenarioConfig { duration: 1.0, ..ScenarioConfig::default() };
    let results = run_all(&config).unwrap();
    let dir = std::env::temp_dir().join(format!("cbfgen_multilayer_{}", std::process::id()));
    let written = scenario::write_figures(&dir, &config, &results).unwrap();
    let names: Vec<_> = written.iter().map(|p| p.file_name().unwrap().to_str().unwrap()).collect();
    assert_eq!(
        names,
        ["multilayer_positions.svg", "multilayer_positions.png", "multilayer_inputs.svg", "multilayer_inputs.png"]
    );
    let positions = std::fs::read_to_string(&written[0]).unwrap();
    let inputs = std::fs::read_to_string(&written[2]).unwrap();
    // Each variant's line in its own colour, once in the plot and once in the legend.
    for colour in ["#1F77B4", "#D62728", "#2CA02C"] {
        let line = format!(r#"stroke="{colour}""#);
        assert_eq!(positions.matches(&line).count(), 2, "positions: {colour}");
        assert_eq!(inputs.matches(&line).count(), 2, "inputs: {colour}");
    }
    // The boundary is dashed: many short black pieces.
    assert!(positions.matches(r##"stroke="#000000""##).count() > 50, "the boundary is drawn dashed");
    for png in [&written[1], &written[3]] {
        assert_eq!(&std::fs::read(png).unwrap()[1..4], b"PNG");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

use cbfgen::filter::{Backend, QpStatus, Solver, SolverSettings};
use cbfgen::qp::dual_active_set::DenseStatus;

/// The MPC's QP in its sparse form, written out here from the module docs (`z = [q_0..q_N,
/// v_0..v_{N−1}]`, the dynamics as equality rows, barrier rows from k = 2) and solved by
/// Clarabel to tolerances 1e-11. Returns `z`, and whether Clarabel met those tolerances
/// (else it reports "almost solved", to its looser ones).
fn clarabel_plan(settings: &MpcSettings, mode: MpcMode, barrier: SineBarrier, t: f64, x: [f64; 2]) -> (Vec<f64>, bool) {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT};
    let (n, dt) = (settings.horizon, settings.dt);
    let vars = 2 * n + 1;
    let (q, v) = (|k: usize| k, |k: usize| n + 1 + k);
    // Dense P (upper triangle kept below) and q from the cost's three sums.
    let mut p = vec![vec![0.0; vars]; vars];
    let mut lin = vec![0.0; vars];
    for k in 1..=n {
        p[q(k)][q(k)] += 2.0 * settings.w_q;
        lin[q(k)] -= 2.0 * settings.w_q * settings.q_ref;
    }
    for k in 0..n {
        p[v(k)][v(k)] += 2.0 * settings.w_v;
    }
    let wa = settings.w_a / (dt * dt);
    for k in 1..n {
        for (a, b, sign) in
            [(v(k), v(k), 1.0), (v(k - 1), v(k - 1), 1.0), (v(k), v(k - 1), -1.0), (v(k - 1), v(k), -1.0)]
        {
            p[a][b] += 2.0 * wa * sign;
        }
    }
    // Equalities (Clarabel: A z + s = b, s = 0), then barrier rows as −(row) z + s = −bound, s ≥ 0.
    let mut rows: Vec<(Vec<(usize, f64)>, f64)> = vec![(vec![(q(0), 1.0)], x[0]), (vec![(v(0), 1.0)], x[1])];
    for k in 0..n {
        rows.push((vec![(q(k + 1), 1.0), (q(k), -1.0), (v(k), -dt)], 0.0));
    }
    let equalities = rows.len();
    let keep = match mode {
        MpcMode::DiscreteCbf { gamma } => Some(1.0 - gamma),
        MpcMode::StateConstraint => Some(0.0),
        MpcMode::Unconstrained => None,
    };
    if let Some(keep) = keep {
        for k in 2..=n {
            let (tk, tp) = (t + k as f64 * dt, t + (k - 1) as f64 * dt);
            let bound = barrier.boundary(tk) - keep * barrier.boundary(tp);
            rows.push((vec![(q(k), -1.0), (q(k - 1), keep)], -bound));
        }
    }
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for c in 0..vars {
        for (r, (row, _)) in rows.iter().enumerate() {
            if let Some(&(_, value)) = row.iter().find(|(col, value)| *col == c && *value != 0.0) {
                rowval.push(r);
                nzval.push(value);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(rows.len(), vars, colptr, rowval, nzval);
    let b: Vec<f64> = rows.iter().map(|(_, b)| *b).collect();
    let (mut pc, mut pr, mut pv) = (vec![0], Vec::new(), Vec::new());
    for c in 0..vars {
        for (r, row) in p.iter().enumerate().take(c + 1) {
            if row[c] != 0.0 {
                pr.push(r);
                pv.push(row[c]);
            }
        }
        pc.push(pr.len());
    }
    let p = CscMatrix::new(vars, vars, pc, pr, pv);
    let mut cones = vec![ZeroConeT(equalities)];
    if rows.len() > equalities {
        cones.push(NonnegativeConeT(rows.len() - equalities));
    }
    let tight = DefaultSettings {
        verbose: false,
        tol_gap_abs: 1e-11,
        tol_gap_rel: 1e-11,
        tol_feas: 1e-11,
        tol_ktratio: 1e-9,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(&p, &lin, &a, &b, &cones, tight).expect("clarabel setup");
    solver.solve();
    let status = solver.solution.status;
    assert!(matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved), "{status:?}");
    (solver.solution.x.clone(), status == SolverStatus::Solved)
}

#[test]
fn dense_plans_agree_with_clarabel_on_the_sparse_form_in_every_mode() {
    let config = ScenarioConfig::default();
    let settings = config.mpc;
    assert_eq!(settings.solver.backend, Solver::DenseThenOsqp, "the default");
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let (mut worst, mut binding, mut solves, mut loose) = (0.0f64, 0, 0, 0);
    for mode in config.modes() {
        let mut mpc = KinematicMpc::new(settings, mode, config.barrier).unwrap();
        // The example's states and random ones, in time order so warm starts carry.
        for i in 0..200 {
            let t = 0.05 * i as f64;
            let s = config.barrier.boundary(t);
            let x = [s + rng.random_range(-0.2..1.5), rng.random_range(-3.0..3.0)];
            let out = mpc.solve(t, &x).unwrap();
            assert_eq!((out.status, out.answered_by, out.iterations), (QpStatus::Solved, Backend::Dense, 0));
            assert_eq!(mpc.dense_status(), Some(DenseStatus::Solved));
            binding += usize::from(mpc.dense_solver().is_some_and(|d| !d.active_set().is_empty()));
            let (q, v) = (mpc.planned_positions(), mpc.planned_velocities());
            let (n, dt) = (settings.horizon, settings.dt);
            // Feasible: the measured start, the dynamics, the barrier rows (recomputed here).
            assert!(q[0] == x[0] && v[0] == x[1]);
            for k in 0..n {
                assert!((q[k + 1] - q[k] - dt * v[k]).abs() <= 1e-12 * (1.0 + q[k + 1].abs()), "dynamics {k}");
            }
            let keep = match mode {
                MpcMode::DiscreteCbf { gamma } => Some(1.0 - gamma),
                MpcMode::StateConstraint => Some(0.0),
                MpcMode::Unconstrained => None,
            };
            if let Some(keep) = keep {
                let h = |k: usize| q[k] - config.barrier.boundary(t + k as f64 * dt);
                for k in 2..=n {
                    let slack = h(k) - keep * h(k - 1);
                    let size = 1.0 + h(k).abs() + keep * h(k - 1).abs();
                    assert!(slack >= -1e-9 * size, "{} row {k} at t {t}: {slack:.1e}", mode.name());
                }
            }
            let (reference, tight) = clarabel_plan(&settings, mode, config.barrier, t, x);
            let ours: Vec<f64> = q.iter().chain(v).copied().collect();
            if tight {
                let scale = 1.0 + reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let gap = ours.iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                worst = worst.max(gap / scale);
                assert!(gap <= 1e-6 * scale, "{} at t {t}, x {x:?}: plans differ by {gap:.2e}", mode.name());
            } else {
                // Clarabel stopped at its looser tolerances, 1e-8 outside some rows, where
                // a steep barrier buys 1e-7 of the cost: no reference, counted.
                loose += 1;
            }
            assert!((out.desired_accel - (ours[settings.horizon + 2] - x[1]) / settings.dt).abs() < 1e-9);
            solves += 1;
        }
    }
    println!(
        "{solves} solves, {binding} with barrier rows active; plans within {worst:.1e} of Clarabel's (of the scale); \
         {loose} where Clarabel met only its looser tolerances (not compared)"
    );
    assert!(binding > 100, "the barrier must bind in many of them: {binding}");
    assert!(loose * 20 <= solves, "Clarabel short on {loose} of {solves}");
}

#[test]
fn out_of_dense_steps_is_flagged_or_handed_to_osqp() {
    let config = ScenarioConfig::default();
    let mode = MpcMode::StateConstraint;
    let with = |backend, dense_max_steps| MpcSettings {
        solver: SolverSettings { backend, dense_max_steps, ..config.mpc.solver },
        ..config.mpc
    };
    // On the boundary, falling at 2 m/s, at the time (on a grid over one period) whose
    // cold solve takes the most steps: several barrier rows bind.
    let mut exact = KinematicMpc::new(with(Solver::Dense, 100), mode, config.barrier).unwrap();
    let mut hardest = (0, 0.0);
    for i in 0..32 {
        let t = i as f64 * std::f64::consts::PI / 32.0;
        let mut cold = KinematicMpc::new(with(Solver::Dense, 100), mode, config.barrier).unwrap();
        cold.solve(t, &[config.barrier.boundary(t), -2.0]).unwrap();
        let added = cold.dense_solver().expect("dense").rows_added();
        if added > hardest.0 {
            hardest = (added, t);
        }
    }
    let t = hardest.1;
    let x = [config.barrier.boundary(t), -2.0];
    let reference = exact.solve(t, &x).unwrap();
    // The budget counts rows added to the active set (the drops on the way are free).
    let needed = exact.dense_solver().expect("dense").rows_added();
    assert!(reference.status == QpStatus::Solved && needed > 1, "{reference:?}");

    let mut short = KinematicMpc::new(with(Solver::Dense, needed - 1), mode, config.barrier).unwrap();
    let out = short.solve(t, &x).unwrap();
    assert_eq!((out.status, out.answered_by), (QpStatus::MaxIterations, Backend::Dense));
    assert_eq!(short.dense_solver().expect("dense").rows_added(), needed - 1);
    assert_eq!(short.dense_status(), Some(DenseStatus::MaxSteps));
    assert!(out.desired_accel.is_finite(), "the iterate it reached, flagged");

    let mut fallback = KinematicMpc::new(with(Solver::DenseThenOsqp, needed - 1), mode, config.barrier).unwrap();
    let out = fallback.solve(t, &x).unwrap();
    assert!(out.status.is_solved() && out.answered_by == Backend::Osqp && out.iterations > 0, "{out:?}");
    let gap = (out.desired_accel - reference.desired_accel).abs();
    assert!(gap < 1e-2 * (1.0 + reference.desired_accel.abs()), "OSQP's {out:?} vs {reference:?}");

    // OSQP alone: today's path, no dense solver at all.
    let mut osqp = KinematicMpc::new(with(Solver::Osqp, 100), mode, config.barrier).unwrap();
    let out = osqp.solve(t, &x).unwrap();
    assert!(out.status.is_solved() && out.answered_by == Backend::Osqp && out.dense_steps == 0, "{out:?}");
    assert!(osqp.dense_solver().is_none() && osqp.dense_status().is_none());
    let gap = (out.desired_accel - reference.desired_accel).abs();
    assert!(gap < 1e-2 * (1.0 + reference.desired_accel.abs()), "OSQP's {out:?} vs {reference:?}");
}
