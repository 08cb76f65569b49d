//! The ECBF safety filter: one real-time control update (Tachyon 3 paper, section III-C),
//! for any system that implements [`BarrierSet`].
//!
//! Each cycle [`EcbfFilter::update`] evaluates every barrier row at the state, decides
//! which rows take part (the barrier set's own flags, then each family's activation
//! threshold on `h`), and finds the input
//!
//! ```text
//! rows:  L_g L_f^{r−1} h_i · u ≥ −(L_f^r h_i + Σ_k k_k L_f^k h_i)   (active rows)
//! box:   input_min ≤ u ≤ input_max
//! ```
//!
//! where `r` is row `i`'s relative degree and the gains `k` place its poles
//! ([`Gains::from_poles`](crate::system::Gains::from_poles)); rows of different degrees
//! share the QP.
//!
//! # The safety promise
//! Every row is **met exactly when the rows and the input box are compatible**: the
//! answer is then the closest input to the nominal one, `min Σ_j w_j (u_j − u_ref,j)²` —
//! or, for a system whose spec gives an objective ([`BarrierSet::has_objective`]),
//! `min ½ (u − u_ref)ᵀ P(x) (u − u_ref) + q(x)ᵀ u`, with `P(x)` checked positive definite
//! every cycle ([`crate::qp::metric`]).
//! When they are not, the families' priorities decide
//! ([`FamilyParams::priority`](crate::system::FamilyParams::priority)): tier 0 is met
//! if the box allows it, else relaxed as little as possible (its largest violation, in
//! input units, is the least possible, then the next largest, …); then tier 1 in the room
//! tier 0 leaves, and so on — a lexicographic solve ([`crate::qp::lexicographic`]), so no
//! row's strength depends on the units it is written in. And the filter **never reports
//! safety it did not achieve**: each output carries a [`Safety`] verdict, measured at the
//! input it returns ([`verdict`]), separate from the solve's status — every active row
//! met, or how many were relaxed, the worst of them with its slack and its [`Cause`]
//! (an input at its limit, a higher-priority row, a row of its own tier, no control
//! authority at this state, or a solve that did not finish), and per family
//! ([`EcbfFilter::relaxation`]) and per row ([`EcbfFilter::relaxed`]).
//!
//! The dense solve is exact and warm-started from the previous cycle's active sets, with
//! OSQP as the fallback when its first stage has not verified within its budget and as a
//! selectable reference backend ([`Solver`]). Everything is laid out when the filter is
//! built; after that an update allocates nothing, on any backend (tested by counting every
//! `malloc` over thousands of cycles).
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
//! * Settings are checked once, in [`EcbfFilter::new`]: every weight, pole, priority,
//!   limit and solver setting has a documented range ([`domain`],
//!   [`SolverSettings::validate`]), and capacities a maximum (for a generated system, [`system::MAX_INSTANCES`](crate::system::MAX_INSTANCES)).
//! * [`InputSource::Qp`] means the verified optimum, and nothing else. A solve that
//!   stops first — OSQP at its iteration or time limit, or with an answer the dense solve
//!   could not verify; the dense solve at its step budget (under [`Solver::Dense`]) — is
//!   `Ok` with the point it reached, [`InputSource::Unconverged`], its verdict measured
//!   like any other. The next cycle's solve continues from where this one stopped, so a
//!   hard instance converges over a few cycles instead of stalling one.
//! * An active row that evaluates to NaN/inf (degenerate geometry such as a toe exactly at
//!   its hip joint), an OSQP iterate with a non-finite entry ([`QpStatus::NonFinite`]:
//!   discarded, and OSQP's workspace, warm start included, is rebuilt before the next
//!   solve), an infeasibility report or a solver fault: `Ok`, with a **fallback input**:
//!   the last QP-solved input if there is one ([`InputSource::LastSafe`]), else the
//!   nominal input ([`InputSource::NominalClipped`]), its verdict measured on this cycle's
//!   rows (or [`Verdict::Unassessed`] when a row was not finite). Only a finite, clipped
//!   [`InputSource::Qp`] output ever becomes the last safe input.
//!
//! Every returned input is clipped to the input box. [`FilterOutput::consecutive_fallbacks`]
//! counts the cycles in a row whose source was not [`InputSource::Qp`].
//!
//! A system is anything that implements [`BarrierSet`]; generated code does, and so can a
//! few hand-written lines. A cart on a rail, `x = (p, v)`, input the acceleration `a`,
//! kept behind a wall at `p = wall`: `h = wall − p`, `ḣ = −v`, `ḧ = −a`, so relative
//! degree 2 with `L_f h = −v`, `L_f² h = 0`, `L_g L_f h = −1`. With poles (10, 10) the row
//! reads `−20 v + 100 h − a ≥ 0`: at `p = 0.9`, `v = 0.5` the most it allows is
//! `a = 100 · 0.1 − 20 · 0.5 = 0`.
//!
//! ```
//! use cbfgen::filter::{EcbfFilter, FilterSettings, InputSource};
//! use cbfgen::system::{BarrierSet, ClassK, FamilyInfo, FamilyKind, FamilyParams, InstanceKind, Poles, Row, RowLayout};
//!
//! struct Wall([Row<1>; 1]);
//!
//! const FAMILIES: [FamilyInfo; 1] = [FamilyInfo {
//!     name: "wall",
//!     kind: FamilyKind::Barrier,
//!     relative_degree: 2,
//!     row_names: &["wall"],
//!     members: &[],
//!     instances: InstanceKind::Fixed,
//!     count: 1,
//!     params: &[("wall", &[])],
//!     defaults: FamilyParams {
//!         poles: Poles::from_array([10.0, 10.0]),
//!         priority: 0,
//!         activation: f64::INFINITY,
//!         class_k: ClassK::LINEAR,
//!     },
//! }];
//! const LAYOUT: [RowLayout; 1] = [RowLayout { family: 0, member: 0, instance: 0, row: 0, columns: &[0] }];
//!
//! impl BarrierSet<1> for Wall {
//!     type State = [f64; 2];
//!     type Params = f64; // where the wall is
//!     fn families(&self) -> &[FamilyInfo] {
//!         &FAMILIES
//!     }
//!     fn layout(&self) -> &[RowLayout] {
//!         &LAYOUT
//!     }
//!     fn rows(&self) -> &[Row<1>] {
//!         &self.0
//!     }
//!     fn evaluate(&mut self, _t: f64, x: &[f64; 2], wall: &f64) -> Result<(), cbfgen::CbfError> {
//!         self.0[0].store(&[wall - x[0], -x[1], 0.0], &[-1.0], &[0]);
//!         Ok(())
//!     }
//! }
//!
//! let settings = FilterSettings::defaults(&FAMILIES, [-5.0], [5.0]);
//! let mut filter = EcbfFilter::new(Wall([Row::ZERO]), settings)?;
//! let out = filter.update(&[0.9, 0.5], &[3.0], &1.0)?; // the nominal input speeds up
//! assert_eq!(out.source, InputSource::Qp);
//! assert!(out.safety.is_met()); // the wall row holds at the returned input
//! assert!(out.u[0].abs() < 1e-6); // the closest input to 3 with −20 v + 100 h − a ≥ 0
//! let out = filter.update(&[0.0, 0.0], &[3.0], &1.0)?; // far from the wall
//! assert!((out.u[0] - 3.0).abs() < 1e-6); // nothing to correct
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

