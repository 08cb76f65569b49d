//! Joint torques as the filter's inputs, for rows written in joint accelerations.
//!
//! A spec whose inputs are a robot's joint accelerations (`ẋ = [q̇, 0] + [0; I] q̈`, the
//! arm's form) gives rows `L_f^r h + Σ k_i L_f^i h + a · q̈ ≥ 0` with `a = L_g L_f^{r−1} h`.
//! A torque-controlled robot's accelerations are `q̈ = M(q)⁻¹ (τ − b(q, q̇))`, with `M`
//! the joint-space mass matrix and `b` the Coriolis, centrifugal and gravity forces, so the
//! same row in torques is
//!
//! ```text
//! (L_f^r h − ã · b) + Σ k_i L_f^i h + ã · τ ≥ 0,      ã = M⁻¹ a   (M is symmetric)
//! ```
//!
//! which is again an ECBF row: `L_f^r h` along the torque-free drift and `L_g L_f^{r−1} h`
//! in torques. [`JointTorque`] wraps the acceleration rows' [`BarrierSet`] and a function
//! giving `M` and `b` at a state (a spec's generated `dynamics` output, built from the
//! URDF's inertials by `symbolic/dynamics.py`), factors `M` once per cycle (Cholesky, on
//! the stack, no allocation), forms `M⁻¹` from the factor and maps every evaluated row
//! with one `N × N` product. Rows of a relative degree below
//! the inputs' do not see them and are copied as they are; culled rows stay culled.
//!
//! The filter's inputs are then torques: give it torque limits, torque weights and a
//! nominal torque. A row's input columns become every joint (`M⁻¹` couples them).
//!
//! Given the same dynamics on intervals and dual intervals
//! ([`JointTorque::with_interval_dynamics`]; a generated `dynamics` is generic, so
//! `gen::dynamics::<Interval>` and `gen::dynamics::<Dual<Interval>>`), the wrapper also
//! encloses its rows between the samples for the sampled-data certificate
//! ([`crate::filter::between_samples`]): the flow of `M(q) q̈ + b(q, q̇) = τ` under the
//! held torque, with `q̈` enclosed by [`solve_linear`] over each box of states and
//! tightened by a first-order form in time.
//!
//! Given the dynamics' operation count ([`JointTorque::with_dynamics_ops`]; a generated
//! system's `gen::dynamics_ops()`), the wrapper states its evaluation's count too (the
//! inner rows', the dynamics', and [`torque_map_ops`]), so that the filter's worst case
//! per update has a time; with the interval forms too, its enclosures' count
//! ([`BarrierSet::enclosure_ops`]), so that a certified update has one.
//!
//! The cart of the [filter's example](crate::filter) again, now of mass 2 kg pushed by a
//! force `F` against a drag of 3 N (`b = 3`): its acceleration is `(F − 3) / 2`, so the
//! wall row `−20 v + 100 h − a ≥ 0` becomes `F ≤ 2 (100 h − 20 v) + 3`, which at
//! `p = 0.9`, `v = 0.5` allows at most `F = 3` N.
//!
//! ```
//! use cbfgen::filter::{EcbfFilter, FilterSettings, InputSource};
//! use cbfgen::system::{BarrierSet, ClassK, FamilyInfo, FamilyKind, FamilyParams, InstanceKind, Poles, Row, RowLayout};
//! use cbfgen::torque::JointTorque;
//!
//! struct Wall([Row<1>; 1]);
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
//! impl BarrierSet<1> for Wall {
//!     type State = [f64; 2];
//!     type Params = f64;
//!     fn families(&self) -> &[FamilyInfo] { &FAMILIES }
//!     fn layout(&self) -> &[RowLayout] { &LAYOUT }
//!     fn rows(&self) -> &[Row<1>] { &self.0 }
//!     fn evaluate(&mut self, _t: f64, x: &[f64; 2], wall: &f64) -> Result<(), cbfgen::CbfError> {
//!         self.0[0].store(&[wall - x[0], -x[1], 0.0], &[-1.0], &[0]); // in accelerations
//!         Ok(())
//!     }
//! }
//! // M = 2 kg, b = 3 N, whatever the state.
//! fn cart(_x: &[f64; 2]) -> ([[f64; 1]; 1], [f64; 1]) {
//!     ([[2.0]], [3.0])
//! }
//!
//! let settings = FilterSettings::defaults(&FAMILIES, [-50.0], [50.0]); // force limits [N]
//! let mut filter = EcbfFilter::new(JointTorque::new(Wall([Row::ZERO]), cart), settings)?;
//! let out = filter.update(&[0.9, 0.5], &[10.0], &1.0)?;
//! assert_eq!(out.source, InputSource::Qp);
//! assert!((out.u[0] - 3.0).abs() < 1e-6); // F ≤ 2 (100 · 0.1 − 20 · 0.5) + 3
//! let row = filter.rows()[0];
//! assert!((row.lg[0] + 0.5).abs() < 1e-15 && (row.lie[2] - 1.5).abs() < 1e-15); // −1/M; 0 − (−1/M) b
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use crate::dual::{dual_ops, Dual};
use crate::error::CbfError;
use crate::filter::between_samples::{enclose_window, EnclosureOps, NotEnclosed, RowEnclosure, Window};
use crate::interval::{solve_linear, solve_linear_ops, Interval};
use crate::ops::OpCount;
use crate::scalar::Scalar;
use crate::system::{BarrierSet, FamilyInfo, Row, RowLayout};

