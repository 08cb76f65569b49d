//! Safe between the samples: a certified sampled-data margin for every ECBF row.
//!
//! The ECBF rows hold in continuous time: row `i` asks `ψ_i(x, u) = a_i(x)·u + b_i(x) ≥ 0`
//! (`a = L_g L_f^{r−1} h`, `b = L_f^r h + Σ k_j L_f^j h`), and `ψ_i ≥ 0` at every instant
//! keeps `h_i ≥ 0` from any state of the ECBF's safe set. A controller holds the input
//! for a whole period `Δt` (zero-order hold), so the row met at the sample `t_k` can fail
//! at `t_k + τ`: the Panda among OSCBF's obstacles dipped 35.5 µm into an obstacle between
//! samples with every row met at every sample.
//!
//! With [`SampledData`] in the filter's settings, each update **certifies** its answer `u`:
//!
//! 1. the states the plant can reach while `u` is held, `x(t_k + τ)` for `τ ∈ [0, Δt]`,
//!    are enclosed in a box `B` ([`enclose_flow`]: a Picard iteration on the interval
//!    extension of `f(x) + g(x) u`, accepted only when `x_k + [0, Δt]·F(B) ⊆ B`, which
//!    proves the flow stays in `B`; where no such box is found the period is enclosed in
//!    pieces, each halved as needed, [`enclose_window`]);
//! 2. every active row's `ψ_i(·, u)` is enclosed over `B` (and the time window), by running
//!    its generated kernel — the same straight line the filter runs on `f64` — on
//!    [`Interval`]s, every operation rounded outward;
//! 3. a row whose enclosure reaches below 0, by its deficit `d_i`, gets a margin: the QP
//!    is solved again with `a_i·u + b_i ≥ μ_i`, `μ_i` the row's value at the sample (or
//!    its margin, where it binds) plus `1.05 d_i` (`1.5 d_i` from the third solve on: the
//!    input moves with the margin and can widen the enclosure with it), and the new
//!    answer is certified afresh, up to
//!    [`SampledData::max_rounds`] solves. Where raising the margins made the answer fall
//!    shorter (a fast input widens the enclosure faster than the margin grows: the
//!    Panda's wrist), the round that fell least short is solved again and returned,
//!    reported uncertified ([`Why::Deficit`]): the margins never make the answer worse
//!    than the plain ECBF's.
//!
//! So the margin comes from bounds, never from sampling, and it is as small as the
//! enclosure allows at the input actually applied (a margin from the input box's worst
//! case would be useless where the box is wide: the double integrator's is ±10⁶ m/s²).
//! With [`SampledData::input_delay`] the input is taken to apply one period late, on
//! `[t_k + Δt, t_k + 2Δt]`, after the input returned last (or, before the first, any input
//! in the box).
//!
//! What is certified, and what is not:
//! * a row **certified** has `ψ_i ≥ 0` at every instant of the period for the plant
//!   `ẋ = f(x) + g(x) u` (the model the kernels are generated from), so `h_i ≥ 0` until the
//!   next sample from any state of the ECBF's safe set;
//! * rows that are not active (above their family's activation threshold, or culled)
//!   take no part and are not certified; nor are rows the QP relaxed (the safety
//!   verdict already reports them), Lyapunov rows, or rows of families in
//!   [`SampledData::exempt`];
//! * a barrier set without an interval form (one written by hand, or the joint-torque
//!   wrapper [`JointTorque`](crate::torque::JointTorque) without
//!   [`with_interval_dynamics`](crate::torque::JointTorque::with_interval_dynamics))
//!   cannot be certified: the update says so ([`Why::NoIntervalForm`]) instead of
//!   claiming it. With it, the torque-controlled plant `M(q) q̈ + b(q, q̇) = τ` is
//!   enclosed through the generated rigid-body dynamics on intervals, tightened by their
//!   rates on [`Dual`](crate::dual::Dual) intervals.
//!
//! Every update reports what it achieved in [`Output::between_samples`](super::Output)
//! ([`BetweenSamples`]), and per row the margin it used
//! ([`EcbfFilter::margins`](super::EcbfFilter::margins)).
//!
//! **Stack.** The certificate allocates nothing: its buffers are on the stack. A generated
//! row's interval inputs and outputs take up to 2 × [`MAX_FLAT`] intervals and its
//! parameters [`MAX_FLAT`] numbers (40 KiB), the flow's input matrix [`MAX_FLAT`]
//! intervals (16 KiB); the interval rigid-body dynamics keep per-body composite inertias
//! and placements for [`MAX_BODIES`](crate::rigid_body::MAX_BODIES) bodies (about
//! 50 KiB). A thread that runs a certified filter needs about 128 KiB of stack beyond its
//! own (Rust's spawned threads have 2 MiB, the main thread 8 MiB).

