//! How a QP is solved: OSQP's settings with their documented ranges ([`SolverSettings`])
//! and the choice of solver ([`Solver`]), shared by the filter and the MPCs.

use std::time::Duration;

use super::status::{Backend, QpStatus};
use crate::error::{within, CbfError};

/// OSQP settings for this problem class, exposed as they are passed to the solver.
///
/// The defaults are chosen for a 1 ms cycle, warm-started each cycle from the last one:
/// * the QP is handed to OSQP already scaled (variables by `√w`, each row by its norm,
///   every cycle), so OSQP's own Ruiz scaling — computed once at set-up on values that
///   change every cycle — is off;
/// * polishing is off: it allocates and factorises a second system on every solve;
/// * ρ adapts on a fixed iteration interval (not OSQP's default fraction of set-up time),
///   so iteration counts are reproducible across machines and runs;
/// * loose tolerances (`eps_abs` 1e-3, `eps_rel` 1e-4, scaled units: m/s² for inputs of
///   weight 1) because ADMM only has to find the active set: the filter's dense solve
///   then starts from that face and answers only with a point that passes every KKT
///   condition (the polish step, allocation-free); OSQP's own iterate is never reported
///   as an optimum. 1e-4 tolerances cost twice the p99 iterations for nothing;
/// * at most 200 iterations (about 1 ms here): a cycle that needs more hands back the
///   iterate, flagged, and the next cycle continues from it;
/// * convergence is checked every 5 iterations: a check costs about one iteration, and
///   checking every iteration costs 40 % more instructions than it saves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Which solver answers ([`Solver::DenseThenOsqp`] by default).
    pub backend: Solver,
    /// Most rows the dense solve may add to its active set in one stage before it gives
    /// up, 1 ..= [`SolverSettings::MAX_ITERATIONS`] (the drops on the way are bounded by
    /// the inputs and not counted). Under [`Solver::DenseThenOsqp`] OSQP then runs; under
    /// [`Solver::Dense`] the point reached is handed back, flagged, and the next cycle's
    /// first stage continues from it (the cascade of relaxations starts from nothing at
    /// every cycle: see [`crate::qp::lexicographic`]).
    pub dense_max_steps: u32,
    /// Most work one dense solve may do over all its stages, in dense-solver trips
    /// ([`DualActiveSet::work`](super::dual_active_set::DualActiveSet::work): one
    /// multiply–add or a few flops on one entry), 1 ..= [`SolverSettings::MAX_WORK`]. A
    /// solve that spends it ends as one out of steps does (its point flagged, never called
    /// verified). With it the solve's work has a stated bound
    /// ([`LexicographicSolver::worst_case_work`](super::lexicographic::LexicographicSolver::worst_case_work)).
    /// The default, 10⁷ (about 10 ms here), cuts no answer short: the most a random
    /// problem of 18 inputs and 60 rows in three conflicting tiers took was 8.1·10⁶ (48
    /// least-violation stages), while Tachyon 3's updates take at most 3·10⁴. A controller
    /// that must finish within its period sets it lower and counts the flagged cycles
    /// (docs/filter.md, "The worst case").
    pub dense_max_work: u64,
    /// OSQP's absolute tolerance, in the scaled problem's units (\[m/s²\] for an input of
    /// weight 1); within [`SolverSettings::MIN_TOLERANCE`] ..=
    /// [`SolverSettings::MAX_TOLERANCE`].
    pub eps_abs: f64,
    /// OSQP's relative tolerance \[–\]; same range as `eps_abs`.
    pub eps_rel: f64,
    /// Most ADMM iterations per solve, 1 ..= [`SolverSettings::MAX_ITERATIONS`]; a solve
    /// that reaches it hands back its iterate, flagged
    /// [`QpStatus::MaxIterations`](super::QpStatus::MaxIterations).
    pub max_iter: u32,
    /// Initial ADMM step.
    pub rho: f64,
    /// ADMM's regularisation of the variables (OSQP's σ), within
    /// [`SolverSettings::SIGMA_RANGE`].
    pub sigma: f64,
    /// Over-relaxation, in (0, 2).
    pub alpha: f64,
    /// Whether OSQP adapts ρ during a solve, every `adaptive_rho_interval` iterations.
    pub adaptive_rho: bool,
    /// Iterations between ρ adaptations (each one refactorises).
    pub adaptive_rho_interval: u32,
    /// Iterations between convergence checks (each costs about one iteration).
    pub check_termination: u32,
    /// Give up (flagged, with a fallback input) after this long; `None` = no limit.
    pub time_limit: Option<Duration>,
    /// Start the dense solve from ADMM's active set and keep its answer when it verifies
    /// (this crate's allocation-free polish, used by the ECBF filter; OSQP's own stays
    /// off). Without it the filter hands on OSQP's iterate flagged
    /// [`QpStatus::MaxIterations`](super::QpStatus::MaxIterations), never as an optimum.
    pub polish: bool,
    /// OSQP's own Ruiz scaling passes, computed once at set-up: 0 (off) for a QP whose
    /// matrices change every cycle (the filter scales its rows itself), about 10 where
    /// they are constant (the multi-layer MPC). At most [`Self::MAX_SCALING`].
    pub scaling: u32,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SolverSettings {
    /// The defaults (the type's docs say why each).
    pub const DEFAULT: Self = Self {
        backend: Solver::DenseThenOsqp,
        dense_max_steps: 100,
        dense_max_work: 10_000_000,
        eps_abs: 1e-3,
        eps_rel: 1e-4,
        max_iter: 200,
        rho: 0.1,
        sigma: 1e-6,
        alpha: 1.6,
        adaptive_rho: true,
        adaptive_rho_interval: 25,
        check_termination: 5,
        time_limit: None,
        polish: true,
        scaling: 0,
    };

    /// Most work one dense solve may be given: 10¹⁰ trips, seconds of it.
    pub const MAX_WORK: u64 = 10_000_000_000;
    /// Most ADMM iterations one solve may take. With the time limit it bounds an update:
    /// 10⁴ iterations of the 269-row QP take tens of milliseconds, never hours.
    pub const MAX_ITERATIONS: u32 = 10_000;
    /// Longest time limit accepted: a thousand 1 ms control periods.
    pub const MAX_TIME_LIMIT: Duration = Duration::from_secs(1);
    /// Tolerances below this are rounding noise in double precision (OSQP's residuals are
    /// sums of hundreds of products), so they could only be met by running out of
    /// iterations.
    pub const MIN_TOLERANCE: f64 = 1e-12;
    /// Tolerances above this accept any iterate (the polish still checks KKT exactly).
    pub const MAX_TOLERANCE: f64 = 1e3;
    /// ρ range: OSQP's own clamp for adaptive ρ (`RHO_MIN`, `RHO_MAX`).
    pub const RHO_RANGE: [f64; 2] = [1e-6, 1e6];
    /// σ range: a regularisation below 1e-12 is lost in rounding, above 1e3 it dominates
    /// the cost.
    pub const SIGMA_RANGE: [f64; 2] = [1e-12, 1e3];
    /// Over-relaxation range: OSQP's open interval (0, 2), kept away from the ends where
    /// ADMM stops making progress.
    pub const ALPHA_RANGE: [f64; 2] = [0.01, 1.99];
    /// Most Ruiz scaling passes (OSQP's default is 10).
    pub const MAX_SCALING: u32 = 100;

    /// # Errors
    /// A value outside its documented range (the `MAX_*`, `MIN_*` and `*_RANGE` constants):
    /// every accepted combination ends a solve after at most [`Self::MAX_ITERATIONS`]
    /// iterations or [`Self::MAX_TIME_LIMIT`].
    pub fn validate(&self) -> Result<(), CbfError> {
        let tol = (Self::MIN_TOLERANCE, Self::MAX_TOLERANCE, "[1e-12, 1e3]");
        within("eps_abs", self.eps_abs, tol.0, tol.1, tol.2)?;
        within("eps_rel", self.eps_rel, tol.0, tol.1, tol.2)?;
        within("rho", self.rho, Self::RHO_RANGE[0], Self::RHO_RANGE[1], "[1e-6, 1e6]")?;
        within("sigma", self.sigma, Self::SIGMA_RANGE[0], Self::SIGMA_RANGE[1], "[1e-12, 1e3]")?;
        within("alpha", self.alpha, Self::ALPHA_RANGE[0], Self::ALPHA_RANGE[1], "[0.01, 1.99]")?;
        for (what, v) in [
            ("max_iter", self.max_iter),
            ("dense_max_steps", self.dense_max_steps),
            ("adaptive_rho_interval", self.adaptive_rho_interval),
            ("check_termination", self.check_termination),
        ] {
            if v == 0 {
                return Err(CbfError::NotPositive { what, value: 0.0 });
            }
            if v > Self::MAX_ITERATIONS {
                return Err(CbfError::TooLarge { what, value: v as usize, max: Self::MAX_ITERATIONS as usize });
            }
        }
        if self.dense_max_work == 0 {
            return Err(CbfError::NotPositive { what: "dense_max_work", value: 0.0 });
        }
        if self.dense_max_work > Self::MAX_WORK {
            return Err(CbfError::TooLarge {
                what: "dense_max_work",
                value: usize::try_from(self.dense_max_work).unwrap_or(usize::MAX),
                max: Self::MAX_WORK as usize,
            });
        }
        if self.scaling > Self::MAX_SCALING {
            return Err(CbfError::TooLarge {
                what: "scaling",
                value: self.scaling as usize,
                max: Self::MAX_SCALING as usize,
            });
        }
        if let Some(limit) = self.time_limit {
            if limit.is_zero() || limit > Self::MAX_TIME_LIMIT {
                return Err(CbfError::OutOfRange {
                    what: "time limit [s]",
                    value: limit.as_secs_f64(),
                    range: "(0, 1]",
                });
            }
        }
        Ok(())
    }

    /// A time limit from seconds, checked: `(0, MAX_TIME_LIMIT]`, never a panic (for
    /// callers holding seconds as a float, such as the Python bindings).
    ///
    /// # Errors
    /// NaN, infinite, non-positive or above [`Self::MAX_TIME_LIMIT`].
    pub fn time_limit_from_secs(secs: f64) -> Result<Duration, CbfError> {
        let max = Self::MAX_TIME_LIMIT.as_secs_f64();
        if within("time limit [s]", secs, 0.0, max, "(0, 1]")? == 0.0 {
            return Err(CbfError::NotPositive { what: "time limit [s]", value: secs });
        }
        // Below a nanosecond, the shortest limit a Duration holds.
        Ok(Duration::from_secs_f64(secs).max(Duration::from_nanos(1)))
    }

    /// These settings in OSQP's terms (quiet, warm-started, not polished), for a solver
    /// built outside the filter (the systems' MPCs) as for the filter's own.
    pub fn to_osqp(self) -> osqp::Settings {
        osqp::Settings::default()
            .verbose(false)
            .polish(false)
            .scaling(if self.scaling == 0 { None } else { Some(self.scaling) })
            .warm_start(true)
            .eps_abs(self.eps_abs)
            .eps_rel(self.eps_rel)
            .max_iter(self.max_iter)
            .rho(self.rho)
            .sigma(self.sigma)
            .alpha(self.alpha)
            .adaptive_rho(self.adaptive_rho)
            .adaptive_rho_interval(Some(self.adaptive_rho_interval))
            .check_termination(Some(self.check_termination))
            .time_limit(self.time_limit)
    }
}