/// The most joints a [`JointTorque`] maps.
pub const MAX_JOINTS: usize = 64;

/// `0, 1, …, MAX_JOINTS − 1`: every row's input columns once mapped to torques.
static ALL_COLUMNS: [usize; MAX_JOINTS] = {
    let mut columns = [0; MAX_JOINTS];
    let mut i = 0;
    while i < MAX_JOINTS {
        columns[i] = i;
        i += 1;
    }
    columns
};

/// `M(q)` (row by row) and `b(q, q̇)` at a state.
pub type Dynamics<const NX: usize, const NU: usize> = fn(&[f64; NX]) -> ([[f64; NU]; NU], [f64; NU]);

/// [`Dynamics`] over a box of states: enclosures of every `M(q)` and `b(q, q̇)` in it. A
/// generated `dynamics` is generic: `gen::dynamics::<Interval>` is this form of the same
/// function.
pub type IntervalDynamics<const NX: usize, const NU: usize> =
    fn(&[Interval; NX]) -> ([[Interval; NU]; NU], [Interval; NU]);

/// [`Dynamics`] on dual intervals: over a box of states whose rates are seeded, `M` and
/// `b` with enclosures of their rates of change (`gen::dynamics::<Dual<Interval>>`).
pub type RateDynamics<const NX: usize, const NU: usize> =
    fn(&[Dual<Interval>; NX]) -> ([[Dual<Interval>; NU]; NU], [Dual<Interval>; NU]);

/// The dynamics' two interval forms.
#[derive(Debug, Clone, Copy)]
struct IntervalForms<const NX: usize, const NU: usize> {
    dynamics: IntervalDynamics<NX, NU>,
    rates: RateDynamics<NX, NU>,
}

/// Passes of the first-order form in time over one window. A second pass, on the
/// narrower box, certified a few percent more of the Panda's updates at 1.5 times the
/// cost.
const REFINEMENTS: usize = 1;

