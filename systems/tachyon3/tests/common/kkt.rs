//! Independent truths about one Tachyon 3 filter update: the filter's rows rebuilt in
//! original units from its evaluated Lie derivatives and settings (the ECBF bound from the
//! family's two poles by hand, the tier from the family's priority), and the answer
//! checked stage by stage against Clarabel (`lexicographic_reference.rs`, which the test
//! crate must include as `lexicographic_reference`).
#![allow(dead_code)]
// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]

use cbfgen::qp::lexicographic::TieredRow;
use cbfgen_tachyon3::catalog::Tachyon3Filter;
use cbfgen_tachyon3::catalog::Tachyon3FilterExt;
use cbfgen_tachyon3::model::{Input, NU};

use crate::lexicographic_reference::{check_answer, hard_qp, terms, violation, RefRow};

/// The ECBF row's constant term for a linear class-K: the polynomial prod (s + p_i)
/// applied to `lie` = (h, L_f h, ...): h' + p h for one pole (the foothold pull),
/// L_f^2 h + (p1 + p2) L_f h + p1 p2 h for two (every barrier family).
pub fn ecbf_bound(lie: &[f64], poles: &[f64]) -> f64 {
    match *poles {
        [p] => lie[1] + p * lie[0],
        [p1, p2] => lie[2] + (p1 + p2) * lie[1] + p1 * p2 * lie[0],
        _ => panic!("Tachyon 3's families have one or two poles, not {poles:?}"),
    }
}

/// Every row of the filter's last update as `a·u + b ≥ 0` with its tier, and which took
/// part.
pub fn rows(filter: &Tachyon3Filter) -> (Vec<TieredRow<NU>>, Vec<bool>) {
    let s = filter.settings();
    let rows = filter
        .rows()
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let f = s.family(filter.slot(i).family.index());
            TieredRow { a: row.lg, b: ecbf_bound(&row.lie, f.poles.as_slice()), tier: f.priority }
        })
        .collect();
    (rows, filter.active().to_vec())
}

/// The last answer `u` checked against Clarabel's stages (see `check_answer`): `Ok(true)`
/// when rows are relaxed at it.
pub fn check(filter: &Tachyon3Filter, u: &Input, u_ref: &Input) -> Result<bool, String> {
    let s = filter.settings();
    let (rows, active) = rows(filter);
    check_answer(&s.input_weights, &s.input_min, &s.input_max, u_ref, &rows, &active, u)
}

/// Clarabel's closest input to `u_ref` with every active row at most as violated as it is
/// at `u` (every row hard, where the rows fit), to a rounding of 1e-10 of each row's terms
/// (without it, rows that meet at a vertex can leave Clarabel no interior): the answer the
/// filter must give, and its cost `½ Σ w (u − u_ref)²`.
pub fn clarabel_reference(filter: &Tachyon3Filter, u: &Input, u_ref: &Input) -> (Input, f64) {
    let s = filter.settings();
    let (rows, active) = rows(filter);
    let refs: Vec<RefRow> = rows
        .iter()
        .zip(&active)
        .filter(|(_, &on)| on)
        .map(|(r, _)| RefRow { a: r.a.to_vec(), lower: -r.b - violation(r, u) - 1e-10 * terms(r, u), elastic: 0.0 })
        .collect();
    let x = hard_qp(&s.input_weights, u_ref, &s.input_min, &s.input_max, &refs).expect("clarabel must solve it");
    let x: Input = std::array::from_fn(|j| x[j]);
    (x, cost(filter, &x, u_ref))
}

/// `½ Σ_j w_j (u_j − u_ref,j)²`.
pub fn cost(filter: &Tachyon3Filter, u: &Input, u_ref: &Input) -> f64 {
    let w = &filter.settings().input_weights;
    (0..NU).map(|j| 0.5 * w[j] * (u[j] - u_ref[j]).powi(2)).sum()
}