use crate::dynamic::GeneratedSystem;
use crate::error::CbfError;
use crate::interval::Interval;
use crate::ops::OpCount;
use crate::system::{RowLayout, MAX_RELATIVE_DEGREE};

/// Settings of the sampled-data certificate ([module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct SampledData {
    /// The control period `Δt` \[s\]: how long each input is held. Within
    /// [`PERIOD_RANGE`].
    pub period: f64,
    /// The input applies one period late (on `[t_k + Δt, t_k + 2Δt]`), the previous
    /// update's input held until then.
    pub input_delay: bool,
    /// Most QP solves per update, the first included (`1..=`[`MAX_ROUNDS`]): each
    /// solve after the first raises the margins of the rows the last one could not
    /// certify. One more solve returns the round that fell least short when a later
    /// one fell shorter.
    pub max_rounds: u32,
    /// Families (indices into the barrier set's families) whose rows are not certified:
    /// they take part in the QP as usual, with no margin.
    pub exempt: Vec<usize>,
}

/// The periods accepted \[s\]: from 1 µs to 1 s.
pub const PERIOD_RANGE: [f64; 2] = [1e-6, 1.0];
/// The most solves [`SampledData::max_rounds`] allows.
pub const MAX_ROUNDS: u32 = 16;

impl SampledData {
    /// Certify every family for a control period of `period` seconds, no input delay, up
    /// to 4 solves per update.
    pub fn every_family(period: f64) -> Self {
        Self { period, input_delay: false, max_rounds: 4, exempt: Vec::new() }
    }

    /// Check the settings against `families` families.
    ///
    /// # Errors
    /// A period outside [`PERIOD_RANGE`], `max_rounds` outside `1..=`[`MAX_ROUNDS`], or an
    /// exempt family index past the families.
    pub fn validate(&self, families: usize) -> Result<(), CbfError> {
        crate::error::within("sampled-data period", self.period, PERIOD_RANGE[0], PERIOD_RANGE[1], "[1e-6, 1]")?;
        if !(1..=MAX_ROUNDS).contains(&self.max_rounds) {
            return Err(CbfError::OutOfRange {
                what: "sampled-data solves per update",
                value: f64::from(self.max_rounds),
                range: "[1, 16]",
            });
        }
        if let Some(&f) = self.exempt.iter().find(|&&f| f >= families) {
            return Err(CbfError::TooLarge { what: "exempt family index", value: f, max: families.saturating_sub(1) });
        }
        Ok(())
    }
}

/// What one update achieved between the samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BetweenSamples {
    /// Not asked for ([`FilterSettings::sampled_data`](super::FilterSettings) is `None`),
    /// or nothing assessed this cycle (a non-finite row).
    Off,
    /// Every active barrier row met at the returned input is certified for the whole
    /// period, after `rounds` solves.
    Certified {
        /// QP solves this update (1: no margin was needed).
        rounds: u32,
    },
    /// `rows` active rows met at the sample are not certified between the samples.
    Uncertified {
        /// How many.
        rows: usize,
        /// The one with the largest deficit (in its row's units; `∞` when it could not be
        /// enclosed at all), if any row was enclosed.
        worst: Option<(usize, f64)>,
        /// Why.
        why: Why,
    },
}