pub mod between_samples;
pub mod calibrate;
mod qp;
mod settings;
pub mod verdict;
pub mod work;

use std::time::{Duration, Instant};

pub use crate::qp::{Backend, QpStatus, Solver, SolverSettings};
pub use between_samples::{BetweenSamples, SampledData};
pub use qp::{EcbfQp, RowSpec};
pub use settings::{domain, FilterSettings};
pub use verdict::{Cause, FamilyRelaxation, Limit, RelaxedRow, Safety, Verdict};
pub use work::{BoundCheck, Calibration, Work, WorstCase};

use crate::cpu_time::thread_cpu_time;
use crate::error::CbfError;
use crate::interval::Interval;
use crate::qp::metric::InputMetric;
use crate::system::{BarrierSet, FamilyKind, Gains, Objective, Row, RowLayout};
use between_samples::{NotEnclosed, RowEnclosure, Why, Window};

/// A row short of its sampled-data certificate by `d` asks `MARGIN_STEP · d` more at the
/// sample in the next solve (a twentieth for the input moving with the margin), and
/// `LATER_MARGIN_STEP · d` in the solves after: where one step was not enough, the
/// input's move widens the enclosure with the margin (on the Panda's wrist a fifth of
/// the margin comes back as deficit).
const MARGIN_STEP: f64 = 1.05;
/// See [`MARGIN_STEP`].
const LATER_MARGIN_STEP: f64 = 1.5;

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
    /// The dense solve's first stage ran and did not verify within its budget: under the
    /// default [`Solver::DenseThenOsqp`] OSQP ran this cycle (flagged here so a caller can
    /// count such cycles).
    pub dense_fallback: bool,
    /// Least-violation stages the dense solve ran: 0 when every row fitted.
    pub elastic_stages: u32,
    /// The first active row that was not finite, if any.
    pub nonfinite_row: Option<usize>,
    /// OSQP's ADMM iterations this cycle; 0 when OSQP did not run.
    pub iterations: u32,
    /// Whether `u` came from OSQP's face, verified by the dense solve started from it.
    pub polished: bool,
    /// Rows that took part in the QP.
    pub active_rows: usize,
    /// Every active barrier row met at `u`, or which were relaxed and why (measured at
    /// `u`, whatever its source; see [`verdict`]).
    pub safety: Safety,
    /// The same for the rows of Lyapunov families
    /// ([`FamilyKind::Lyapunov`]): `Met` when every
    /// decrease `V̇ + λV ≤ 0` holds at `u` (and when the system has none), `Relaxed` with
    /// the worst when convergence gave way to safety or to the input limits. Never part
    /// of [`Output::safety`].
    pub convergence: Safety,
    /// Whether the rows met at the returned input are certified to hold until the next
    /// sample ([`between_samples`]): [`BetweenSamples::Off`] unless
    /// [`FilterSettings::sampled_data`] asks for it.
    pub between_samples: BetweenSamples,
    /// Fallback cycles in a row, this one included (0 when `source` is `Qp`).
    pub consecutive_fallbacks: u32,
    /// The work this update did, counted as it ran, over every solve: never above
    /// [`EcbfFilter::worst_case`] ([`work`]).
    pub work: Work,
    /// Time in row evaluation and activation.
    pub eval_time: Duration,
    /// Time in the QP update and solve, and the verdict's assessment.
    pub solve_time: Duration,
    /// The thread's CPU time over the whole update (evaluation and solve), beside its wall
    /// time `eval_time + solve_time`: a gap between the two is the thread waiting (a VM
    /// stall, preemption), not work. `None` unless
    /// [`FilterSettings::measure_cpu_time`] asks for it, or where the platform has no
    /// thread clock ([`crate::cpu_time`]). It can read zero on a short update: on some
    /// virtual machines the thread clock does not advance over a few microseconds, or
    /// steps back when the thread moves between cores (a step back is clamped to zero).
    pub cpu_time: Option<Duration>,
}

