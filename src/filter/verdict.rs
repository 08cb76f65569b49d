//! What an update says about safety, separate from how its QP ended: every active row met
//! at the input returned, or which rows were relaxed, by how much and why.
//!
//! The verdict is measured, not inferred from the solver: after the input is chosen
//! (optimum, unverified iterate or fallback) and clipped, every active row is evaluated at
//! it. A row is **met** when `a·u + b ≥ −`[`MET_TOLERANCE`]` · (|b| + Σ_j |a_j| (1 +
//! |u_j|))` — rounding of the solve, nothing more — and **relaxed** otherwise, with its
//! slack `−(a·u + b)` in the row's own units (those of `h⁽ʳ⁾`), the slack relative to the
//! row's terms `|b| + Σ_j |a_j u_j|`, and its [`Cause`]. Rows above their family's
//! activation threshold take no part and are not assessed.

pub use crate::filter::qp::MET_TOLERANCE;
pub use crate::qp::lexicographic::{Cause, Limit};

/// The safety verdict of one update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Verdict {
    /// Every active row is met at the returned input.
    Met,
    /// At least one active row is relaxed beyond [`MET_TOLERANCE`]: see
    /// [`Safety::worst`], the filter's per-family and per-row reports.
    Relaxed,
    /// The rows could not be assessed: an active row was not finite (the input is a
    /// fallback, see [`Output::nonfinite_row`](super::Output::nonfinite_row)).
    Unassessed,
}

impl Verdict {
    /// Snake-case name, as shown in Python and written to CSV.
    pub const fn name(self) -> &'static str {
        match self {
            Verdict::Met => "met",
            Verdict::Relaxed => "relaxed",
            Verdict::Unassessed => "unassessed",
        }
    }
}

/// One relaxed row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelaxedRow {
    /// Its index in the row layout.
    pub row: usize,
    /// Its family's index.
    pub family: usize,
    /// By how much it is missed, `−(a·u + b)`, in the row's units.
    pub slack: f64,
    /// The slack relative to the row's terms `|b| + Σ_j |a_j u_j|`.
    pub relative: f64,
    /// Why.
    pub cause: Cause,
}

/// An update's safety: the verdict, how many rows were relaxed, and the worst of them (the
/// largest relative slack).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Safety {
    /// Met, relaxed or unassessed.
    pub verdict: Verdict,
    /// Active rows relaxed beyond [`MET_TOLERANCE`].
    pub relaxed_rows: usize,
    /// The relaxed row with the largest relative slack.
    pub worst: Option<RelaxedRow>,
}

impl Safety {
    /// Nothing assessed yet.
    pub const UNASSESSED: Safety = Safety { verdict: Verdict::Unassessed, relaxed_rows: 0, worst: None };

    /// Whether every active row was met.
    pub fn is_met(&self) -> bool {
        self.verdict == Verdict::Met
    }
}

/// One family's relaxations in an update. (`repr(C)`: it crosses the plugin ABI as is.)
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FamilyRelaxation {
    /// Its rows relaxed beyond [`MET_TOLERANCE`].
    pub relaxed_rows: usize,
    /// The largest slack among them, in the rows' units (0 when none).
    pub max_slack: f64,
    /// The largest relative slack among them (0 when none).
    pub max_relative: f64,
}