impl BetweenSamples {
    /// Whether the update was certified.
    pub fn is_certified(&self) -> bool {
        matches!(self, BetweenSamples::Certified { .. })
    }

    /// Snake-case name of the outcome, as shown in Python: "off", "certified" or
    /// "uncertified".
    pub const fn name(&self) -> &'static str {
        match self {
            BetweenSamples::Off => "off",
            BetweenSamples::Certified { .. } => "certified",
            BetweenSamples::Uncertified { .. } => "uncertified",
        }
    }
}

/// Why an update is not certified between the samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Why {
    /// The margins still left a deficit after [`SampledData::max_rounds`] solves (or the
    /// raised margins made the rows conflict, and the QP relaxed them).
    Deficit,
    /// A row has no interval form (a hand-written barrier set, or rows through the
    /// joint-torque wrapper without its interval dynamics).
    NoIntervalForm,
    /// The reachable states could not be enclosed: the flow leaves every box the
    /// iteration tried within the period (a state or input far too fast for `Δt`), or an
    /// enclosure was not finite.
    Flow,
    /// The input is not the QP's verified answer (a fallback or an unconverged
    /// iterate): there was nothing to certify.
    NotSolved,
}

impl Why {
    /// Snake-case name, as shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            Why::Deficit => "deficit",
            Why::NoIntervalForm => "no_interval_form",
            Why::Flow => "flow",
            Why::NotSolved => "not_solved",
        }
    }
}

/// One row enclosed over a window: `h, L_f h, …, L_f^r h` and `L_g L_f^{r−1} h` (on every
/// input column, 0 where the row has none), each an interval holding every value the row
/// takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowEnclosure<const NU: usize> {
    /// `h, L_f h, …, L_f^r h`.
    pub lie: [Interval; MAX_RELATIVE_DEGREE + 1],
    /// `L_g L_f^{r−1} h` per input.
    pub lg: [Interval; NU],
}

impl<const NU: usize> RowEnclosure<NU> {
    /// Every entry 0.
    pub const ZERO: Self =
        Self { lie: [Interval { lo: 0.0, hi: 0.0 }; MAX_RELATIVE_DEGREE + 1], lg: [Interval { lo: 0.0, hi: 0.0 }; NU] };
}

/// The window a row is enclosed over: the input `u` held from `t` for `period` seconds,
/// or, with a delay, `before` held first for one period and then `u` for one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window<const NU: usize> {
    /// The sample's time \[s\].
    pub t: f64,
    /// `Δt` \[s\].
    pub period: f64,
    /// With an input delay: what is held during the first period (the previous input, or
    /// the input box before there is one).
    pub before: Option<[Interval; NU]>,
    /// The input whose rows are certified.
    pub u: [f64; NU],
}

/// Why rows could not be enclosed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NotEnclosed {
    /// No interval form (see [`Why::NoIntervalForm`]); `row` is the first such row.
    NoIntervalForm {
        /// The row.
        row: usize,
    },
    /// The flow could not be enclosed (see [`Why::Flow`]).
    Flow,
    /// `wanted` or `out` of another length than the rows (a caller's bug; the filter
    /// never passes one).
    LengthMismatch,
}

/// A kernel on intervals behind the flat signature: inputs in, outputs out.
pub type IntervalCall = fn(&[Interval], &mut [Interval]);

/// One generated kernel on intervals, behind a flat signature (the interval twin of
/// [`KernelEntry`](crate::system::KernelEntry)), with the input columns of its `lg_lf`
/// output. Generated systems list their dynamics and each barrier member in
/// `INTERVAL_KERNELS` ([`GeneratedSystem::INTERVAL_KERNELS`]).
#[derive(Debug, Clone, Copy)]
pub struct IntervalKernel {
    /// The kernel's function name.
    pub name: &'static str,
    /// Inputs in argument order: name and number of scalars.
    pub inputs: &'static [(&'static str, usize)],
    /// Outputs in return order: name and number of scalars.
    pub outputs: &'static [(&'static str, usize)],
    /// The input columns of the kernel's `lg_lf` output (empty for the dynamics).
    pub columns: &'static [usize],
    /// The kernel on intervals, inputs and outputs flattened as in
    /// [`KernelEntry::call`](crate::system::KernelEntry); `None`: the member has no
    /// interval form.
    pub call: Option<IntervalCall>,
}

