//! The ECBF safety filter: one real-time control update (Tachyon 3 paper, section III-C),
//! for any system that implements [`BarrierSet`].
//!
//! Each cycle [`EcbfFilter::update`] evaluates every barrier row at the state, decides
//! which rows take part (the barrier set's own flags, then each family's activation
//! threshold on `h`), and solves
//!
//! ```text
//! min Σ_j w_j (u_j − u_ref,j)² + Σ_i w_δ,i δ_i²
//! s.t. L_g L_f^{r−1} h_i · u + δ_i ≥ −(L_f^r h_i + Σ_k k_k L_f^k h_i)   (active rows)
//!      input_min ≤ u ≤ input_max
//! ```
//!
//! where `r` is row `i`'s relative degree and the gains `k` place its poles
//! ([`Gains::from_poles`](crate::system::Gains::from_poles)); rows of different degrees
//! share the QP.
//!
//! exactly in input space ([`crate::qp::input_space`]), warm-started from the previous
//! cycle's answer, with OSQP as the fallback when that solve has not verified within its
//! budget and as a selectable reference backend ([`Solver`]). Everything is laid out when
//! the filter is built; after that an update allocates nothing, on any backend (tested by
//! counting every `malloc` over thousands of cycles).
//!
//! # The output contract
//! **Every input `update` returns is finite and inside the input box**, whatever it is
//! given, and no cycle's trouble carries into the next. Concretely:
//! * Inputs outside the documented domain are typed errors, and the filter is unchanged
//!   (the caller chooses; [`EcbfFilter::fallback_input`] is there): NaN/inf anywhere,
//!   a state entry beyond [`STATE_LIMIT`](crate::system::STATE_LIMIT), a nominal
//!   input beyond [`domain::MAX_INPUT`], parameters (an environment) of another capacity. Extreme but
//!   finite values are rejected, not rescaled: a nominal input of 10³⁰⁰ m/s² is a bug
//!   upstream, and the filter says so instead of guessing.
//! * Settings are checked once, in [`EcbfFilter::new`]: every weight, pole, limit and
//!   solver setting has a documented range ([`domain`], [`SolverSettings::validate`]),
//!   and capacities a maximum (for Tachyon 3, [`Capacity::validate`](crate::systems::tachyon3::catalog::Capacity::validate); for a generated system, [`system::MAX_INSTANCES`](crate::system::MAX_INSTANCES)). Every accepted setting ends a
//!   solve within [`SolverSettings::MAX_ITERATIONS`] iterations.
//! * OSQP stops at its iteration or time limit (or, under [`Solver::Dense`], the dense
//!   solve at its step budget): `Ok`, with the iterate it stopped at
//!   ([`InputSource::Unconverged`]). It already reflects this cycle's rows, and the next
//!   cycle continues from it (warm start), so a hard instance converges over a few cycles
//!   instead of stalling one. This happens when rows conflict with the input limits (large
//!   slacks), where ADMM needs hundreds of iterations.
//! * An active row that evaluates to NaN/inf (degenerate geometry such as a toe exactly at
//!   its hip joint), an OSQP iterate with a non-finite entry ([`QpStatus::NonFinite`]:
//!   discarded, and OSQP's workspace, warm start included, is rebuilt before the next
//!   solve; a dense solve whose rows or steps are not finite is not accepted), an infeasibility
//!   report or a
//!   solver fault: `Ok`, with a **fallback input**: the last QP-solved input if there is
//!   one ([`InputSource::LastSafe`]), else the nominal input
//!   ([`InputSource::NominalClipped`]). Only a finite, clipped [`InputSource::Qp`] output
//!   ever becomes the last safe input.
//!
//! Every returned input is clipped to the input box (ADMM meets it only to its
//! tolerance). [`FilterOutput::consecutive_fallbacks`] counts the cycles in a row whose
//! source was not [`InputSource::Qp`]. The slacks make the QP feasible for any rows, so
//! "infeasible" is a solver report, not a property of the problem.
//!
//! ```
//! use cbfgen::systems::tachyon3::catalog::{self, Capacity, Catalog, EdgeCuboid, Environment};
//! use cbfgen::filter::{EcbfFilter, InputSource};
//! use cbfgen::systems::tachyon3::model::{standard_posture, NU};
//! use nalgebra::Vector3;
//!
//! let mut filter = EcbfFilter::new(Catalog::new(Capacity::PAPER_WORST_CASE)?, catalog::default_settings())?;
//! let mut env = Environment::new(Capacity::PAPER_WORST_CASE)?;
//! let step = cbfgen::OrientedBox::axis_aligned(Vector3::new(0.8, 0.0, 0.15), Vector3::new(0.02, 1.0, 0.02))?;
//! env.push_edge(EdgeCuboid::from_box(&step))?;
//! let out = filter.update(&standard_posture(), &[0.0; NU], &env)?;
//! assert_eq!(out.source, InputSource::Qp);
//! assert!(out.u.iter().all(|u| u.abs() < 1e-3)); // at rest and safe: nothing to correct
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