/// The first-order form in time: from `q̈` at the window's start (`at_start`) and the
/// jerk `d q̈/dt = M⁻¹ (−ḃ − Ṁ q̈)` over the reached box `states` (the dynamics' rates,
/// seeded with the box's velocities and accelerations `qdd`), `q̈` over the period
/// `h` lies in `q̈(start) + [0, h]·jerk`, and the states in
/// `q̇ ∈ q̇(start) + [0, h]·q̈`, `q ∈ q(start) + [0, h]·q̇(start) + [0, h²/2]·q̈`; each
/// intersected with what it tightens (both hold). `None` when the jerk cannot be
/// enclosed.
fn tighten<const NX: usize, const NU: usize>(
    rates: RateDynamics<NX, NU>,
    start: &[Interval; NX],
    at_start: &[Interval; NU],
    states: &[Interval; NX],
    qdd: &[Interval; NU],
    h: f64,
) -> Option<([Interval; NX], [Interval; NU])> {
    let seeded: [Dual<Interval>; NX] =
        core::array::from_fn(|i| Dual { v: states[i], d: if i < NU { states[NU + i] } else { qdd[i - NU] } });
    let (mass, bias) = rates(&seeded);
    let values = mass.map(|row| row.map(|m| m.v));
    let rhs: [Interval; NU] = core::array::from_fn(|i| (0..NU).fold(-bias[i].d, |s, j| s - mass[i][j].d * qdd[j]));
    let jerk = solve_linear(&values, &rhs)?;
    let span = Interval::new(0.0, h);
    let half_square = Interval::point(0.5) * span.sqr();
    let tight: [Interval; NU] = core::array::from_fn(|i| (at_start[i] + span * jerk[i]).meet(qdd[i]));
    let next: [Interval; NX] = core::array::from_fn(|i| {
        let by_form = if i < NU {
            start[i] + span * start[NU + i] + half_square * tight[i]
        } else {
            start[i] + span * tight[i - NU]
        };
        by_form.meet(states[i])
    });
    Some((next, tight))
}

/// The rows of `B` (written in joint accelerations) mapped to joint torques each cycle:
/// see the [module docs](self).
#[derive(Debug, Clone)]
pub struct JointTorque<B, const NX: usize, const NU: usize> {
    inner: B,
    dynamics: Dynamics<NX, NU>,
    interval_forms: Option<IntervalForms<NX, NU>>,
    dynamics_ops: Option<OpCount>,
    layout: Vec<RowLayout>,
    rows: Vec<Row<NU>>,
    mass: [[f64; NU]; NU],
    bias: [f64; NU],
}

impl<B: BarrierSet<NU, State = [f64; NX]>, const NX: usize, const NU: usize> JointTorque<B, NX, NU> {
    /// Wrap `inner` (its inputs joint accelerations, one per joint) with `dynamics`, giving
    /// `M` and `b` at a state.
    pub fn new(inner: B, dynamics: Dynamics<NX, NU>) -> Self {
        const { assert!(NU <= MAX_JOINTS, "JointTorque maps at most MAX_JOINTS joints") };
        let layout = inner.layout().iter().map(|l| RowLayout { columns: &ALL_COLUMNS[..NU], ..*l }).collect();
        let rows = inner.rows().to_vec();
        Self {
            inner,
            dynamics,
            interval_forms: None,
            dynamics_ops: None,
            layout,
            rows,
            mass: [[0.0; NU]; NU],
            bias: [0.0; NU],
        }
    }

    /// The same dynamics on intervals and on dual intervals (for a generated system,
    /// `gen::dynamics::<Interval>` and `gen::dynamics::<Dual<Interval>>` beside
    /// `gen::dynamics`): what lets the sampled-data certificate
    /// ([`crate::filter::between_samples`]) enclose the rows in torques. Without them the
    /// certificate reports [`Why::NoIntervalForm`](crate::filter::between_samples::Why).
    ///
    /// The certificate then takes the plant to be `ẋ = [q̇, M(q)⁻¹ (τ − b(q, q̇))]` on
    /// `x = [q, q̇]` (so `NX = 2 NU`, as [`step_rigid_body`] integrates it) under the held
    /// torque, and needs the inner rows' own interval form
    /// ([`BarrierSet::enclose_over`]). The dual form gives `d/dt` of `M` and `b` along
    /// the flow, which tightens `q̈`'s enclosure over the period to a first-order form in
    /// time (see [`JointTorque::enclose`](BarrierSet::enclose)).
    pub fn with_interval_dynamics(mut self, dynamics: IntervalDynamics<NX, NU>, rates: RateDynamics<NX, NU>) -> Self {
        const { assert!(NX == 2 * NU, "the certificate's plant is x = [q, q̇]") };
        self.interval_forms = Some(IntervalForms { dynamics, rates });
        self
    }