impl IntervalKernel {
    /// A member without an interval form.
    pub const NONE: Self = Self { name: "", inputs: &[], outputs: &[], columns: &[], call: None };

    fn input_len(&self) -> usize {
        self.inputs.iter().map(|i| i.1).sum()
    }

    fn output_len(&self) -> usize {
        self.outputs.iter().map(|o| o.1).sum()
    }
}

/// Most scalars a kernel's flat inputs or outputs may hold on the certificate's path
/// (stack buffers: the control path does not allocate). A larger member reports
/// [`NotEnclosed::NoIntervalForm`].
pub const MAX_FLAT: usize = 1024;

/// Picard steps [`enclose_flow`] tries before giving up.
const MAX_PICARD: usize = 6;

/// How many times [`enclose_window`] halves a piece of the period whose flow could not be
/// enclosed: the shortest piece is `Δt / 2^MAX_HALVINGS`.
pub const MAX_HALVINGS: u32 = 6;

/// Field evaluations one [`enclose_flow`] makes at most: the first step from `x0` and up
/// to `MAX_PICARD` more.
pub const MAX_FIELD_CALLS: u32 = 1 + MAX_PICARD as u32;

/// [`enclose_flow`] calls one window's pieces make at most: each of the period's
/// `2^MAX_HALVINGS` shortest pieces once, and each halving once (a piece is never longer
/// than the last one, so there are at most [`MAX_HALVINGS`] halvings).
pub const MAX_PIECES: u32 = (1 << MAX_HALVINGS) + MAX_HALVINGS;

/// What one [`BarrierSet::enclose`](crate::system::BarrierSet::enclose) of every row
/// performs at most, in interval operations ([`BarrierSet::enclosure_ops`](crate::system::BarrierSet::enclosure_ops)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EnclosureOps {
    /// One evaluation of the dynamics over a box, `f(B) + g(B) u`.
    pub field: OpCount,
    /// The states.
    pub states: usize,
    /// What a wrapper that encloses the flow itself does with the reached box before the
    /// rows (the [joint-torque map](crate::torque::JointTorque)'s tightening); zero for a
    /// generated system.
    pub refine: OpCount,
    /// Every row's kernel once ([`BarrierSet::enclose_over`](crate::system::BarrierSet::enclose_over)
    /// of every row).
    pub rows: OpCount,
}

impl EnclosureOps {
    /// The whole enclosure over a window, with or without a delayed input (two periods'
    /// flows then): every piece's field evaluations ([`MAX_PIECES`] ×
    /// [`MAX_FIELD_CALLS`]), each step's `x0 + τ·F` and the end's `x0 + h·F`, the
    /// refinement and the rows. The iteration's own bookkeeping per state and step (the finiteness and
    /// containment tests, the inflation, the hull) is counted generously as 4 additions,
    /// 2 multiplications and 9 comparisons: operations on the bounds, cheaper than the
    /// interval operations whose rate they are timed at.
    pub const fn window(&self, delayed: bool) -> OpCount {
        let n = self.states as u64;
        let per_state = OpCount { add: 1 + 4, mul: 1 + 2, compare: 9, ..OpCount::ZERO };
        let step = self.field.plus(per_state.times(n));
        let end = OpCount { add: n, mul: n, compare: 4 * n, ..OpCount::ZERO };
        let flow = step.times(MAX_FIELD_CALLS as u64).plus(end);
        let flows = if delayed { 2 * MAX_PIECES as u64 } else { MAX_PIECES as u64 };
        flow.times(flows).plus(self.refine).plus(self.rows)
    }
}