mod qp;
mod settings;

use std::time::{Duration, Instant};

pub(crate) use qp::Iterate;
pub use qp::{Backend, EcbfQp, QpStatus, RowSpec};
pub use settings::{domain, FilterSettings, Solver, SolverSettings};

use crate::cpu_time::Stopwatch;
use crate::error::CbfError;
use crate::system::{BarrierSet, Row};

/// Where this cycle's input came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputSource {
    /// The QP's optimum.
    Qp,
    /// The iterate OSQP stopped at when it hit its iteration or time limit.
    Unconverged,
    /// Fallback: the last QP-solved input.
    LastSafe,
    /// Fallback before any QP was solved: the nominal input.
    NominalClipped,
}

impl InputSource {
    /// Every source, in declaration order.
    pub const ALL: [InputSource; 4] =
        [InputSource::Qp, InputSource::Unconverged, InputSource::LastSafe, InputSource::NominalClipped];

    /// Snake-case name, as written to CSV and shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            InputSource::Qp => "qp",
            InputSource::Unconverged => "unconverged",
            InputSource::LastSafe => "last_safe",
            InputSource::NominalClipped => "nominal_clipped",
        }
    }
}

/// One update's result of the typed filter (rows, their `h` and slacks are read through
/// the filter).
pub type FilterOutput<const NU: usize> = Output<[f64; NU]>;

/// One update's result, whatever holds the input: `[f64; NU]` in the typed filter
/// ([`FilterOutput`]), a slice or a vector where the size is known only at run time
/// ([`crate::dynamic`], the Python bindings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output<U> {
    /// The input to apply.
    pub u: U,
    /// Where `u` came from: the QP's optimum, an unconverged iterate, or a fallback.
    pub source: InputSource,
    /// How the solve ended (the dense solve's report, or OSQP's when OSQP answered);
    /// `None` when no solve was attempted (a non-finite row).
    pub status: Option<QpStatus>,
    /// Which solver answered; `None` when no solve was attempted.
    pub backend: Option<Backend>,
    /// Newton steps of the dense solve (0 when it did not run).
    pub dense_steps: u32,
    /// The dense solve ran and did not verify within its budget: under the default
    /// [`Solver::DenseThenOsqp`] OSQP answered this cycle instead (flagged here so a
    /// caller can count such cycles).
    pub dense_fallback: bool,
    /// The first active row that was not finite, if any.
    pub nonfinite_row: Option<usize>,
    /// OSQP's ADMM iterations this cycle; 0 when OSQP did not run.
    pub iterations: u32,
    /// Whether `u` is OSQP's iterate polished to the verified optimum by the dense solve;
    /// an unconverged OSQP iterate that polishes is reported as `Qp`.
    pub polished: bool,
    /// Rows that took part in the QP.
    pub active_rows: usize,
    /// Fallback cycles in a row, this one included (0 when `source` is `Qp`).
    pub consecutive_fallbacks: u32,
    /// Time in row evaluation and activation.
    pub eval_time: Duration,
    /// Time in the QP update and solve.
    pub solve_time: Duration,
    /// The thread's CPU time over the whole update (evaluation and solve), beside its wall
    /// time `eval_time + solve_time`: a gap between the two is the thread waiting (a VM
    /// stall, preemption), not work. `Duration::ZERO` where the platform has no thread
    /// clock ([`crate::cpu_time`]).
    pub cpu_time: Duration,
}

