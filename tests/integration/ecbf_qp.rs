//! The ECBF filter's QP (`cbfgen::filter::EcbfQp`) with its solver settings drawn at
//! random from their documented ranges (no time limit), OSQP's fallback and polish
//! included: a verified
//! answer is the problem's, whatever the QP solved before (issue 62). Before the cascade
//! of relaxations started cold, 8 of 2 115 problems with 18 inputs and 60 rows ended up to
//! 1.3e-5 of the inputs' scale from a fresh QP's answer.

use cbfgen::filter::{EcbfQp, RowSpec};
use cbfgen::qp::lexicographic::TieredRow;
use cbfgen::qp::{QpStatus, Solver, SolverSettings};
use cbfgen::system::{Gains, Row, MAX_RELATIVE_DEGREE};
use cbfgen_testkit::boxes as common;
use cbfgen_testkit::lexicographic_reference::{check_answer, gap_in_scale};
use rand::Rng;

fn log_uniform(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp()
}

/// Solver settings anywhere in their documented ranges (`SolverSettings`'s constants);
/// iteration counts below 400 keep a case fast, half the dense budgets below 4 steps.
fn settings(rng: &mut impl Rng) -> SolverSettings {
    let range = |rng: &mut _, [lo, hi]: [f64; 2]| log_uniform(rng, lo, hi);
    let tolerance = [SolverSettings::MIN_TOLERANCE, SolverSettings::MAX_TOLERANCE];
    SolverSettings {
        backend: Solver::ALL[rng.random_range(0..Solver::ALL.len())],
        dense_max_steps: if rng.random_bool(0.5) { rng.random_range(1..4) } else { rng.random_range(4..200) },
        dense_max_work: SolverSettings::DEFAULT.dense_max_work,
        eps_abs: range(rng, tolerance),
        eps_rel: range(rng, tolerance),
        max_iter: rng.random_range(1..400),
        rho: range(rng, SolverSettings::RHO_RANGE),
        sigma: range(rng, SolverSettings::SIGMA_RANGE),
        alpha: rng.random_range(SolverSettings::ALPHA_RANGE[0]..=SolverSettings::ALPHA_RANGE[1]),
        adaptive_rho: rng.random_bool(0.5),
        adaptive_rho_interval: rng.random_range(1..400),
        check_termination: rng.random_range(1..400),
        time_limit: None,
        polish: rng.random_bool(0.8),
        scaling: rng.random_range(0..=SolverSettings::MAX_SCALING),
    }
}

/// Rows `a·u + b ≥ 0` with `b` from well inside to well outside the box, so that tier 0
/// often cannot hold.
fn rows<const NU: usize>(
    rng: &mut impl Rng,
    count: usize,
    lo: &[f64; NU],
    hi: &[f64; NU],
) -> (Vec<Row<NU>>, [f64; NU]) {
    let rows = (0..count)
        .map(|_| {
            let scale = 10f64.powf(rng.random_range(-2.0..2.0));
            let lg: [f64; NU] = std::array::from_fn(|_| scale * rng.random_range(-1.0..1.0));
            let reach: f64 = (0..NU).map(|j| lg[j].abs() * lo[j].abs().max(hi[j].abs())).sum();
            let mut lie = [0.0; MAX_RELATIVE_DEGREE + 1];
            lie[1] = reach * rng.random_range(-1.6..0.8);
            Row { lie, lg, active: rng.random_bool(0.9), culled: false }
        })
        .collect();
    (rows, std::array::from_fn(|_| rng.random_range(-8.0..8.0)))
}

fn solve<const NU: usize>(qp: &mut EcbfQp<NU>, rows: &[Row<NU>], u_ref: &[f64; NU]) {
    let active: Vec<bool> = rows.iter().map(|r| r.active).collect();
    qp.solve(u_ref, rows, &active).expect("valid rows");
}