/// The reachable states over a time span, enclosed ([`enclose_flow`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach<const NX: usize> {
    /// The states the span starts from.
    pub start: [Interval; NX],
    /// A box holding every state of every solution over the span.
    pub states: [Interval; NX],
    /// `F` over [`Reach::states`]: every velocity along those solutions.
    pub field: [Interval; NX],
    /// A box holding every state at the span's end (narrower than
    /// [`Reach::states`]: `x0 + h·field`).
    pub end: [Interval; NX],
}

/// A box holding `x(τ)` for every `τ ∈ [0, h]` of every solution of `ẋ = F(x)` from
/// any point of `x0`, where `field` is an interval extension of `F` (it encloses `F` over
/// any box it is given; `None` when it cannot), with `F` over it and the states at `h`.
/// `None` when no box was found.
///
/// Why it is certified: if `x0 + [0, h]·F(B) ⊆ B`, no solution can leave `B` before `h`
/// (at the first exit its velocity since `x0` would lie in `F(B)`), and then every
/// `x(τ) = x0 + ∫F` lies in `x0 + [0, h]·F(B)`, the box returned, and `x(h)` in
/// `x0 + h·F(B)`.
///
/// ```
/// use cbfgen::filter::between_samples::enclose_flow;
/// use cbfgen::interval::Interval;
///
/// // A point mass from q = 0, v = 1 under a = −2 for 0.1 s reaches q ∈ [0, 0.09],
/// // v ∈ [0.8, 1]; the box holds both, a little wider (a step of the iteration's room).
/// let a = Interval::point(-2.0);
/// let reach = enclose_flow(&[Interval::point(0.0), Interval::point(1.0)], 0.1, |x| Some([x[1], a])).unwrap();
/// let b = reach.states;
/// assert!(b[0].contains(0.0) && b[0].contains(0.09) && b[0].hi < 0.11);
/// assert!(b[1].contains(0.8) && b[1].contains(1.0) && b[1].width() < 0.25);
/// assert!(reach.end[1].contains(0.8) && reach.end[1].width() < 0.05);
/// ```
pub fn enclose_flow<const NX: usize>(
    x0: &[Interval; NX],
    h: f64,
    field: impl Fn(&[Interval; NX]) -> Option<[Interval; NX]>,
) -> Option<Reach<NX>> {
    let tau = Interval::new(0.0, h);
    let step = |b: &[Interval; NX]| -> Option<([Interval; NX], [Interval; NX])> {
        let f = field(b)?;
        let next: [Interval; NX] = core::array::from_fn(|i| x0[i] + tau * f[i]);
        next.iter().all(|v| v.is_finite()).then_some((next, f))
    };
    let mut b = step(x0)?.0.map(inflate);
    for _ in 0..MAX_PICARD {
        let (next, f) = step(&b)?;
        if next.iter().zip(&b).all(|(n, b)| b.lo <= n.lo && n.hi <= b.hi) {
            // F(b) holds F over `next` ⊆ b too.
            let end = core::array::from_fn(|i| x0[i] + Interval::point(h) * f[i]);
            return Some(Reach { start: *x0, states: next, field: f, end });
        }
        // Only where the box was too small: inflating a component already large enough
        // would widen the next step of every component that reads it, for ever.
        b = core::array::from_fn(|i| {
            if b[i].lo <= next[i].lo && next[i].hi <= b[i].hi {
                b[i]
            } else {
                inflate(Interval::hull(b[i], next[i]))
            }
        });
    }
    None
}

/// `v` widened by a tenth of its width and a little more: room for the next Picard step.
fn inflate(v: Interval) -> Interval {
    let pad = 0.1 * v.width() + 1e-12 * v.lo.abs().max(v.hi.abs()) + 1e-300;
    Interval::new(v.lo - pad, v.hi + pad)
}