    /// What one call of the dynamics performs (for a generated system, `gen::dynamics_ops()`):
    /// with it, and the inner rows' own count, [`evaluation_ops`](BarrierSet::evaluation_ops)
    /// states each cycle's work, so that the filter's
    /// [`worst_case`](crate::filter::EcbfFilter::worst_case) has a time.
    pub fn with_dynamics_ops(mut self, ops: OpCount) -> Self {
        self.dynamics_ops = Some(ops);
        self
    }

    /// The acceleration rows, as last evaluated.
    pub fn inner(&self) -> &B {
        &self.inner
    }

    /// `M` and `b` at the last evaluated state.
    pub fn dynamics(&self) -> (&[[f64; NU]; NU], &[f64; NU]) {
        (&self.mass, &self.bias)
    }
}

/// `Σ_k a_k b_k` from `−0.0`, as `f64`'s `sum` adds (one multiplication and one addition
/// per term).
fn dot<S: Scalar>(terms: impl Iterator<Item = (S, S)>) -> S {
    terms.fold(S::from(-0.0), |sum, (a, b)| sum + a * b)
}

/// `M = L Lᵀ` in place (lower triangle), or the first pivot that is not positive.
fn cholesky<S: Scalar + PartialOrd, const N: usize>(m: &mut [[S; N]; N]) -> Result<(), S> {
    for j in 0..N {
        let pivot = m[j][j] - dot((0..j).map(|k| (m[j][k], m[j][k])));
        // Positive and finite; NaN fails both.
        if !(pivot > S::from(0.0) && pivot < S::from(f64::INFINITY)) {
            return Err(pivot);
        }
        let d = pivot.sqrt();
        m[j][j] = d;
        for i in j + 1..N {
            m[i][j] = (m[i][j] - dot((0..j).map(|k| (m[i][k], m[j][k])))) / d;
        }
    }
    Ok(())
}

/// `x = (L Lᵀ)⁻¹ v` with `L` from [`cholesky`].
fn solve<S: Scalar, const N: usize>(l: &[[S; N]; N], v: &[S; N]) -> [S; N] {
    let mut y = *v;
    for i in 0..N {
        y[i] = (y[i] - dot((0..i).map(|k| (l[i][k], y[k])))) / l[i][i];
    }
    for i in (0..N).rev() {
        y[i] = (y[i] - dot((i + 1..N).map(|k| (l[k][i], y[k])))) / l[i][i];
    }
    y
}

/// `M⁻¹` from `M`'s Cholesky factor (N solves), or `M`'s first pivot that is not positive.
/// Once per cycle, then one dense N × N product per row ([`to_torques`]): no division and
/// no dependent chain per row, where two triangular solves per row had both.
fn inverse_mass<S: Scalar + PartialOrd, const N: usize>(mass: &[[S; N]; N]) -> Result<[[S; N]; N], S> {
    let mut factor = *mass;
    cholesky(&mut factor)?;
    let mut inverse = [[S::from(0.0); N]; N];
    for j in 0..N {
        let unit: [S; N] = core::array::from_fn(|i| S::from(if i == j { 1.0 } else { 0.0 }));
        for (row, value) in inverse.iter_mut().zip(solve(&factor, &unit)) {
            row[j] = value;
        }
    }
    Ok(inverse)
}