/// `count` random problems of `rows` rows over `NU` inputs, each solved by a fresh QP and
/// by one that solved 1–4 other problems first, under the same random settings: where
/// both verify, how many were compared, how many had relaxed rows, and the answers that
/// differ or (every 25th) are not Clarabel's lexicographic optimum.
fn history<const NU: usize>(seed: u64, count: usize, rows_per_problem: usize) -> (usize, usize, Vec<String>) {
    let mut rng = common::rng(seed);
    let gains = Gains::new(&[1.0]).expect("gains");
    let all: Vec<usize> = (0..NU).collect();
    let (mut compared, mut relaxed, mut failures) = (0, 0, Vec::new());
    for case in 0..count {
        let specs: Vec<RowSpec> =
            (0..rows_per_problem).map(|_| RowSpec { columns: &all, gains, priority: rng.random_range(0..3) }).collect();
        let weights: [f64; NU] = std::array::from_fn(|_| 10f64.powf(rng.random_range(-1.0..1.0)));
        let lo: [f64; NU] = std::array::from_fn(|_| -rng.random_range(0.2..5.0));
        let hi: [f64; NU] = std::array::from_fn(|_| rng.random_range(0.2..5.0));
        let s = settings(&mut rng);
        let (problem, u_ref) = rows(&mut rng, rows_per_problem, &lo, &hi);
        let mut fresh = EcbfQp::new(&specs, &weights, &lo, &hi, s).expect("valid settings");
        solve(&mut fresh, &problem, &u_ref);
        let mut used = EcbfQp::new(&specs, &weights, &lo, &hi, s).expect("valid settings");
        for _ in 0..rng.random_range(1..=4) {
            let (other, other_ref) = rows(&mut rng, rows_per_problem, &lo, &hi);
            solve(&mut used, &other, &other_ref);
        }
        solve(&mut used, &problem, &u_ref);
        if !(fresh.verified() && used.verified()) {
            continue;
        }
        compared += 1;
        relaxed += usize::from(fresh.elastic_stages() > 0);
        let gap = gap_in_scale(fresh.u(), used.u());
        if gap > 1e-10 {
            failures.push(format!("case {case} ({s:?}): {gap:.3e} of the input scale apart"));
        }
        // And it is the lexicographic optimum, by Clarabel's stages (every 25th case: a
        // reference solve costs a hundred of these).
        if case % 25 == 0 {
            let tiered: Vec<TieredRow<NU>> = problem
                .iter()
                .zip(&specs)
                .map(|(r, spec)| TieredRow { a: r.lg, b: r.lie[1], tier: spec.priority })
                .collect();
            let active: Vec<bool> = problem.iter().map(|r| r.active).collect();
            if let Err(e) = check_answer(&weights, &lo, &hi, &u_ref, &tiered, &active, used.u()) {
                failures.push(format!("case {case}: not the lexicographic optimum: {e}"));
            }
        }
    }
    (compared, relaxed, failures)
}

#[test]
fn a_verified_answer_does_not_depend_on_what_the_qp_solved_before() {
    for (shape, (compared, relaxed, failures)) in
        [("3 inputs, 12 rows", history::<3>(62, 3000, 12)), ("18 inputs, 60 rows", history::<18>(63, 2000, 60))]
    {
        println!("{shape}: {compared} compared, {relaxed} relaxed, {} differ", failures.len());
        assert!(compared > 600, "{shape}: only {compared} cases verified twice");
        assert!(relaxed * 5 > compared, "{shape}: only {relaxed} of {compared} relaxed");
        assert!(
            failures.is_empty(),
            "{shape}: {} differ, e.g. {:?}",
            failures.len(),
            &failures[..failures.len().min(3)]
        );
    }
}

/// Under a work budget, whatever its size: no solve's counted work passes the QP's stated
/// worst case, a solve that verifies gives the answer an unbudgeted one gives, and a
/// budget too small to finish leaves the answer flagged (never called verified).
fn budgeted<const NU: usize>(seed: u64, count: usize, rows_per_problem: usize) -> (usize, usize) {
    let mut rng = common::rng(seed);
    let gains = Gains::new(&[1.0]).expect("gains");
    let all: Vec<usize> = (0..NU).collect();
    let (mut cut, mut finished) = (0, 0);
    for case in 0..count {
        let specs: Vec<RowSpec> =
            (0..rows_per_problem).map(|_| RowSpec { columns: &all, gains, priority: rng.random_range(0..3) }).collect();
        let weights = [1.0; NU];
        let lo = [-2.0; NU];
        let hi = [2.0; NU];
        let (problem, u_ref) = rows(&mut rng, rows_per_problem, &lo, &hi);
        let free_settings = SolverSettings { backend: Solver::Dense, ..SolverSettings::DEFAULT };
        let mut free = EcbfQp::new(&specs, &weights, &lo, &hi, free_settings).expect("valid settings");
        solve(&mut free, &problem, &u_ref);
        let backend = Solver::ALL[rng.random_range(0..Solver::ALL.len())];
        // From a fifth of what the unbudgeted solve took to twice it.
        let max_work = ((free.dense_work() as f64 * rng.random_range(0.2..2.0)) as u64).max(1);
        let s = SolverSettings { backend, dense_max_work: max_work, ..SolverSettings::DEFAULT };
        let mut qp = EcbfQp::new(&specs, &weights, &lo, &hi, s).expect("valid settings");
        solve(&mut qp, &problem, &u_ref);
        let bound = qp.worst_case();
        assert!(qp.dense_work() <= bound.dense_trips, "case {case}: {} > {}", qp.dense_work(), bound.dense_trips);
        assert!(qp.iterations() <= bound.osqp_iterations, "case {case}");
        if qp.verified() {
            finished += 1;
            if free.verified() {
                let gap = gap_in_scale(free.u(), qp.u());
                assert!(gap <= 1e-9, "case {case}: {gap:.3e} of the input scale from the unbudgeted answer");
            }
        } else {
            cut += 1;
            assert_ne!(qp.status(), QpStatus::Solved, "case {case}: an answer not verified reported solved");
        }
    }
    (cut, finished)
}

#[test]
fn a_work_budget_bounds_every_solve_and_never_changes_a_verified_answer() {
    for (shape, (cut, finished)) in
        [("3 inputs, 12 rows", budgeted::<3>(64, 1500, 12)), ("18 inputs, 60 rows", budgeted::<18>(65, 600, 60))]
    {
        println!("{shape}: {cut} cut short by their budget, {finished} verified within it");
        assert!(cut > 50 && finished > 50, "{shape}: {cut} cut, {finished} finished");
    }
}