/// [`enclose_flow`] over `[0, h]` in pieces: where the flow over a piece cannot be
/// enclosed (a box grows faster than the iteration can catch it: a stiff or fast flow,
/// or an enclosure of `F` much wider than `F`'s true range), the piece is halved, down to
/// `h / 2^`[`MAX_HALVINGS`]; each piece starts from the last one's end. Returns the hull
/// of the pieces: every state over `[0, h]` (`states`), `F` over them (`field`), and the
/// states at `h` (`end`).
fn enclose_pieces<const NX: usize>(
    x0: &[Interval; NX],
    h: f64,
    field: impl Fn(&[Interval; NX]) -> Option<[Interval; NX]>,
) -> Option<Reach<NX>> {
    // In units of the shortest piece, so that the pieces cover [0, h] exactly; each
    // piece's length is rounded up (covering a little more is sound).
    const UNITS: u32 = 1 << MAX_HALVINGS;
    let unit = h / f64::from(UNITS);
    let (mut done, mut length, mut start) = (0, UNITS, *x0);
    let mut hull: Option<Reach<NX>> = None;
    while done < UNITS {
        let piece = length.min(UNITS - done);
        match enclose_flow(&start, (unit * f64::from(piece)).next_up(), &field) {
            Some(r) => {
                hull = Some(match hull {
                    None => r,
                    Some(a) => Reach {
                        start: a.start,
                        states: core::array::from_fn(|i| Interval::hull(a.states[i], r.states[i])),
                        field: core::array::from_fn(|i| Interval::hull(a.field[i], r.field[i])),
                        end: r.end,
                    },
                });
                start = r.end;
                done += piece;
            }
            None if piece > 1 => length = piece / 2,
            None => return None,
        }
    }
    hull
}

/// The states the plant reaches while `window`'s input is held, from `x`, the times they
/// are reached at, and the dynamics over them: `field(b, u)` encloses the dynamics over
/// the box `b` under the held inputs `u` (`None` when it cannot). With an input delay,
/// the states of the second period, reached from every state the first can end in.
///
/// # Errors
/// [`NotEnclosed::Flow`] when the flow could not be enclosed.
pub fn enclose_window<const NX: usize, const NU: usize>(
    window: &Window<NU>,
    x: &[f64; NX],
    field: impl Fn(&[Interval; NX], &[Interval; NU]) -> Option<[Interval; NX]>,
) -> Result<(Reach<NX>, Interval), NotEnclosed> {
    let point = x.map(Interval::point);
    let u = window.u.map(Interval::point);
    let (start, periods) = match window.before {
        None => (point, 1.0),
        Some(before) => {
            (enclose_pieces(&point, window.period, |b| field(b, &before)).ok_or(NotEnclosed::Flow)?.end, 2.0)
        }
    };
    let reach = enclose_pieces(&start, window.period, |b| field(b, &u)).ok_or(NotEnclosed::Flow)?;
    Ok((reach, Interval::point(window.t) + Interval::new(0.0, periods * window.period)))
}

/// The dynamics' interval extension over a box `b`, inputs `u`: `f(b) + g(b) u` from a
/// generated system's `drift` and `input_matrix` (its first two `INTERVAL_KERNELS`).
fn field<const NX: usize, const NU: usize>(
    kernels: &[IntervalKernel],
    b: &[Interval; NX],
    u: &[Interval; NU],
) -> Option<[Interval; NX]> {
    let (drift, input) = (kernels.first()?, kernels.get(1)?);
    let (drift_call, input_call) = (drift.call?, input.call?);
    let mut f = [Interval::point(0.0); NX];
    drift_call(b, &mut f);
    let mut g = [Interval::point(0.0); MAX_FLAT];
    let g = g.get_mut(..NX * NU)?;
    input_call(b, g);
    for (i, fi) in f.iter_mut().enumerate() {
        for j in 0..NU {
            *fi = *fi + g[i * NU + j] * u[j];
        }
    }
    Some(f)
}