impl<U> Output<U> {
    /// The same result with the input held by `f(&u)` (a slice of it, a copy).
    pub fn map_input<'a, V>(&'a self, f: impl FnOnce(&'a U) -> V) -> Output<V> {
        Output {
            u: f(&self.u),
            source: self.source,
            status: self.status,
            backend: self.backend,
            dense_steps: self.dense_steps,
            dense_fallback: self.dense_fallback,
            nonfinite_row: self.nonfinite_row,
            iterations: self.iterations,
            polished: self.polished,
            active_rows: self.active_rows,
            consecutive_fallbacks: self.consecutive_fallbacks,
            eval_time: self.eval_time,
            solve_time: self.solve_time,
            cpu_time: self.cpu_time,
        }
    }
}

/// The ECBF-QP safety filter over the barrier set `B` of a system with `NU` inputs.
///
/// Generated systems name it `Filter` (`EcbfFilter<Barriers, NU>`).
#[derive(Debug)]
pub struct EcbfFilter<B: BarrierSet<NU>, const NU: usize> {
    barriers: B,
    settings: FilterSettings<NU>,
    qp: EcbfQp<NU>,
    /// Per row: the family's activation threshold on `h`.
    activation: Vec<f64>,
    active: Vec<bool>,
    last_safe: Option<[f64; NU]>,
    output: FilterOutput<NU>,
}

impl<B: BarrierSet<NU>, const NU: usize> EcbfFilter<B, NU> {
    /// Lay out the QP for `barriers`' rows and set OSQP up. The only allocations of the
    /// filter's life happen here (and in building `barriers`).
    ///
    /// # Errors
    /// Settings outside their domain or not matching the families
    /// ([`FilterSettings::validate`]), a row naming an input column twice, or an OSQP
    /// set-up failure.
    pub fn new(barriers: B, settings: FilterSettings<NU>) -> Result<Self, CbfError> {
        settings.validate(barriers.families())?;
        let gains: Vec<_> = settings.families.iter().map(|p| p.gains()).collect();
        let specs: Vec<RowSpec<'_>> = barriers
            .layout()
            .iter()
            .map(|s| RowSpec {
                columns: s.columns,
                gains: gains[s.family],
                slack_weight: settings.families[s.family].slack_weight,
            })
            .collect();
        let qp =
            EcbfQp::new(&specs, &settings.input_weights, &settings.input_min, &settings.input_max, settings.solver)?;
        let activation = barriers.layout().iter().map(|s| settings.families[s.family].activation).collect();
        let rows = barriers.layout().len();
        Ok(Self {
            barriers,
            settings,
            qp,
            activation,
            active: vec![false; rows],
            last_safe: None,
            output: FilterOutput {
                u: [0.0; NU],
                source: InputSource::NominalClipped,
                status: None,
                backend: None,
                dense_steps: 0,
                dense_fallback: false,
                nonfinite_row: None,
                iterations: 0,
                polished: false,
                active_rows: 0,
                consecutive_fallbacks: 0,
                eval_time: Duration::ZERO,
                solve_time: Duration::ZERO,
                cpu_time: Duration::ZERO,
            },
        })
    }

    /// One control update of a time-invariant system: [`EcbfFilter::update_at`] at
    /// `t = 0`.
    ///
    /// # Errors
    /// As [`EcbfFilter::update_at`].
    pub fn update(
        &mut self,
        x: &B::State,
        u_ref: &[f64; NU],
        params: &B::Params,
    ) -> Result<&FilterOutput<NU>, CbfError> {
        self.update_at(0.0, x, u_ref, params)
    }

