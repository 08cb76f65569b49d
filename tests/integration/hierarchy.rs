//! The hierarchical QP against independent truths: each level's answer against Clarabel
//! (an interior-point solver) on the same level written without null spaces — the tasks
//! above pinned as equality rows, the rows above as bounds — on random hierarchies; and the
//! property the hierarchy exists for: solving the levels below a level never changes that
//! level's residual or its slacks (the same problem cut after it gives the same numbers).

// Index loops mirror the formulas (rows × variables).
#![allow(clippy::needless_range_loop)]

use cbfgen::qp::dual_active_set::DenseStatus;
use cbfgen::qp::hierarchy::{Hierarchy, LevelShape, LevelStatus};
use cbfgen_testkit::clarabel_qp::{self, Answer};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One level's data, row-major.
#[derive(Debug, Clone)]
struct Level {
    shape: LevelShape,
    task: Vec<f64>,
    target: Vec<f64>,
    rows: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

/// A random hierarchy of 2–4 levels over 3–16 variables: tasks totalling fewer rows than
/// variables, hard rows at the top (true at a random point, so they can hold), soft rows
/// below that may well conflict with the tasks.
fn random_hierarchy(rng: &mut ChaCha8Rng) -> (usize, Vec<Level>) {
    let n = rng.random_range(3..=16);
    let count = rng.random_range(2..=4);
    let inside: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut budget = n - 1;
    let mut levels = Vec::new();
    for k in 0..count {
        let tasks = rng.random_range(0..=budget.min(n / 2 + 1));
        budget -= tasks;
        let hard = if k == 0 { rng.random_range(0..=4) } else { 0 };
        let soft = rng.random_range(0..=3);
        let mut random = |len: usize| -> Vec<f64> { (0..len).map(|_| rng.random_range(-2.0..2.0)).collect() };
        let task = random(tasks * n);
        let target = random(tasks);
        let rows = random((hard + soft) * n);
        let (mut lower, mut upper) = (Vec::new(), Vec::new());
        for i in 0..hard + soft {
            let at: f64 = rows[i * n..(i + 1) * n].iter().zip(&inside).map(|(a, z)| a * z).sum();
            // Hard rows hold at `inside`; soft ones are drawn anywhere.
            let centre = if i < hard { at } else { at + rng.random_range(-3.0..3.0) };
            let (below, above) = (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            match rng.random_range(0..3) {
                0 => {
                    lower.push(centre - below);
                    upper.push(f64::INFINITY);
                }
                1 => {
                    lower.push(f64::NEG_INFINITY);
                    upper.push(centre + above);
                }
                _ => {
                    lower.push(centre - below);
                    upper.push(centre + above);
                }
            }
        }
        levels.push(Level { shape: LevelShape { tasks, hard, soft }, task, target, rows, lower, upper });
    }
    (n, levels)
}

fn solve(n: usize, levels: &[Level]) -> Hierarchy {
    let shapes: Vec<LevelShape> = levels.iter().map(|l| l.shape).collect();
    let mut qp = Hierarchy::new(n, &shapes).expect("sizes");
    for (k, level) in levels.iter().enumerate() {
        let data = qp.level_mut(k);
        data.task.copy_from_slice(&level.task);
        data.target.copy_from_slice(&level.target);
        data.rows.copy_from_slice(&level.rows);
        data.lower.copy_from_slice(&level.lower);
        data.upper.copy_from_slice(&level.upper);
    }
    qp.solve();
    qp
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Level `k` on Clarabel over `(z, s)`: `½‖A z − b‖² + ½‖s‖² + ½ ε ‖z − z_above‖²` with the
/// tasks above pinned at `pins` (`A_j z = A_j z_j`), the rows above kept within their
/// slacks `kept`, its own hard rows and its soft rows with `s`. Returns `(z, s)`.
fn clarabel_level(
    n: usize,
    levels: &[Level],
    k: usize,
    z_above: &[f64],
    pins: &[Vec<f64>],
    kept: &[Vec<f64>],
    eps: f64,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let level = &levels[k];
    let soft = level.shape.soft;
    let size = n + soft;
    // Cost.
    let mut p = vec![0.0; size * size];
    let mut q = vec![0.0; size];
    for i in 0..level.shape.tasks {
        let a = &level.task[i * n..(i + 1) * n];
        for r in 0..n {
            for c in 0..n {
                p[r * size + c] += a[r] * a[c];
            }
            q[r] -= a[r] * level.target[i];
        }
    }
    for r in 0..n {
        p[r * size + r] += eps;
        q[r] -= eps * z_above[r];
    }
    for r in n..size {
        p[r * size + r] = 1.0;
    }
    let mut equalities: Vec<(Vec<f64>, f64)> = Vec::new();
    let mut inequalities: Vec<(Vec<f64>, f64)> = Vec::new();
    for (j, pinned) in pins.iter().enumerate() {
        for i in 0..levels[j].shape.tasks {
            let a = &levels[j].task[i * n..(i + 1) * n];
            let mut row = a.to_vec();
            row.resize(size, 0.0);
            equalities.push((row, dot(a, pinned)));
        }
    }
    for j in 0..=k {
        let l = &levels[j];
        for i in 0..l.shape.hard + l.shape.soft {
            let mut row = l.rows[i * n..(i + 1) * n].to_vec();
            row.resize(size, 0.0);
            let mut shift = 0.0;
            if i >= l.shape.hard {
                if j < k {
                    shift = kept[j][i - l.shape.hard];
                } else {
                    row[n + i - l.shape.hard] = -1.0;
                }
            }
            if l.upper[i].is_finite() {
                inequalities.push((row.clone(), l.upper[i] + shift));
            }
            if l.lower[i].is_finite() {
                inequalities.push((row.iter().map(|v| -v).collect(), -(l.lower[i] + shift)));
            }
        }
    }
    match clarabel_qp::solve(size, &p, &q, &equalities, &inequalities, clarabel_qp::tight_settings()) {
        Answer::Solved(x) => Some((x[..n].to_vec(), x[n..].to_vec())),
        _ => None,
    }
}

#[test]
fn each_level_matches_clarabel_on_the_same_level_without_null_spaces() {
    let mut rng = ChaCha8Rng::seed_from_u64(3707);
    let (mut compared, mut slackened) = (0, 0);
    for case in 0..400 {
        let (n, levels) = random_hierarchy(&mut rng);
        let ours = solve(n, &levels);
        let reports = ours.reports();
        assert!(reports.iter().all(|r| r.status == LevelStatus::Solved), "case {case}: {reports:?}");
        // Clarabel's chain: each level from its own previous answer.
        let (mut z, mut pins, mut kept) = (vec![0.0; n], Vec::new(), Vec::new());
        for k in 0..levels.len() {
            let Some((next, slack)) = clarabel_level(n, &levels, k, &z, &pins, &kept, reports[k].regularisation) else {
                panic!("case {case}, level {k}: Clarabel found no answer");
            };
            z = next;
            pins.push(z.clone());
            slackened += usize::from(slack.iter().any(|s| s.abs() > 1e-6));
            // Residuals and slacks of this level, from the final solution (the hierarchy)
            // and from Clarabel's answer at this level.
            let level = &levels[k];
            let residual = (0..level.shape.tasks)
                .map(|i| (dot(&level.task[i * n..(i + 1) * n], &z) - level.target[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(
                (residual - reports[k].residual).abs() <= 1e-6 * (1.0 + residual),
                "case {case}, level {k}: \
                     residual {} vs Clarabel's {residual}",
                reports[k].residual
            );
            for (s, t) in ours.slacks(k).iter().zip(&slack) {
                assert!((s - t).abs() <= 1e-6 * (1.0 + t.abs()), "case {case}, level {k}: slack {s} vs {t}");
            }
            kept.push(slack);
        }
        // The tasks' values at the end (z itself is fixed only to ε in directions no task
        // reads, where an interior-point answer is not that exact).
        for level in &levels {
            for i in 0..level.shape.tasks {
                let row = &level.task[i * n..(i + 1) * n];
                let (a, b) = (dot(row, ours.solution()), dot(row, &z));
                assert!((a - b).abs() <= 1e-6 * (1.0 + b.abs()), "case {case}: task value {a} vs Clarabel's {b}");
            }
        }
        compared += 1;
    }
    assert_eq!(compared, 400);
    assert!(slackened > 50, "only {slackened} levels needed a slack: the soft rows rarely conflicted");
}

#[test]
fn the_levels_below_never_change_a_levels_residual_or_slacks() {
    let mut rng = ChaCha8Rng::seed_from_u64(3708);
    for case in 0..2000 {
        let (n, levels) = random_hierarchy(&mut rng);
        let full = solve(n, &levels);
        for k in 0..levels.len() - 1 {
            let cut = solve(n, &levels[..=k]);
            assert_eq!((full.reports()[k].status, cut.reports()[k].status), (LevelStatus::Solved, LevelStatus::Solved));
            // Level k's task at the end of the full solve, against the solve cut after it.
            let level = &levels[k];
            for i in 0..level.shape.tasks {
                let row = &level.task[i * n..(i + 1) * n];
                let (a, b) = (dot(row, full.solution()), dot(row, cut.solution()));
                assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()), "case {case}, level {k}: task value {a} vs {b}");
            }
            for (s, t) in full.slacks(k).iter().zip(cut.slacks(k)) {
                assert!((s - t).abs() <= 1e-9 * (1.0 + t.abs()), "case {case}, level {k}: slack {s} vs {t}");
            }
            // And every row at or above it still holds within its slack at the final solution.
            for j in 0..=k {
                let l = &levels[j];
                for i in 0..l.shape.hard + l.shape.soft {
                    let slack = if i >= l.shape.hard { full.slacks(j)[i - l.shape.hard] } else { 0.0 };
                    let v = dot(&l.rows[i * n..(i + 1) * n], full.solution()) - slack;
                    let scale = 1.0 + l.rows[i * n..(i + 1) * n].iter().map(|x| x.abs()).sum::<f64>();
                    assert!(
                        v >= l.lower[i] - 1e-8 * scale && v <= l.upper[i] + 1e-8 * scale,
                        "case {case}, level {j}, row {i}: {v} outside [{}, {}]",
                        l.lower[i],
                        l.upper[i]
                    );
                }
            }
        }
    }
}

#[test]
fn hard_rows_that_cannot_hold_stop_the_solve_there_and_say_so() {
    // z0 ≥ 1 and z0 ≤ 0 at the top: nothing below is attempted.
    let levels = [
        Level {
            shape: LevelShape { tasks: 0, hard: 2, soft: 0 },
            task: vec![],
            target: vec![],
            rows: vec![1.0, 0.0, 1.0, 0.0],
            lower: vec![1.0, f64::NEG_INFINITY],
            upper: vec![f64::INFINITY, 0.0],
        },
        Level {
            shape: LevelShape { tasks: 1, hard: 0, soft: 0 },
            task: vec![0.0, 1.0],
            target: vec![3.0],
            rows: vec![],
            lower: vec![],
            upper: vec![],
        },
    ];
    let qp = solve(2, &levels);
    assert_eq!(qp.reports()[0].status, LevelStatus::Failed(DenseStatus::Infeasible));
    assert_eq!(qp.reports()[1].status, LevelStatus::Skipped);
    assert!(qp.solution().iter().all(|z| z.is_finite()));
}

/// Rows of the top level that the tasks below push against end each level at their bound;
/// once the levels below have pinned every direction that moves such a row, what is left
/// of it is rounding. That must never read as an infeasible level (it did, in a quarter of
/// seed 004's whole-body cycles with active foothold rows, before a row's tolerance at the
/// level below was made to match what the level above was verified to), and every row
/// must still hold where its level left it.
#[test]
fn rows_pinned_at_their_bound_by_the_levels_below_never_read_as_infeasible() {
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let mut pinned_at_bound = 0;
    for case in 0..3000 {
        let n = rng.random_range(3..=12);
        let soft = rng.random_range(1..=(n - 1).min(4));
        // Rows of very different sizes (the whole-body QP's mix newtons, metres and radians).
        let rows: Vec<f64> = (0..soft * n)
            .map(|k| {
                let scale = 10f64.powf(rng.random_range(-2.0..3.0) + if k % n == 0 { 0.0 } else { -1.0 });
                scale * rng.random_range(-2.0..2.0)
            })
            .collect();
        let inside: Vec<f64> = (0..n).map(|_| 10.0 * rng.random_range(-1.0..1.0)).collect();
        let lower: Vec<f64> = (0..soft).map(|i| dot(&rows[i * n..(i + 1) * n], &inside)).collect();
        // Level 1 asks for the opposite of each row from far away (it must stop at the
        // rows); level 2 takes up what is left, so few directions stay free.
        let tasks_1 = rng.random_range(soft..=(n - 1).min(soft + 2));
        let tasks_2 = rng.random_range(0..=n - tasks_1);
        let mut task_1 = Vec::new();
        let mut target_1 = Vec::new();
        for t in 0..tasks_1 {
            let row: Vec<f64> = if t < soft {
                rows[t * n..(t + 1) * n].iter().map(|a| -a).collect()
            } else {
                (0..n).map(|_| rng.random_range(-2.0..2.0)).collect()
            };
            target_1.push(dot(&row, &inside) + 10.0 * (1.0 + row.iter().map(|a| a.abs()).sum::<f64>()));
            task_1.extend(row);
        }
        let task_2: Vec<f64> = (0..tasks_2 * n).map(|_| rng.random_range(-2.0..2.0)).collect();
        let target_2: Vec<f64> = (0..tasks_2).map(|_| rng.random_range(-5.0..5.0)).collect();
        let levels = [
            Level {
                shape: LevelShape { tasks: 0, hard: 0, soft },
                task: vec![],
                target: vec![],
                rows: rows.clone(),
                lower: lower.clone(),
                upper: vec![f64::INFINITY; soft],
            },
            Level {
                shape: LevelShape { tasks: tasks_1, hard: 0, soft: 0 },
                task: task_1,
                target: target_1,
                rows: vec![],
                lower: vec![],
                upper: vec![],
            },
            Level {
                shape: LevelShape { tasks: tasks_2, hard: 0, soft: 0 },
                task: task_2,
                target: target_2,
                rows: vec![],
                lower: vec![],
                upper: vec![],
            },
        ];
        let qp = solve(n, &levels);
        for (k, report) in qp.reports().iter().enumerate() {
            assert_eq!(report.status, LevelStatus::Solved, "case {case}: level {k} of n = {n}, {soft} rows");
        }
        for i in 0..soft {
            let row = &rows[i * n..(i + 1) * n];
            let v = dot(row, qp.solution()) - qp.slacks(0)[i];
            let scale = 1.0 + row.iter().zip(qp.solution()).map(|(a, z)| (a * z).abs()).sum::<f64>();
            assert!(v >= lower[i] - 1e-8 * scale, "case {case}, row {i}: {v} below {}", lower[i]);
            pinned_at_bound += usize::from(v - lower[i] <= 1e-8 * scale);
        }
    }
    assert!(pinned_at_bound > 3000, "only {pinned_at_bound} rows ended at their bound: the tasks did not push");
}
