//! The stairs run's own QPs (the committed fixture, `systems/tachyon3/tests/data/stairs_qps.bin`) through
//! the filter's QP laid out as the filter's, warm along the recorded sequence: every
//! backend's answer verified, checked stage by stage against Clarabel, and equal to a
//! cold solve of the same problem.

use crate::replay;
use cbfgen_testkit::lexicographic_reference;

use cbfgen::filter::{Backend, QpStatus, Solver};
use cbfgen::qp::lexicographic::{LexicographicSolver, Outcome};
use cbfgen_tachyon3::model::NU;
use lexicographic_reference::check_answer;
use replay::{input_distance, stairs_qps, Replay};

fn percentile(mut v: Vec<u32>, p: f64) -> u32 {
    v.sort_unstable();
    v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1]
}

#[test]
fn every_backend_gives_the_verified_optimum_of_every_recorded_stairs_qp() {
    let problems = stairs_qps();
    assert_eq!(problems.len(), 500);
    let hard = problems.iter().filter(|p| (25.10..25.30).contains(&p.t)).count();
    assert_eq!(hard, 200, "every cycle of the hard window");

    let mut replays: Vec<Replay> = Solver::ALL.iter().map(|&b| Replay::new(b, &problems[0])).collect();
    let (mut steps, mut admm, mut polished, mut relaxed) = (vec![], vec![], 0, 0);
    for (k, p) in problems.iter().enumerate() {
        let (weights, u_ref, input_min, input_max) = p.inputs::<NU>().expect("17 inputs");
        let rows = p.tiered_rows::<NU>().expect("17 inputs");
        let active = vec![true; rows.len()];
        // Cold, from nothing: the reference the warm solves must equal.
        let mut cold = LexicographicSolver::new(rows.len(), &weights, &input_min, &input_max).expect("box");
        assert_eq!(cold.solve(&u_ref, &rows, &active, 100), Ok(Outcome::Verified), "problem {k} cold");
        let r = check_answer(&weights, &input_min, &input_max, &u_ref, &rows, &active, cold.u())
            .unwrap_or_else(|e| panic!("problem {k} (t = {}): {e}", p.t));
        relaxed += usize::from(r);
        for replay in &mut replays {
            replay.load(p);
            let backend = replay.backend();
            assert_eq!(replay.solve(), QpStatus::Solved, "problem {k} (t = {}), {backend:?}", p.t);
            assert!(replay.qp.verified(), "problem {k}, {backend:?}: not verified");
            let d = input_distance(p, cold.u(), replay.qp.u());
            assert!(d <= 1e-8, "problem {k}, {backend:?}: {d:.2e} from the cold answer");
            match backend {
                Solver::Dense => steps.push(replay.qp.dense_steps()),
                Solver::Osqp => {
                    admm.push(replay.qp.iterations());
                    polished += usize::from(replay.qp.polished());
                }
                Solver::DenseThenOsqp => assert_eq!(replay.qp.backend(), Some(Backend::Dense), "problem {k}"),
            }
        }
    }
    eprintln!(
        "500 stairs QPs ({relaxed} with rows relaxed): dense steps warm median {} / max {}; OSQP iterations median {} / p99 {} / max {}, {polished} polished",
        percentile(steps.clone(), 0.5),
        percentile(steps, 1.0),
        percentile(admm.clone(), 0.5),
        percentile(admm.clone(), 0.99),
        percentile(admm, 1.0),
    );
}