/// Which solver answers a QP.
///
/// The dense solvers are exact: they answer only with a point that satisfies the QP's
/// optimality (KKT) conditions to a scale-aware tolerance, or not at all. OSQP (ADMM) is
/// approximate, to `eps_abs`/`eps_rel`, and needs many iterations on stiff or conflicting
/// rows; it is kept as the fallback and as the reference the dense solvers are tested
/// against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Solver {
    /// The dense solve only; when it does not verify within `dense_max_steps` its iterate
    /// is handed back, flagged unconverged.
    Dense,
    /// OSQP on the QP with every row hard (as the paper writes its QP; the paper names no
    /// solver), then the dense solve from
    /// OSQP's face when `polish` is set: it verifies the answer, or settles the priority
    /// tiers when the rows do not fit.
    Osqp,
    /// The dense solve, and OSQP only when the dense solve has not verified within its
    /// budget.
    #[default]
    DenseThenOsqp,
}

impl Solver {
    /// Every choice, in declaration order.
    pub const ALL: [Solver; 3] = [Solver::Dense, Solver::Osqp, Solver::DenseThenOsqp];

    /// Solve `qp` as this choice says — the dense solve, OSQP, or the dense solve and OSQP
    /// only when it did not return [`QpStatus::Solved`] — and say who answered. Shared by
    /// the QPs whose dense solve and OSQP solve are separate steps (the MPCs).
    pub fn run<Q>(
        self,
        qp: &mut Q,
        mut dense: impl FnMut(&mut Q) -> QpStatus,
        mut osqp: impl FnMut(&mut Q) -> QpStatus,
    ) -> (QpStatus, Backend) {
        match self {
            Solver::Osqp => (osqp(qp), Backend::Osqp),
            Solver::Dense => (dense(qp), Backend::Dense),
            Solver::DenseThenOsqp => match dense(qp) {
                QpStatus::Solved => (QpStatus::Solved, Backend::Dense),
                _ => (osqp(qp), Backend::Osqp),
            },
        }
    }

    /// Snake-case name, as accepted and shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            Solver::Dense => "dense",
            Solver::Osqp => "osqp",
            Solver::DenseThenOsqp => "dense_then_osqp",
        }
    }
}