/// A row in accelerations (`lg`, the input part) in torques: `lg M⁻¹` and the drift's
/// change `−lg M⁻¹ b`.
fn to_torques<S: Scalar, const N: usize>(inverse: &[[S; N]; N], bias: &[S; N], lg: &[S; N]) -> ([S; N], S) {
    let mapped: [S; N] = core::array::from_fn(|i| dot(inverse[i].iter().copied().zip(lg.iter().copied())));
    (mapped, -dot(mapped.iter().copied().zip(bias.iter().copied())))
}

/// What [`JointTorque`] performs each cycle besides the inner rows and the dynamics, with
/// `n` joints and `rows` rows: `M`'s Cholesky factor, its inverse (n solves), and each row
/// mapped (a product with `M⁻¹`; a culled or inactive row is not). Checked against the functions
/// run on counting numbers.
pub const fn torque_map_ops(n: usize, rows: usize) -> OpCount {
    let (n, rows) = (n as u64, rows as u64);
    // Σ_j j over the n columns, and Σ_j (n − 1 − j) j over the entries below the diagonal.
    let (pairs, below) = (n * n.saturating_sub(1) / 2, n * n.saturating_sub(1) * n.saturating_sub(2) / 6);
    // Cholesky: per column j, its pivot (j + 1 adds, j muls, 1 sqrt) and each entry below
    // it (j + 1 adds, j muls, 1 div).
    let cholesky = OpCount { add: pairs + n + below + pairs, mul: pairs + below, sqrt: n, div: pairs, ..OpCount::ZERO };
    // One solve: each pass Σ_i (i + 1 adds, i muls, 1 div).
    let solve = OpCount { add: 2 * (pairs + n), mul: 2 * pairs, div: 2 * n, ..OpCount::ZERO };
    // One row: n dot products of n terms, one of n terms for the bias, its negation, and
    // the row's drift entry taking the change.
    let row = OpCount { add: n * n + n + 1, mul: n * n + n, neg: 1, ..OpCount::ZERO };
    cholesky.plus(solve.times(n)).plus(row.times(rows))
}

impl<B: BarrierSet<NU, State = [f64; NX]>, const NX: usize, const NU: usize> BarrierSet<NU> for JointTorque<B, NX, NU> {
    type State = [f64; NX];
    type Params = B::Params;

    fn families(&self) -> &[FamilyInfo] {
        self.inner.families()
    }

    fn layout(&self) -> &[RowLayout] {
        &self.layout
    }

    fn rows(&self) -> &[Row<NU>] {
        &self.rows
    }

    /// # Errors
    /// As the inner rows' evaluation; a non-finite `b`; an `M` that is not positive
    /// definite (or not finite): [`CbfError::NotPositive`] with the failing Cholesky pivot.
    /// The rows are then left as they were.
    fn evaluate(&mut self, t: f64, x: &[f64; NX], params: &B::Params) -> Result<(), CbfError> {
        let (mass, bias) = (self.dynamics)(x);
        if let Some(&b) = bias.iter().find(|b| !b.is_finite()) {
            return Err(CbfError::NonFinite { what: "bias force b(q, q̇)", value: b });
        }
        let inverse =
            inverse_mass(&mass).map_err(|pivot| CbfError::NotPositive { what: "mass matrix pivot", value: pivot })?;
        self.inner.evaluate(t, x, params)?;
        let families = self.inner.families();
        for ((out, row), at) in self.rows.iter_mut().zip(self.inner.rows()).zip(self.inner.layout()) {
            *out = *row;
            if !row.active || row.culled {
                continue;
            }
            let degree = families[at.family].relative_degree;
            let (mapped, change) = to_torques(&inverse, &bias, &row.lg);
            out.lie[degree] += change;
            out.lg = mapped;
        }
        self.mass = mass;
        self.bias = bias;
        Ok(())
    }

    /// The inner rows' count, the dynamics' ([`with_dynamics_ops`](Self::with_dynamics_ops))
    /// and the map to torques ([`torque_map_ops`], every row mapped); `None` without
    /// either of the first two.
    fn evaluation_ops(&self) -> Option<OpCount> {
        Some(self.inner.evaluation_ops()? + self.dynamics_ops? + torque_map_ops(NU, self.rows.len()))
    }