impl<U> Output<U> {
    /// What a filter reports before its first update: input `u`, nothing solved or
    /// assessed.
    pub(crate) fn before_any_update(u: U) -> Self {
        Output {
            u,
            source: InputSource::NominalClipped,
            status: None,
            backend: None,
            dense_steps: 0,
            dense_fallback: false,
            elastic_stages: 0,
            nonfinite_row: None,
            iterations: 0,
            polished: false,
            active_rows: 0,
            safety: Safety::UNASSESSED,
            convergence: Safety::UNASSESSED,
            between_samples: BetweenSamples::Off,
            consecutive_fallbacks: 0,
            work: Work::default(),
            eval_time: Duration::ZERO,
            solve_time: Duration::ZERO,
            cpu_time: None,
        }
    }

    /// The same result with the input held by `f(&u)` (a slice of it, a copy).
    pub fn map_input<'a, V>(&'a self, f: impl FnOnce(&'a U) -> V) -> Output<V> {
        Output {
            u: f(&self.u),
            source: self.source,
            status: self.status,
            backend: self.backend,
            dense_steps: self.dense_steps,
            dense_fallback: self.dense_fallback,
            elastic_stages: self.elastic_stages,
            nonfinite_row: self.nonfinite_row,
            iterations: self.iterations,
            polished: self.polished,
            active_rows: self.active_rows,
            safety: self.safety,
            convergence: self.convergence,
            between_samples: self.between_samples,
            consecutive_fallbacks: self.consecutive_fallbacks,
            work: self.work,
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
    /// Per family: this cycle's relaxations.
    relaxation: Vec<FamilyRelaxation>,
    last_safe: Option<[f64; NU]>,
    output: FilterOutput<NU>,
    /// The system's objective, when it has one ([`BarrierSet::has_objective`]): this
    /// cycle's `P(x)`, `q(x)`.
    cost: Option<Objective<NU>>,
    /// Per family: its ECBF gains (the certificate's enclosure of each row's bound).
    gains: Vec<Gains>,
    /// Per family: certified between the samples (not exempt, not Lyapunov).
    certified_family: Vec<bool>,
    /// Per row: the sampled-data margin of this update's last solve.
    margins: Vec<f64>,
    /// Per row: the margins of the round whose answer fell least short so far.
    best_margins: Vec<f64>,
    /// Per row: what the last certificate found missing (0 when certified or not checked).
    deficits: Vec<f64>,
    /// Per row: whether the certificate encloses it this round.
    wanted: Vec<bool>,
    /// Per row: the enclosures of the last certificate.
    enclosures: Vec<RowEnclosure<NU>>,
    /// The input the last successful update returned (what the plant is holding now),
    /// for a certificate with an input delay.
    applied: Option<[f64; NU]>,
}

impl<B: BarrierSet<NU>, const NU: usize> EcbfFilter<B, NU> {
    /// Lay out the QP for `barriers`' rows and set OSQP up. The only allocations of the
    /// filter's life happen here (and in building `barriers`).
    ///
    /// # Errors
    /// Settings outside their domain or not matching the families
    /// ([`FilterSettings::validate`]), a row naming an input column twice, or an OSQP
    /// set-up failure.
    pub fn new(mut barriers: B, settings: FilterSettings<NU>) -> Result<Self, CbfError> {
        settings.validate(barriers.families())?;
        // Off means off, even for barriers a caller set thresholds on before.
        barriers.cull_above(&cull_thresholds(&settings));
        let gains: Vec<_> = settings.families.iter().map(|p| p.gains()).collect();
        let specs = row_specs(barriers.layout(), &settings);
        let cost = barriers.has_objective().then(Objective::default);
        let qp = if cost.is_some() {
            // The objective is the cost: weights beside it would be a second, silent one.
            if let Some(&w) = settings.input_weights.iter().find(|&&w| w != 1.0) {
                return Err(CbfError::OutOfRange {
                    what: "input weight of a system with an objective (its P(x) is the cost; leave the weights at 1)",
                    value: w,
                    range: "[1, 1]",
                });
            }
            EcbfQp::with_cost_matrix(&specs, &settings.input_min, &settings.input_max, settings.solver)?
        } else {
            EcbfQp::new(&specs, &settings.input_weights, &settings.input_min, &settings.input_max, settings.solver)?
        };
        let activation = barriers.layout().iter().map(|s| settings.families[s.family].activation).collect();
        let rows = barriers.layout().len();
        let families = barriers.families().len();
        let certified_family = barriers
            .families()
            .iter()
            .enumerate()
            .map(|(k, f)| {
                f.kind == FamilyKind::Barrier
                    && settings.sampled_data.as_ref().is_some_and(|sd| !sd.exempt.contains(&k))
            })
            .collect();
        Ok(Self {
            barriers,
            settings,
            qp,
            activation,
            active: vec![false; rows],
            relaxation: vec![FamilyRelaxation::default(); families],
            last_safe: None,
            output: FilterOutput::before_any_update([0.0; NU]),
            cost,
            gains,
            certified_family,
            margins: vec![0.0; rows],
            best_margins: vec![0.0; rows],
            deficits: vec![0.0; rows],
            wanted: vec![false; rows],
            enclosures: vec![RowEnclosure::ZERO; rows],
            applied: None,
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
    /// [`domain::MAX_INPUT`], parameters of another capacity), or an objective whose `P(x)`
    /// is not positive definite at `x` ([`CbfError::NotPositiveDefinite`]) or whose
    /// unconstrained minimiser is beyond ±[`domain::MAX_INPUT`]; the filter's output is then
    /// unchanged. Solver trouble is not an error: see the [module docs](self).
    pub fn update_at(
        &mut self,
        t: f64,
        x: &B::State,
        u_ref: &[f64; NU],
        params: &B::Params,
    ) -> Result<&FilterOutput<NU>, CbfError> {
        // What the plant holds now, for a certificate with an input delay: unknown after an
        // update that returned an error (the caller chose what to apply).
        let before = self.applied.take();
        settings::validate_nominal(u_ref)?;
        let cpu_start = if self.settings.measure_cpu_time { thread_cpu_time() } else { None };
        let start = Instant::now();
        self.barriers.evaluate(t, x, params)?;
        // The cost: the weights' about u_ref, or the objective's metric about its centre.
        let centre = match &mut self.cost {
            None => *u_ref,
            Some(cost) => {
                self.barriers.objective(t, x, params, cost);
                let (metric, centre) = InputMetric::objective(&cost.p, &cost.q, u_ref)?;
                self.qp.set_metric(&metric)?;
                centre
            }
        };
        let mut active_rows = 0;
        for ((on, row), &threshold) in self.active.iter_mut().zip(self.barriers.rows()).zip(&self.activation) {
            // A NaN row takes part, so the QP reports it (`nonfinite_row`) and the input
            // falls back, instead of the comparison quietly leaving it out.
            *on = row.active && (row.h() < threshold || row.h().is_nan());
            active_rows += usize::from(*on);
        }
        let evaluated = Instant::now();
        self.output.eval_time = evaluated - start;
        self.margins.fill(0.0);
        self.deficits.fill(0.0);
        self.output.work = Work::default();
        self.solve_round(&centre, u_ref, active_rows);
        let mut between = BetweenSamples::Off;
        if let Some(sampled) = &self.settings.sampled_data {
            let max_rounds = sampled.max_rounds;
            let mut rounds = 1;
            // The least worst deficit so far, and how many rows the first solve relaxed.
            let (mut best, mut base_relaxed) = (f64::INFINITY, None);
            between = loop {
                let solved = self.output.source == InputSource::Qp;
                if !solved && rounds == 1 {
                    break self.uncertified(Why::NotSolved);
                }
                // A later round whose margins the solve could not meet (its budget, an
                // infeasibility) is a round that fell shorter: the best round is solved
                // again below, never the fallback input returned.
                let certified = if solved { self.certify(t, x, params, before) } else { Err(Why::NotSolved) };
                let worst = self.deficits.iter().fold(0.0, |m: f64, d| m.max(*d));
                // Rows the QP gave up at the sample: a margin that makes rows conflict
                // is worse than the deficit it was meant to cover.
                let relaxed = self.qp.relaxed().iter().filter(|r| r.is_some()).count();
                let first_relaxed = *base_relaxed.get_or_insert(relaxed);
                let last_is_best = match certified {
                    _ if !solved || relaxed > first_relaxed => false,
                    Ok(0) => break BetweenSamples::Certified { rounds },
                    Ok(_) => worst < best,
                    Err(_) => false,
                };
                if last_is_best {
                    best = worst;
                }
                if rounds >= max_rounds || !last_is_best {
                    // Raising the margins made this round fall shorter (or its flow
                    // could not be enclosed: an input fast enough to widen the
                    // enclosure faster than the margin grows): the answer that fell
                    // least short is returned, solved again, and reported as it is.
                    if !last_is_best && best.is_finite() {
                        self.margins.copy_from_slice(&self.best_margins);
                        self.solve_round(&centre, u_ref, active_rows);
                        if self.output.source != InputSource::Qp {
                            break self.uncertified(Why::NotSolved);
                        }
                        if let Err(why) = self.certify(t, x, params, before) {
                            break self.uncertified(why);
                        }
                    }
                    break match certified {
                        Err(why) if !best.is_finite() => self.uncertified(why),
                        _ => self.uncertified(Why::Deficit),
                    };
                }
                self.best_margins.copy_from_slice(&self.margins);
                // Each row short of its certificate asks more at the sample than it has
                // now — its margin where the row binds, its value where it does not (a
                // margin below the row's value changes nothing) — by its deficit and a
                // little more ([`MARGIN_STEP`]).
                let u = self.output.u;
                for (i, l) in self.barriers.layout().iter().enumerate() {
                    let d = self.deficits[i];
                    if d > 0.0 {
                        let at_sample = self.gains[l.family].condition(&self.barriers.rows()[i], &u);
                        let step = if rounds == 1 { MARGIN_STEP } else { LATER_MARGIN_STEP };
                        self.margins[i] = self.margins[i].max(at_sample) + step * d;
                    }
                }
                rounds += 1;
                self.solve_round(&centre, u_ref, active_rows);
            };
        }
        let out = &mut self.output;
        out.between_samples = between;
        if out.source == InputSource::Qp {
            out.consecutive_fallbacks = 0;
            self.last_safe = Some(out.u);
        } else {
            out.consecutive_fallbacks = out.consecutive_fallbacks.saturating_add(1);
        }
        self.applied = Some(out.u);
        // The verdict, measured at the input returned.
        self.relaxation.fill(FamilyRelaxation::default());
        if out.nonfinite_row.is_some() {
            self.qp.clear_assessment();
            (out.safety, out.convergence) = (Safety::UNASSESSED, Safety::UNASSESSED);
        } else {
            self.qp.assess(&out.u);
            // [barriers, Lyapunov families]: (relaxed rows, worst).
            let mut verdicts: [(usize, Option<RelaxedRow>); 2] = [(0, None), (0, None)];
            let families = self.barriers.families();
            for (i, cause) in self.qp.relaxed().iter().enumerate() {
                let Some(cause) = *cause else { continue };
                let family = self.barriers.layout()[i].family;
                let (slack, relative) = (self.qp.delta()[i], self.qp.relative_slack()[i]);
                let f = &mut self.relaxation[family];
                f.relaxed_rows += 1;
                f.max_slack = f.max_slack.max(slack);
                f.max_relative = f.max_relative.max(relative);
                let (count, worst) = &mut verdicts[usize::from(families[family].kind == FamilyKind::Lyapunov)];
                *count += 1;
                if worst.is_none_or(|w| relative > w.relative) {
                    *worst = Some(RelaxedRow { row: i, family, slack, relative, cause });
                }
            }
            let [safety, convergence] = verdicts.map(|(relaxed_rows, worst)| Safety {
                verdict: if relaxed_rows == 0 { Verdict::Met } else { Verdict::Relaxed },
                relaxed_rows,
                worst,
            });
            (out.safety, out.convergence) = (safety, convergence);
        }
        out.solve_time = evaluated.elapsed();
        out.cpu_time = cpu_start.and_then(|a| Some(thread_cpu_time()?.saturating_sub(a)));
        Ok(&self.output)
    }

    /// One QP solve of this cycle's active rows with the current margins: the output's
    /// solve fields, its input (clipped to the box) and source.
    fn solve_round(&mut self, centre: &[f64; NU], u_ref: &[f64; NU], active_rows: usize) {
        self.qp.set_margins(&self.margins);
        let solved = self.qp.solve(centre, self.barriers.rows(), &self.active);
        let out = &mut self.output;
        if solved.is_ok() {
            let work = &mut out.work;
            work.qp_solves += 1;
            work.dense_trips = work.dense_trips.saturating_add(self.qp.dense_work());
            work.osqp_iterations = work.osqp_iterations.saturating_add(self.qp.iterations());
        }
        out.active_rows = active_rows;
        let ok = solved.is_ok();
        out.iterations = if ok { self.qp.iterations() } else { 0 };
        out.polished = ok && self.qp.polished();
        out.backend = if ok { self.qp.backend() } else { None };
        out.dense_steps = if ok { self.qp.dense_steps() } else { 0 };
        out.dense_fallback = ok && self.qp.dense_fallback();
        out.elastic_stages = if ok { self.qp.elastic_stages() } else { 0 };
        (out.status, out.nonfinite_row) = match solved {
            Ok(status) => (Some(status), None),
            Err(CbfError::NonFiniteRow { row }) => (None, Some(row)),
            // `u_ref`, `x` and the row count were checked above, so nothing else reaches here.
            Err(_) => (Some(QpStatus::SolverFault), None),
        };
        (out.u, out.source) = match out.status {
            Some(QpStatus::Solved) if self.qp.verified() => (*self.qp.u(), InputSource::Qp),
            Some(QpStatus::MaxIterations | QpStatus::TimeLimit) => (*self.qp.u(), InputSource::Unconverged),
            _ => match self.last_safe {
                Some(u) => (u, InputSource::LastSafe),
                None => (*u_ref, InputSource::NominalClipped),
            },
        };
        // The dense solve meets the box only to its tolerance, ADMM to its own; the caller
        // gets it exactly.
        clip(&mut out.u, &self.settings.input_min, &self.settings.input_max);
    }

    /// Enclose every active barrier row met at the output's input over the period it is
    /// held ([`between_samples`]), and write each row's deficit (how far its enclosure of
    /// `ψ = a·u + b` reaches below 0). Returns how many rows fall short.
    fn certify(&mut self, t: f64, x: &B::State, params: &B::Params, before: Option<[f64; NU]>) -> Result<usize, Why> {
        let Some(sampled) = &self.settings.sampled_data else { return Ok(0) };
        let u = self.output.u;
        self.qp.assess(&u);
        for (i, l) in self.barriers.layout().iter().enumerate() {
            self.wanted[i] = self.active[i] && self.certified_family[l.family] && self.qp.relaxed()[i].is_none();
        }
        if !self.wanted.contains(&true) {
            return Ok(0); // nothing to certify (and nothing to enclose)
        }
        let before = sampled.input_delay.then(|| match before {
            Some(u) => u.map(Interval::point),
            // Before any input was returned the plant may hold anything in the box.
            None => core::array::from_fn(|j| Interval::new(self.settings.input_min[j], self.settings.input_max[j])),
        });
        let window = Window { t, period: sampled.period, before, u };
        match self.barriers.enclose(&window, x, params, &self.wanted, &mut self.enclosures) {
            Ok(()) => {}
            // The filter's vectors are the rows' length: a mismatch is a barrier set that
            // cannot enclose its own rows.
            Err(NotEnclosed::NoIntervalForm { .. } | NotEnclosed::LengthMismatch) => return Err(Why::NoIntervalForm),
            Err(NotEnclosed::Flow) => return Err(Why::Flow),
        }
        let mut short = 0;
        for (i, l) in self.barriers.layout().iter().enumerate() {
            self.deficits[i] = 0.0;
            if !self.wanted[i] {
                continue;
            }
            let psi = self.gains[l.family].condition_enclosure(&self.enclosures[i], &u);
            // Short by no more than the verdict's own rounding allowance at the sample
            // (`MET_TOLERANCE` of the row's size): met between the samples as the row is
            // met at them.
            let row = &self.barriers.rows()[i];
            if psi.lo >= -qp::met_allowance(&row.lg, self.gains[l.family].bound(&row.lie), &u) {
                continue;
            }
            if !psi.lo.is_finite() {
                self.deficits[i] = f64::INFINITY;
                return Err(Why::Flow);
            }
            self.deficits[i] = -psi.lo;
            short += 1;
        }
        Ok(short)
    }

    /// The certificate's report when it fails for `why`: the rows still short (all the
    /// rows it wanted when it could not enclose them), and the largest deficit.
    fn uncertified(&self, why: Why) -> BetweenSamples {
        let worst = self
            .deficits
            .iter()
            .enumerate()
            .filter(|(_, d)| **d > 0.0)
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, &d)| (i, d));
        let rows = match why {
            Why::Deficit => self.deficits.iter().filter(|d| **d > 0.0).count(),
            Why::NotSolved => 0,
            Why::NoIntervalForm | Why::Flow => self.wanted.iter().filter(|w| **w).count(),
        };
        BetweenSamples::Uncertified { rows, worst, why }
    }

    /// Per row: the sampled-data margin the last update's final solve asked of it at the
    /// sample (`a·u + b ≥ margin`; 0 without [`FilterSettings::sampled_data`], and for rows
    /// the certificate did not need to raise).
    pub fn margins(&self) -> &[f64] {
        &self.margins
    }

    /// Per row: by how much the last certificate found the row's `ψ` could fall below 0
    /// between the samples at the returned input (0 for rows certified or not checked).
    pub fn deficits(&self) -> &[f64] {
        &self.deficits
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

    /// The most one update can do with this filter's rows and settings, whatever the
    /// state, the rows and the history ([`work`]): every [`Output::work`] is within it.
    pub fn worst_case(&self) -> WorstCase {
        let per_solve = self.qp.worst_case();
        // The first solve, each later round's, and the best round solved again.
        let (qp_solves, enclosures) = match &self.settings.sampled_data {
            None => (1, 0),
            Some(sampled) => (sampled.max_rounds.saturating_add(1), sampled.max_rounds.saturating_add(1)),
        };
        // Each enclosure, and each row's condition read from it.
        let interval_ops = match &self.settings.sampled_data {
            None => Some(crate::ops::OpCount::ZERO),
            Some(sampled) => self.barriers.enclosure_ops().map(|e| {
                let conditions = Gains::condition_enclosure_ops(NU).times(self.barriers.layout().len() as u64);
                (e.window(sampled.input_delay) + conditions).times(u64::from(enclosures))
            }),
        };
        WorstCase {
            qp_solves,
            dense_trips: per_solve.dense_trips.saturating_mul(u64::from(qp_solves)),
            osqp_iterations: per_solve.osqp_iterations.saturating_mul(qp_solves),
            row_ops: self.barriers.evaluation_ops(),
            enclosures,
            interval_ops,
        }
    }

    /// This machine's rates for this filter's work ([`calibrate`]): its size and solver
    /// settings, its own row evaluation at `t`, `x`, `params` with nothing culled (the
    /// evaluation [`WorstCase::row_ops`] states) and, with the certificate, its rows'
    /// interval kernels at `x` (the rate of [`WorstCase::interval_ops`]). Takes a second
    /// or so; not for the control path (it allocates). The filter's rows are left
    /// evaluated at `x`.
    ///
    /// # Errors
    /// As [`calibrate::osqp_iteration_ns`].
    pub fn calibrate(&mut self, t: f64, x: &B::State, params: &B::Params) -> Result<work::Calibration, CbfError>
    where
        B::State: AsRef<[f64]>,
    {
        let families = self.barriers.families().len();
        self.barriers.cull_above(&vec![f64::INFINITY; families]);
        let specs = row_specs(self.barriers.layout(), &self.settings);
        let (solver, ops) = (self.settings.solver, self.barriers.evaluation_ops());
        let barriers = &mut self.barriers;
        let mut measured = work::Calibration::measure::<NU>(&specs, &solver, ops, || {
            // A state the filter rejects is timed as far as it ran; the caller's own
            // updates report it.
            let _ = barriers.evaluate(t, x, params);
        });
        // The certificate's rate: every row enclosed over the state itself (the rows'
        // interval kernels, each once: the count `enclosure_ops` states for them); where
        // the rows are not enclosed over a box on their own (a wrapper whose flow is its
        // own), the interval solve at the inputs' size.
        if let (Ok(m), Some(_), Some(e)) = (&mut measured, &self.settings.sampled_data, self.barriers.enclosure_ops()) {
            let states: Vec<Interval> = x.as_ref().iter().map(|&v| Interval::point(v)).collect();
            let times = Interval::point(t);
            self.wanted.fill(true);
            let (barriers, wanted, out) = (&self.barriers, &self.wanted, &mut self.enclosures);
            m.ns_per_interval_op = if barriers.enclose_over(&states, times, params, wanted, out).is_ok() {
                calibrate::op_ns(e.rows, 50, || {
                    let _ = barriers.enclose_over(&states, times, params, wanted, out);
                })
            } else {
                calibrate::interval_solve_ns::<NU>(50)
            };
        }
        self.barriers.cull_above(&cull_thresholds(&self.settings));
        measured
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

    /// Per row, at the last returned input: by how much it is missed,
    /// `max(0, −(a·u + b))`, in the row's units (0 for inactive rows, and for every row
    /// after a cycle whose rows were not finite).
    pub fn delta(&self) -> &[f64] {
        self.qp.delta()
    }

    /// Per row, at the last returned input: the slack relative to the row's terms `|b| +
    /// Σ_j |a_j u_j|`, for the rows relaxed (0 otherwise).
    pub fn relative_slack(&self) -> &[f64] {
        self.qp.relative_slack()
    }

    /// Per row, at the last returned input: why it was relaxed, for the rows missed beyond
    /// [`verdict::MET_TOLERANCE`]; `None` for rows met or inactive.
    pub fn relaxed(&self) -> &[Option<Cause>] {
        self.qp.relaxed()
    }

    /// Per family (indexed like the barrier set's families): its relaxed rows in the last
    /// update, and their largest slack and relative slack.
    pub fn relaxation(&self) -> &[FamilyRelaxation] {
        &self.relaxation
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

/// Each row's description for the QP: its input columns, its family's gains and priority.
fn row_specs<const NU: usize>(layout: &[RowLayout], settings: &FilterSettings<NU>) -> Vec<RowSpec<'static>> {
    layout
        .iter()
        .map(|s| {
            let family = &settings.families[s.family];
            RowSpec { columns: s.columns, gains: family.gains(), priority: family.priority }
        })
        .collect()
}

/// Each family's culling threshold: its activation, or `+∞` (none) when culling is off.
fn cull_thresholds<const NU: usize>(settings: &FilterSettings<NU>) -> Vec<f64> {
    settings.families.iter().map(|p| if settings.cull_far_rows { p.activation } else { f64::INFINITY }).collect()
}

fn clip<const NU: usize>(u: &mut [f64; NU], lo: &[f64; NU], hi: &[f64; NU]) {
    for j in 0..NU {
        u[j] = u[j].clamp(lo[j], hi[j]);
    }
}