    /// One control update: the safe input at time `t` (read by time-varying families
    /// only), state `x`, nominal input `u_ref` and this cycle's runtime parameters.
    /// Allocation-free.
    ///
    /// # Errors
    /// `x`, `t`, `u_ref` or `params` outside their domain (NaN/inf, `|x_i| >`
    /// [`STATE_LIMIT`](crate::system::STATE_LIMIT), `|u_ref_j| >`
    /// [`domain::MAX_INPUT`], parameters of another capacity); the filter is then
    /// unchanged. Solver trouble is not an error: see the [module docs](self).
    pub fn update_at(
        &mut self,
        t: f64,
        x: &B::State,
        u_ref: &[f64; NU],
        params: &B::Params,
    ) -> Result<&FilterOutput<NU>, CbfError> {
        settings::validate_nominal(u_ref)?;
        let watch = Stopwatch::start();
        let start = Instant::now();
        self.barriers.evaluate(t, x, params)?;
        let mut active_rows = 0;
        for ((on, row), &threshold) in self.active.iter_mut().zip(self.barriers.rows()).zip(&self.activation) {
            // A NaN row takes part, so the QP reports it (`nonfinite_row`) and the input
            // falls back, instead of the comparison quietly leaving it out.
            *on = row.active && (row.h() < threshold || row.h().is_nan());
            active_rows += usize::from(*on);
        }
        let evaluated = Instant::now();
        let solved = self.qp.solve(u_ref, self.barriers.rows(), &self.active);
        let out = &mut self.output;
        out.eval_time = evaluated - start;
        out.solve_time = evaluated.elapsed();
        out.cpu_time = watch.elapsed().1;
        out.active_rows = active_rows;
        let ok = solved.is_ok();
        out.iterations = if ok { self.qp.iterations() } else { 0 };
        out.polished = ok && self.qp.polished();
        out.backend = if ok { self.qp.backend() } else { None };
        out.dense_steps = if ok { self.qp.dense_steps() } else { 0 };
        out.dense_fallback = ok && self.qp.dense_fallback();
        (out.status, out.nonfinite_row) = match solved {
            Ok(status) => (Some(status), None),
            Err(CbfError::NonFiniteRow { row }) => (None, Some(row)),
            // `u_ref`, `x` and the row count were checked above, so nothing else reaches here.
            Err(_) => (Some(QpStatus::SolverFault), None),
        };
        (out.u, out.source) = match out.status {
            Some(s) if s.is_solved() || out.polished => (*self.qp.u(), InputSource::Qp),
            Some(QpStatus::MaxIterations | QpStatus::TimeLimit) => (*self.qp.u(), InputSource::Unconverged),
            _ => match self.last_safe {
                Some(u) => (u, InputSource::LastSafe),
                None => (*u_ref, InputSource::NominalClipped),
            },
        };
        // ADMM meets the box only to its tolerance; the caller gets it exactly.
        clip(&mut out.u, &self.settings.input_min, &self.settings.input_max);
        if out.source == InputSource::Qp {
            out.consecutive_fallbacks = 0;
            self.last_safe = Some(out.u);
        } else {
            out.consecutive_fallbacks = out.consecutive_fallbacks.saturating_add(1);
        }
        Ok(&self.output)
    }

    /// The last update's result.
    pub fn output(&self) -> &FilterOutput<NU> {
        &self.output
    }

    /// What the filter would fall back to now for nominal input `u_ref` (see the module
    /// docs): for a caller whose update returned `Err`. Always finite and inside the
    /// input box: a NaN entry of `u_ref` (which `update` would have refused) counts as 0.
    pub fn fallback_input(&self, u_ref: &[f64; NU]) -> [f64; NU] {
        let mut u = self.last_safe.unwrap_or(u_ref.map(|v| if v.is_nan() { 0.0 } else { v }));
        clip(&mut u, &self.settings.input_min, &self.settings.input_max);
        u
    }

    /// The barrier set: its families, row layout and the rows as last evaluated.
    pub fn barriers(&self) -> &B {
        &self.barriers
    }

    /// This cycle's rows: `[h, L_f h, …, L_f^r h]` and `L_g L_f^{r−1} h`.
    pub fn rows(&self) -> &[Row<NU>] {
        self.barriers.rows()
    }

    /// Which rows took part in the last QP.
    pub fn active(&self) -> &[bool] {
        &self.active
    }

    /// Slacks of the last QP iterate, one per row.
    pub fn delta(&self) -> &[f64] {
        self.qp.delta()
    }

    /// The settings the filter was built with.
    pub fn settings(&self) -> &FilterSettings<NU> {
        &self.settings
    }

    /// The last update's QP (active rows, their bounds and weights, the nominal input and
    /// box), stamped with time `t`, to replay against any solver. Allocates: for
    /// recording, not for the control path.
    pub fn recorded_qp(&self, t: f64) -> crate::qp::recorded::RecordedQp {
        self.qp.recorded(t)
    }

    /// The QP underneath (for inspection: non-zeros, last status).
    pub fn qp(&self) -> &EcbfQp<NU> {
        &self.qp
    }
}

fn clip<const NU: usize>(u: &mut [f64; NU], lo: &[f64; NU], hi: &[f64; NU]) {
    for j in 0..NU {
        u[j] = u[j].clamp(lo[j], hi[j]);
    }
}