    fn cull_above(&mut self, thresholds: &[f64]) {
        self.inner.cull_above(thresholds);
    }

    /// The flow's field is the interval dynamics ([`with_dynamics_ops`](Self::with_dynamics_ops),
    /// the same walk on intervals) and a [`solve_linear`]; the refinement one more
    /// acceleration at the window's start and the first-order passes (the
    /// dynamics on dual intervals, [`dual_ops`], and a second solve); the rows the inner
    /// rows' kernels and each row's `a · q̈`. `None` without the interval forms, the
    /// dynamics' count or the inner rows' count.
    fn enclosure_ops(&self) -> Option<EnclosureOps> {
        self.interval_forms?;
        let (dynamics, inner) = (self.dynamics_ops?, self.inner.enclosure_ops()?);
        let (n, solve) = (NU as u64, solve_linear_ops(NU));
        // q̈ = M⁻¹ (τ − b) over a box.
        let acceleration = dynamics.plus(OpCount { add: n, ..OpCount::ZERO }).plus(solve);
        // One pass: the right side −ḃ − Ṁ q̈, the jerk's solve, the span's square, then
        // q̈ and the states by the form, each met with what it tightens.
        let pass = dual_ops(dynamics)
            .plus(OpCount { add: n * n, neg: n, mul: n * n, ..OpCount::ZERO })
            .plus(solve)
            .plus(OpCount { add: 4 * n, mul: 2 + 4 * n, compare: 3 * n, ..OpCount::ZERO });
        let fold = OpCount { add: n, mul: n, ..OpCount::ZERO }.times(self.rows.len() as u64);
        Some(EnclosureOps {
            field: acceleration,
            states: NX,
            refine: acceleration.plus(pass.times(REFINEMENTS as u64)),
            rows: inner.rows.plus(fold),
        })
    }

    /// The flow under the held torque is enclosed with the interval dynamics
    /// ([`JointTorque::with_interval_dynamics`]): `q̈ ∈ M(B)⁻¹ (τ − b(B))` over a box `B`
    /// by [`solve_linear`]. That enclosure is far wider than `q̈`'s true range (on the
    /// Panda, 16.7 rad/s² against 0.018 over one period's box: the interval rigid-body
    /// algorithms lose every correlation), so it is then tightened by a first-order form
    /// in time: `q̈` over the period lies in `q̈(start) + [0, Δt]·jerk`, the jerk enclosed
    /// over the box from the dynamics' rates ([`Dual`] intervals), and the box shrinks
    /// with it. The inner rows are enclosed over the reached box in
    /// accelerations, and each row's `a · q̈` over the box is folded into its
    /// `L_f^r h` with `L_g L_f^{r−1} h = 0`: the torque is fixed over the window, so `ψ`
    /// is the same, and enclosing `a · M⁻¹ (τ − b)` at once keeps the cancellation between
    /// the torque and the bias that enclosing `M⁻¹ a` and `M⁻¹ a · b` apart would lose.
    fn enclose(
        &self,
        window: &Window<NU>,
        x: &[f64; NX],
        params: &B::Params,
        wanted: &[bool],
        out: &mut [RowEnclosure<NU>],
    ) -> Result<(), NotEnclosed> {
        let Some(IntervalForms { dynamics, rates }) = self.interval_forms else {
            return Err(NotEnclosed::NoIntervalForm { row: wanted.iter().position(|&w| w).unwrap_or(0) });
        };
        let acceleration = |b: &[Interval; NX], tau: &[Interval; NU]| {
            let (mass, bias) = dynamics(b);
            solve_linear(&mass, &core::array::from_fn(|i| tau[i] - bias[i]))
        };
        let field = |b: &[Interval; NX], tau: &[Interval; NU]| {
            let qdd = acceleration(b, tau)?;
            Some(core::array::from_fn(|i| if i < NU { b[NU + i] } else { qdd[i - NU] }))
        };
        let (reach, times) = enclose_window(window, x, field)?;
        // The enclosure's field holds q̈ over the reached states already; tighten both
        // with the first-order form in time.
        let mut states = reach.states;
        let mut qdd: [Interval; NU] = core::array::from_fn(|i| reach.field[NU + i]);
        let tau = window.u.map(Interval::point);
        if let Some(at_start) = acceleration(&reach.start, &tau) {
            for _ in 0..REFINEMENTS {
                match tighten(rates, &reach.start, &at_start, &states, &qdd, window.period) {
                    Some((s, q)) => (states, qdd) = (s, q),
                    None => break,
                }
            }
        }
        self.inner.enclose_over(&states, times, params, wanted, out)?;
        let families = self.inner.families();
        for ((e, &w), l) in out.iter_mut().zip(wanted).zip(self.inner.layout()) {
            if w {
                let degree = families[l.family].relative_degree;
                e.lie[degree] = e.lg.iter().zip(&qdd).fold(e.lie[degree], |s, (a, q)| s + *a * *q);
                e.lg = [Interval::point(0.0); NU];
            }
        }
        Ok(())
    }
}