/// Enclose the rows of a generated system flagged in `wanted` over `window`, from state
/// `x` and `params`, into `out` (rows not wanted are left as they are): what generated
/// barrier sets' [`BarrierSet::enclose`](crate::system::BarrierSet::enclose) calls.
/// Allocation-free.
///
/// # Errors
/// [`NotEnclosed::Flow`] when the reachable states could not be enclosed;
/// [`NotEnclosed::NoIntervalForm`] for the first wanted row whose member has none;
/// [`NotEnclosed::LengthMismatch`] for `wanted` or `out` of another length than `layout`.
pub fn enclose_generated<G: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize>(
    layout: &[RowLayout],
    window: &Window<NU>,
    x: &[f64; NX],
    params: &G::Params,
    wanted: &[bool],
    out: &mut [RowEnclosure<NU>],
) -> Result<(), NotEnclosed> {
    if wanted.len() != layout.len() || out.len() != layout.len() {
        return Err(NotEnclosed::LengthMismatch);
    }
    let kernels = G::INTERVAL_KERNELS;
    if kernels.len() < 2 || kernels[0].name != "drift" || kernels[1].name != "input_matrix" {
        return Err(NotEnclosed::NoIntervalForm { row: wanted.iter().position(|&w| w).unwrap_or(0) });
    }
    let (reach, times) = enclose_window(window, x, |b, u| field(kernels, b, u))?;
    enclose_rows_generated::<G, NX, NU>(layout, &reach.states, times, params, wanted, out)
}

/// Where the member of the row at `l` sits in a generated module's `INTERVAL_KERNELS`:
/// after the dynamics (`drift`, `input_matrix`), every family's members in order.
fn member_kernel(families: &[crate::system::FamilyInfo], l: &RowLayout) -> usize {
    2 + families[..l.family].iter().map(|f| f.members.len().max(1)).sum::<usize>() + l.member
}

/// Enclose the rows of a generated system flagged in `wanted` over the box `states` and
/// the times `times` (given, not reached by the system's own flow), into `out`: what
/// generated barrier sets' [`BarrierSet::enclose_over`](crate::system::BarrierSet::enclose_over)
/// calls, for a wrapper that encloses the flow itself (the
/// [joint-torque map](crate::torque::JointTorque)). Allocation-free.
///
/// # Errors
/// As [`enclose_generated`], and [`NotEnclosed::LengthMismatch`] for `states` of another
/// length than the state.
pub fn enclose_rows_generated<G: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize>(
    layout: &[RowLayout],
    states: &[Interval],
    times: Interval,
    params: &G::Params,
    wanted: &[bool],
    out: &mut [RowEnclosure<NU>],
) -> Result<(), NotEnclosed> {
    use crate::dynamic::FlatParams;
    if wanted.len() != layout.len() || out.len() != layout.len() || states.len() != NX {
        return Err(NotEnclosed::LengthMismatch);
    }
    let kernels = G::INTERVAL_KERNELS;
    let families = G::FAMILIES;
    let mut input = [Interval::point(0.0); MAX_FLAT];
    let mut output = [Interval::point(0.0); MAX_FLAT];
    let mut values = [0.0; MAX_FLAT];
    let mut i = 0;
    while i < layout.len() {
        let l = layout[i];
        let info = &families[l.family];
        let n = info.row_names.len();
        if !wanted[i..i + n].iter().any(|&w| w) {
            i += n;
            continue;
        }
        let no_form = NotEnclosed::NoIntervalForm { row: i };
        let kernel = kernels.get(member_kernel(families, &l)).ok_or(no_form)?;
        let call = kernel.call.ok_or(no_form)?;
        let (inputs, outputs) = (kernel.input_len(), kernel.output_len());
        if inputs > MAX_FLAT || outputs > MAX_FLAT || inputs < NX {
            return Err(no_form);
        }
        input[..NX].copy_from_slice(states);
        let mut at = NX;
        if kernel.inputs.get(1).is_some_and(|a| a.0 == "t") {
            input[at] = times;
            at += 1;
        }
        let width = inputs - at;
        if width > 0 {
            let store = params.store(l.family, l.member).ok_or(no_form)?;
            if store.width() != width || !matches!(store.get(l.instance, &mut values[..width]), Ok(true)) {
                return Err(no_form);
            }
            for (slot, &v) in input[at..inputs].iter_mut().zip(&values[..width]) {
                *slot = Interval::point(v);
            }
        }
        call(&input[..inputs], &mut output[..outputs]);
        let degree = info.relative_degree;
        let ncols = kernel.columns.len();
        let lie_len = n * (degree + 1);
        if outputs != lie_len + n * ncols {
            return Err(no_form);
        }
        for r in 0..n {
            let e = &mut out[i + r];
            *e = RowEnclosure::ZERO;
            e.lie[..=degree].copy_from_slice(&output[r * (degree + 1)..(r + 1) * (degree + 1)]);
            for (c, &col) in kernel.columns.iter().enumerate() {
                e.lg[col] = output[lie_len + r * ncols + c];
            }
        }
        i += n;
    }
    Ok(())
}