/// `q̈ = M(q)⁻¹ (τ − b(q, q̇))` at `x = [q, q̇]` (`NX = 2 NU`), by LU with partial
/// pivoting: a plant's accelerations, independent of [`JointTorque`]'s Cholesky.
///
/// # Errors
/// A singular or non-finite mass matrix.
pub fn rigid_body_acceleration<const NX: usize, const NU: usize>(
    dynamics: Dynamics<NX, NU>,
    x: &[f64; NX],
    tau: &[f64; NU],
) -> Result<[f64; NU], CbfError> {
    const { assert!(NX == 2 * NU, "the state is [q, q̇]") };
    let (mut m, b) = dynamics(x);
    let mut v: [f64; NU] = std::array::from_fn(|i| tau[i] - b[i]);
    // Gaussian elimination with partial pivoting (LU), then back substitution.
    for col in 0..NU {
        let pivot = (col..NU).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs())).unwrap_or(col);
        let size = m[pivot][col].abs();
        // NaN fails `is_finite`.
        if !size.is_finite() || size == 0.0 {
            return Err(CbfError::NotPositive { what: "mass matrix pivot", value: size });
        }
        m.swap(col, pivot);
        v.swap(col, pivot);
        let (above, below) = m.split_at_mut(col + 1);
        let top = &above[col];
        for (offset, row) in below.iter_mut().enumerate() {
            let factor = row[col] / top[col];
            for (entry, &t) in row[col..].iter_mut().zip(&top[col..]) {
                *entry -= factor * t;
            }
            v[col + 1 + offset] -= factor * v[col];
        }
    }
    for row in (0..NU).rev() {
        v[row] = (v[row] - (row + 1..NU).map(|k| m[row][k] * v[k]).sum::<f64>()) / m[row][row];
    }
    match v.iter().find(|a| !a.is_finite()) {
        Some(&a) => Err(CbfError::NonFinite { what: "joint acceleration", value: a }),
        None => Ok(v),
    }
}

/// A rigid-body plant over `dt` under a held torque: classic RK4 on `x = [q, q̇]` with
/// [`rigid_body_acceleration`]. For simulations and tests of a torque-controlled loop,
/// not for the control path.
///
/// # Errors
/// As [`rigid_body_acceleration`] at any of the four stages.
pub fn step_rigid_body<const NX: usize, const NU: usize>(
    dynamics: Dynamics<NX, NU>,
    x: &[f64; NX],
    tau: &[f64; NU],
    dt: f64,
) -> Result<[f64; NX], CbfError> {
    let f = |x: &[f64; NX]| -> Result<[f64; NX], CbfError> {
        let qdd = rigid_body_acceleration(dynamics, x, tau)?;
        Ok(std::array::from_fn(|i| if i < NU { x[NU + i] } else { qdd[i - NU] }))
    };
    crate::system::rk4_step(f, x, dt)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factor_solves_and_refuses_what_is_not_positive_definite() {
        // A hand-checked 3×3: M = [[4, 2, 0], [2, 5, 1], [0, 1, 3]], v = M · [1, −1, 2].
        let m = [[4.0, 2.0, 0.0], [2.0, 5.0, 1.0], [0.0, 1.0, 3.0]];
        let v = [2.0, -1.0, 5.0];
        let mut l = m;
        cholesky(&mut l).unwrap();
        let x = solve(&l, &v);
        for (got, want) in x.iter().zip([1.0, -1.0, 2.0]) {
            assert!((got - want).abs() < 1e-15, "{x:?}");
        }
        assert_eq!(cholesky(&mut [[1.0, 2.0], [2.0, 1.0]]), Err(-3.0));
        assert!(cholesky(&mut [[f64::NAN]]).is_err());
        assert!(cholesky(&mut [[f64::INFINITY]]).is_err());
    }

    #[test]
    fn the_plant_step_follows_a_hand_solved_pendulum() {
        // m l² q̈ + m g l sin q = τ, small angle: q(t) = q0 cos(ω t), ω² = g / l.
        fn pendulum(x: &[f64; 2]) -> ([[f64; 1]; 1], [f64; 1]) {
            ([[2.0 * 0.5 * 0.5]], [2.0 * 9.81 * 0.5 * x[0].sin()])
        }
        let (q0, dt) = (1e-4, 1e-3);
        let mut x = [q0, 0.0];
        for _ in 0..1000 {
            x = step_rigid_body(pendulum, &x, &[0.0], dt).unwrap();
        }
        let want = q0 * (9.81f64 / 0.5).sqrt().cos();
        assert!((x[0] - want).abs() < 1e-7 * q0, "{} vs {want}", x[0]);
        assert!(rigid_body_acceleration(|_: &[f64; 2]| ([[0.0]], [0.0]), &[0.0, 0.0], &[1.0]).is_err());
    }

    #[test]
    fn the_stated_map_to_torques_is_what_its_functions_perform() {
        // M⁻¹ and the rows' map, run on numbers that count, against torque_map_ops.
        use crate::ops::Counted;
        fn counted<const N: usize>(rows: usize) -> OpCount {
            // A diagonally dominant M, so every pivot is positive.
            let mass: [[Counted; N]; N] =
                core::array::from_fn(|i| core::array::from_fn(|j| Counted(if i == j { N as f64 + 1.0 } else { 0.5 })));
            let bias: [Counted; N] = core::array::from_fn(|i| Counted(i as f64 - 1.0));
            let lg: [Counted; N] = core::array::from_fn(|i| Counted(0.25 * i as f64));
            Counted::measure(|| {
                let inverse = inverse_mass(&mass).unwrap();
                for _ in 0..rows {
                    let (_, change) = to_torques(&inverse, &bias, &lg);
                    let _ = Counted(1.0) + change; // the row's drift entry takes it
                }
            })
            .1
        }
        assert_eq!(counted::<1>(0), torque_map_ops(1, 0));
        assert_eq!(counted::<2>(3), torque_map_ops(2, 3));
        assert_eq!(counted::<3>(1), torque_map_ops(3, 1));
        assert_eq!(counted::<7>(40), torque_map_ops(7, 40));
        // By hand, n = 2 without rows: the factor (l11: 1 add, 1 sqrt; l21: 1 add, 1 div;
        // l22: 2 adds, 1 mul, 1 sqrt) and two solves of 6 adds, 2 muls and 4 divs each.
        let two = torque_map_ops(2, 0);
        assert_eq!((two.sqrt, two.div, two.mul, two.add), (2, 1 + 8, 1 + 4, 4 + 12));
    }
}