/// What one [`enclose_generated`] of every row performs at most for a generated system
/// with rows laid out as `layout`: its `drift` and `input_matrix` and each instance's
/// member kernel, as their `KERNELS` lines state them. `None` where one states no count.
pub fn enclosure_ops_generated<G: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize>(
    layout: &[RowLayout],
) -> Option<EnclosureOps> {
    let stated = |name: &str| G::KERNELS.iter().find(|k| k.name == name).and_then(|k| k.ops);
    let product = OpCount { add: (NX * NU) as u64, mul: (NX * NU) as u64, ..OpCount::ZERO };
    let field = stated("drift")? + stated("input_matrix")? + product;
    let (kernels, families) = (G::INTERVAL_KERNELS, G::FAMILIES);
    let mut rows = OpCount::ZERO;
    let mut i = 0;
    while i < layout.len() {
        let l = layout[i];
        rows = rows + stated(kernels.get(member_kernel(families, &l))?.name)?;
        i += families[l.family].row_names.len().max(1);
    }
    Some(EnclosureOps { field, states: NX, refine: OpCount::ZERO, rows })
}

/// The [`BarrierSet`](crate::system::BarrierSet) methods that enclose a generated
/// system's rows ([`enclose`](crate::system::BarrierSet::enclose),
/// [`enclose_over`](crate::system::BarrierSet::enclose_over) and what they cost,
/// [`enclosure_ops`](crate::system::BarrierSet::enclosure_ops)), for the generated barrier
/// set's `impl` block: `$system` is its [`GeneratedSystem`]. One line in each generated
/// module instead of the methods written out.
#[macro_export]
macro_rules! generated_enclosure {
    ($system:ty) => {
        fn enclose(
            &self,
            window: &$crate::filter::between_samples::Window<NU>,
            x: &[f64; NX],
            params: &Params,
            wanted: &[bool],
            out: &mut [$crate::filter::between_samples::RowEnclosure<NU>],
        ) -> Result<(), $crate::filter::between_samples::NotEnclosed> {
            $crate::filter::between_samples::enclose_generated::<$system, NX, NU>(
                &self.layout,
                window,
                x,
                params,
                wanted,
                out,
            )
        }

        fn enclose_over(
            &self,
            states: &[$crate::interval::Interval],
            times: $crate::interval::Interval,
            params: &Params,
            wanted: &[bool],
            out: &mut [$crate::filter::between_samples::RowEnclosure<NU>],
        ) -> Result<(), $crate::filter::between_samples::NotEnclosed> {
            $crate::filter::between_samples::enclose_rows_generated::<$system, NX, NU>(
                &self.layout,
                states,
                times,
                params,
                wanted,
                out,
            )
        }

        fn enclosure_ops(&self) -> Option<$crate::filter::between_samples::EnclosureOps> {
            $crate::filter::between_samples::enclosure_ops_generated::<$system, NX, NU>(&self.layout)
        }
    };
}
