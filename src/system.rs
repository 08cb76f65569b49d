//! The contract between a system's code and the generic runtime.
//!
//! A *system* is a control-affine model `ẋ = f(x) + g(x) u` with `NX` states and `NU`
//! inputs ([`ControlAffine`]) and a set of barrier families ([`BarrierSet`]): each family
//! is one constraint `h(x, params[, t]) ≥ 0`, differentiated to its relative degree `r`,
//! and instantiated a fixed number of times or up to a capacity filled at run time.
//! `python -m symbolic generate SPEC --out DIR` writes both implementations from a spec
//! file; the generic [`EcbfFilter`](crate::filter::EcbfFilter) needs nothing else.
//!
//! Sizes live in types (`[f64; NX]`, `[f64; NU]`, as nalgebra's `SVector` does), so a row
//! of one system cannot reach another system's filter. Families of different relative
//! degrees share one QP: a row stores `[h, L_f h, …, L_f^r h]` in a fixed array of
//! [`MAX_RELATIVE_DEGREE`]` + 1` entries and its family says how many are used.

use crate::error::{within, CbfError};

use crate::interval::Interval;
pub use crate::limits::{MAX_INSTANCES, MAX_RELATIVE_DEGREE, PARAM_LIMIT, STATE_LIMIT, TIME_LIMIT};

/// One classic RK4 step of `ẋ = f(x)` over `h` (a held input lives in `f`): the plant
/// between two samples in simulations and tests, never the control path. `f` may fail
/// (a singular mass matrix); its first error is returned.
///
/// # Errors
/// `f`'s, at any of the four stages.
pub fn rk4_step<const N: usize, E>(
    f: impl Fn(&[f64; N]) -> Result<[f64; N], E>,
    x: &[f64; N],
    h: f64,
) -> Result<[f64; N], E> {
    let add = |a: &[f64; N], k: &[f64; N], s: f64| -> [f64; N] { std::array::from_fn(|i| a[i] + s * k[i]) };
    let k1 = f(x)?;
    let k2 = f(&add(x, &k1, h / 2.0))?;
    let k3 = f(&add(x, &k2, h / 2.0))?;
    let k4 = f(&add(x, &k3, h))?;
    Ok(std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])))
}

/// One evaluated ECBF row.
///
/// The row enforces `L_f^r h + Σ_{i<r} k_i L_f^i h + L_g L_f^{r−1} h · u ≥ 0`, with the
/// gains `k_i` of its family's poles ([`Gains::from_poles`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row<const NU: usize> {
    /// `[h, L_f h, …, L_f^r h]`, then zeros: the barrier and its time derivatives along
    /// the drift (units of `h`, `h`/s, …).
    pub lie: [f64; MAX_RELATIVE_DEGREE + 1],
    /// `L_g L_f^{r−1} h`: the inputs' effect on `h⁽ʳ⁾`, dense in input order (zero outside
    /// the row's columns).
    pub lg: [f64; NU],
    /// Whether the row applies this cycle (its instance is filled, its condition holds);
    /// set by [`BarrierSet::evaluate`]. An inactive row keeps stale values.
    pub active: bool,
    /// The row was not evaluated this cycle: its family's lower bound on `h` for the
    /// instance was above the activation threshold ([`BarrierSet::cull_above`]), so it
    /// could not take part. `lie[0]` holds that bound (≤ the true `h`); the rest is zero.
    pub culled: bool,
}

impl<const NU: usize> Row<NU> {
    /// An inactive row of zeros: the value storage starts from.
    pub const ZERO: Self = Self { lie: [0.0; MAX_RELATIVE_DEGREE + 1], lg: [0.0; NU], active: false, culled: false };

    /// The barrier value `h = lie[0]`, safe when ≥ 0.
    pub fn h(&self) -> f64 {
        self.lie[0]
    }

    /// Store one kernel row: `lie` (`r + 1` entries) and `lg_lf` on `columns`, and mark the
    /// row active. Used by every barrier set, hand-written or generated.
    ///
    /// Sized by the kernel's arrays, so the copies are fixed-size moves (this runs for every
    /// row of every cycle).
    pub fn store<const L: usize, const C: usize>(&mut self, lie: &[f64; L], lg_lf: &[f64; C], columns: &[usize]) {
        const { assert!(L >= 2 && L <= MAX_RELATIVE_DEGREE + 1, "lie holds h and 1 to 4 derivatives") };
        self.lie[..L].copy_from_slice(lie);
        self.lie[L..].fill(0.0);
        self.lg = [0.0; NU];
        for (&col, &v) in columns.iter().zip(lg_lf) {
            self.lg[col] = v;
        }
        self.active = true;
        self.culled = false;
    }

    /// Store a row that was not evaluated because `bound ≤ h` is above its activation
    /// threshold: `h` reads as the bound, the derivatives as zero, and the row stays out
    /// of the QP as a far row always does.
    pub fn cull(&mut self, bound: f64) {
        self.lie = [0.0; MAX_RELATIVE_DEGREE + 1];
        self.lie[0] = bound;
        self.lg = [0.0; NU];
        self.active = true;
        self.culled = true;
    }
}

/// ECBF poles `p_1 … p_r > 0` \[1/s\] of one family: `h` decays no faster than the slowest
/// `e^{−p t}` towards the boundary. `Copy`, so settings stay plain data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Poles {
    values: [f64; MAX_RELATIVE_DEGREE],
    len: usize,
}

impl Poles {
    /// `degree` poles, all at `pole`; `degree` is clamped to `1..=MAX_RELATIVE_DEGREE`.
    pub const fn repeated(pole: f64, degree: usize) -> Self {
        let len = if degree == 0 {
            1
        } else if degree > MAX_RELATIVE_DEGREE {
            MAX_RELATIVE_DEGREE
        } else {
            degree
        };
        Self { values: [pole; MAX_RELATIVE_DEGREE], len }
    }

    /// `N` poles, in a constant: what generated `FAMILIES` tables use (`From<[f64; N]>`
    /// is the same for run-time code). `N` must be in `1..=MAX_RELATIVE_DEGREE` (checked
    /// when compiled).
    pub const fn from_array<const N: usize>(poles: [f64; N]) -> Self {
        const { assert!(N >= 1 && N <= MAX_RELATIVE_DEGREE, "1 to 4 ECBF poles") };
        let mut values = [0.0; MAX_RELATIVE_DEGREE];
        let mut i = 0;
        while i < N {
            values[i] = poles[i];
            i += 1;
        }
        Self { values, len: N }
    }

    /// These poles, one per derivative.
    ///
    /// # Errors
    /// No poles, or more than [`MAX_RELATIVE_DEGREE`].
    pub fn new(poles: &[f64]) -> Result<Self, CbfError> {
        if poles.is_empty() || poles.len() > MAX_RELATIVE_DEGREE {
            return Err(CbfError::OutOfRange {
                what: "number of ECBF poles",
                value: poles.len() as f64,
                range: "[1, 4]",
            });
        }
        let mut values = [0.0; MAX_RELATIVE_DEGREE];
        values[..poles.len()].copy_from_slice(poles);
        Ok(Self { values, len: poles.len() })
    }

    /// The poles, `p_1 … p_r`.
    pub fn as_slice(&self) -> &[f64] {
        &self.values[..self.len]
    }

    /// How many poles there are: the relative degree they are for.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always `false`: a `Poles` holds at least one pole.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl<const N: usize> From<[f64; N]> for Poles {
    /// [`Poles::from_array`].
    fn from(poles: [f64; N]) -> Self {
        Self::from_array(poles)
    }
}

/// The class-K function `α` of a family's last ECBF term.
///
/// With poles `p_1 … p_r` the row reads `ψ̇ + p_r α(ψ) ≥ 0` (inputs included in `ψ̇`),
/// where `ψ = (d/dt + p_1) ⋯ (d/dt + p_{r−1}) h` (`ψ = h` for relative degree 1). The
/// linear `α(s) = s` is the plain ECBF: `h` decays no faster than `e^{−p t}` (every
/// pole). An *extended* class-K function — odd, increasing, through 0, given by the spec
/// (`class_k=` on a family) and generated as a Rust `fn` — changes how fast the last
/// term may approach the boundary:
/// * `α(s) = s³` asks less far from the boundary (`|ψ| > 1` in `ψ`'s units) and more near
///   it: the approach is allowed late and then damped harder, never crossing.
/// * `α(s) = tanh(s)` caps the allowed approach rate at `p_r` however far away (in
///   `ψ`'s units per second), linear near the boundary.
///
/// Equality is by name: a generated function is named by the spec's expression.
#[derive(Clone, Copy)]
pub struct ClassK {
    name: &'static str,
    alpha: Option<fn(f64) -> f64>,
}

impl ClassK {
    /// `α(s) = s`: the plain ECBF with the family's poles.
    pub const LINEAR: ClassK = ClassK { name: "s", alpha: None };

    /// The extended class-K function `alpha`, named by its formula (e.g. `"s**3"`). It
    /// must be odd, strictly increasing and through 0 (the generator checks a spec's;
    /// nothing here can).
    pub const fn extended(name: &'static str, alpha: fn(f64) -> f64) -> Self {
        Self { name, alpha: Some(alpha) }
    }

    /// Its formula in `s`, as the spec wrote it (`"s"` for the linear one).
    pub const fn name(&self) -> &'static str {
        self.name
    }

    /// Whether this is the linear `α(s) = s`.
    pub const fn is_linear(&self) -> bool {
        self.alpha.is_none()
    }

    /// `α(s)`.
    pub fn eval(&self, s: f64) -> f64 {
        match self.alpha {
            Some(alpha) => alpha(s),
            None => s,
        }
    }
}

impl PartialEq for ClassK {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name && self.alpha.is_none() == other.alpha.is_none()
    }
}

impl std::fmt::Debug for ClassK {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ClassK(α(s) = {})", self.name)
    }
}

/// ECBF gains `k_0 … k_{r−1}` of `L_f^r h + Σ k_i L_f^i h ≥ 0` (with the input term), or,
/// with an extended class-K function, the pieces of `ψ̇ + p_r α(ψ) ≥ 0` ([`ClassK`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    k: [f64; MAX_RELATIVE_DEGREE],
    degree: usize,
    /// Extended class-K only: the coefficients `c_0 … c_{r−1}` (`c_{r−1} = 1`) of
    /// `ψ = Σ c_i L_f^i h`, the last pole `p_r`, and `α`.
    extended: Option<([f64; MAX_RELATIVE_DEGREE], f64, ClassK)>,
}

/// The coefficients of `∏ (s + p_i)`, lowest first (`poles.len() + 1` of them, monic).
fn pole_polynomial(poles: &[f64]) -> [f64; MAX_RELATIVE_DEGREE + 1] {
    let mut c = [0.0; MAX_RELATIVE_DEGREE + 1];
    c[0] = 1.0;
    for (n, &p) in poles.iter().enumerate() {
        // (s + p) · Σ c_i s^i: new c_i = c_{i−1} + p c_i, from the top down.
        c[n + 1] = c[n];
        for i in (1..=n).rev() {
            c[i] = c[i - 1] + p * c[i];
        }
        c[0] *= p;
    }
    c
}

impl Gains {
    /// The gains that place the poles of `h`'s closed loop at `−p_i`: the coefficients of
    /// `∏ (s + p_i) = s^r + k_{r−1} s^{r−1} + … + k_0`. For two poles, `k_0 = p_1 p_2` and
    /// `k_1 = p_1 + p_2`. Every ECBF row in the crate takes its gains from here.
    pub fn from_poles(poles: &Poles) -> Self {
        let c = pole_polynomial(poles.as_slice());
        let mut k = [0.0; MAX_RELATIVE_DEGREE];
        k[..poles.len()].copy_from_slice(&c[..poles.len()]);
        Self { k, degree: poles.len(), extended: None }
    }

    /// The gains of `poles` with `class_k` in the last term: [`Gains::from_poles`] for
    /// [`ClassK::LINEAR`], else the row `ψ̇ + p_r α(ψ) ≥ 0` ([`ClassK`]). `k` stays the
    /// linear gains (what [`Gains::as_slice`] reports and the domain checks read).
    pub fn with_class_k(poles: &Poles, class_k: ClassK) -> Self {
        let mut gains = Self::from_poles(poles);
        if !class_k.is_linear() {
            let (first, last) = poles.as_slice().split_at(poles.len() - 1);
            let c = pole_polynomial(first);
            let mut psi = [0.0; MAX_RELATIVE_DEGREE];
            psi[..poles.len()].copy_from_slice(&c[..poles.len()]);
            gains.extended = Some((psi, last[0], class_k));
        }
        gains
    }

    /// The class-K function of the last term.
    pub fn class_k(&self) -> ClassK {
        self.extended.map_or(ClassK::LINEAR, |(_, _, alpha)| alpha)
    }

    /// Gains given directly, `k_0 … k_{r−1}` (their count is the relative degree). Their
    /// range is checked where they are used ([`EcbfQp::new`](crate::filter::EcbfQp::new)).
    ///
    /// # Errors
    /// No gains, or more than [`MAX_RELATIVE_DEGREE`].
    pub fn new(gains: &[f64]) -> Result<Self, CbfError> {
        let poles = Poles::new(gains)?; // the same count rule
        Ok(Self { k: poles.values, degree: poles.len, extended: None })
    }

    /// The gains, `k_0 … k_{r−1}`.
    pub fn as_slice(&self) -> &[f64] {
        &self.k[..self.degree]
    }

    /// The relative degree `r` these gains are for.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// `b = L_f^r h + k_{r−1} L_f^{r−1} h + … + k_0 h` of a row (≥ 0 when the ECBF condition
    /// holds at `u = 0`), summed from the highest derivative down.
    ///
    /// With an extended class-K function: `b = ψ̇|_{u=0} + p_r α(ψ)`, `ψ = Σ c_i L_f^i h`.
    pub fn bound(&self, lie: &[f64; MAX_RELATIVE_DEGREE + 1]) -> f64 {
        self.bound_on(lie, |alpha, psi| alpha.eval(psi))
    }

    /// [`Gains::bound`] over enclosures of `lie`: an interval holding every value `b`
    /// takes where each `L_f^i h` lies in `lie[i]`, each operation rounded outward. An
    /// extended class-K function is increasing (the generator checks it), so it is
    /// evaluated at the ends of `ψ`'s enclosure, each moved 16 steps outward for its own
    /// rounding.
    pub fn bound_enclosure(&self, lie: &[Interval; MAX_RELATIVE_DEGREE + 1]) -> Interval {
        self.bound_on(lie, |alpha, psi: Interval| {
            if !psi.is_finite() {
                return Interval::ENTIRE;
            }
            let steps = |mut v: f64, up: bool| {
                for _ in 0..16 {
                    v = if up { v.next_up() } else { v.next_down() };
                }
                v
            };
            Interval::new(steps(alpha.eval(psi.lo), false), steps(alpha.eval(psi.hi), true))
        })
    }

    /// The row's ECBF condition at input `u`, `ψ = a·u + b` (met where `≥ 0`).
    pub fn condition<const NU: usize>(&self, row: &Row<NU>, u: &[f64; NU]) -> f64 {
        row.lg.iter().zip(u).fold(self.bound(&row.lie), |s, (a, u)| s + a * u)
    }

    /// [`Gains::condition`] over a row's enclosure at input `u`: every `ψ` the row can
    /// take where the enclosure holds.
    pub fn condition_enclosure<const NU: usize>(
        &self,
        e: &crate::filter::between_samples::RowEnclosure<NU>,
        u: &[f64; NU],
    ) -> Interval {
        e.lg.iter().zip(u).fold(self.bound_enclosure(&e.lie), |s, (a, u)| s + *a * Interval::point(*u))
    }

    /// At most the interval operations one [`Gains::condition_enclosure`] performs with
    /// `nu` inputs: the bound's sums over every derivative (two with an extended
    /// class-K function, whose `α` is evaluated on the bounds) and `a·u`.
    pub const fn condition_enclosure_ops(nu: usize) -> crate::ops::OpCount {
        let terms = 2 * (MAX_RELATIVE_DEGREE + 1) as u64 + nu as u64;
        crate::ops::OpCount { add: terms, mul: terms, ..crate::ops::OpCount::ZERO }
    }

    /// [`Gains::bound`]'s formula on any scalar, with `α(ψ)` given: one formula for the
    /// filter's `f64` and the certificate's enclosure, summed in the same order.
    #[inline]
    fn bound_on<S: crate::scalar::Scalar>(
        &self,
        lie: &[S; MAX_RELATIVE_DEGREE + 1],
        alpha_of: impl Fn(&ClassK, S) -> S,
    ) -> S {
        if let Some((c, last, alpha)) = &self.extended {
            let (mut psi, mut psi_dot) = (S::from(0.0), S::from(0.0));
            for i in (0..self.degree).rev() {
                psi = psi + S::from(c[i]) * lie[i];
                psi_dot = psi_dot + S::from(c[i]) * lie[i + 1];
            }
            return psi_dot + S::from(*last) * alpha_of(alpha, psi);
        }
        // One arm per degree: straight-line code in the QP's per-row loop (a loop over the
        // degree costs about 1 % of a Tachyon 3 update), summed in the same order.
        let k = |i: usize| S::from(self.k[i]);
        match self.degree {
            1 => lie[1] + k(0) * lie[0],
            2 => lie[2] + k(1) * lie[1] + k(0) * lie[0],
            3 => lie[3] + k(2) * lie[2] + k(1) * lie[1] + k(0) * lie[0],
            _ => lie[4] + k(3) * lie[3] + k(2) * lie[2] + k(1) * lie[1] + k(0) * lie[0],
        }
    }
}

/// One family's ECBF tuning: its poles, priority and activation threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FamilyParams {
    /// One pole per derivative, as many as the family's relative degree.
    pub poles: Poles,
    /// Who yields when rows conflict: 0 (the default) is met first, then 1 in the room
    /// tier 0 leaves, and so on, up to
    /// [`domain::MAX_PRIORITY`](crate::filter::domain::MAX_PRIORITY). A lexicographic
    /// order, not a weight: no row of a higher number is kept at the cost of one of a
    /// lower number, whatever units either is written in. Put what must hold (the
    /// mechanism, the environment) at 0 and preferences (footholds, posture) after it.
    pub priority: u8,
    /// The row takes part only while `h` is below this (in `h`'s own units;
    /// `f64::INFINITY` = always). Rows above it are relaxed through their bounds, not
    /// removed.
    pub activation: f64,
    /// The class-K function of the last ECBF term ([`ClassK`]): the spec's `class_k=`,
    /// [`ClassK::LINEAR`] unless it gives one.
    pub class_k: ClassK,
}

impl FamilyParams {
    /// The ECBF gains of [`FamilyParams::poles`] and [`FamilyParams::class_k`].
    pub fn gains(&self) -> Gains {
        Gains::with_class_k(&self.poles, self.class_k)
    }
}

/// What a family's rows promise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FamilyKind {
    /// A control barrier function: `h ≥ 0` is kept (safety, in
    /// [`Output::safety`](crate::filter::Output::safety)).
    Barrier,
    /// A control Lyapunov function `V`, declared with `s.lyapunov` in the spec: the rows
    /// ask for the decrease `V̇ + λ V ≤ 0` (stored as the barrier `h = −V` with the pole
    /// `λ`), at a priority below the safety rows (never 0), relaxed by as little as the
    /// tiers above leave room for — a relaxation is convergence given up, reported in
    /// [`Output::convergence`](crate::filter::Output::convergence), never as a safety
    /// verdict.
    Lyapunov,
}

impl FamilyKind {
    /// Lower-case name, for messages and bindings.
    pub const fn name(self) -> &'static str {
        match self {
            FamilyKind::Barrier => "barrier",
            FamilyKind::Lyapunov => "lyapunov",
        }
    }
}

/// A barrier family's fixed description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FamilyInfo {
    /// The family's name (snake case), as in the spec.
    pub name: &'static str,
    /// A barrier (safety) or a Lyapunov (convergence) family.
    pub kind: FamilyKind,
    /// The relative degree `r`, found symbolically.
    pub relative_degree: usize,
    /// What each row of one instance constrains.
    pub row_names: &'static [&'static str],
    /// The members of an indexed family (a robot's legs, an arm's links), each with its own
    /// kernel and instances; empty for a family that is not indexed.
    pub members: &'static [&'static str],
    /// How the instances are given: fixed, optional or filled up to a capacity.
    pub instances: InstanceKind,
    /// Instances per member of a fixed or optional family; the largest capacity a
    /// capacity family accepts per member.
    pub count: usize,
    /// The run-time parameters of one instance, in declaration order: name and shape
    /// (`[]` a scalar, `[n]` a vector, `[r, c]` a matrix, flattened row by row where
    /// flat); empty for a family without parameters.
    pub params: &'static [(&'static str, &'static [usize])],
    /// The spec's defaults for poles, priority and activation.
    pub defaults: FamilyParams,
}

/// How a family's instances are given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InstanceKind {
    /// A fixed number of instances, always applied: set them.
    Fixed,
    /// A fixed number of slots, each present or absent: set or remove them.
    Optional,
    /// A list filled at run time up to a capacity chosen at construction: push, set,
    /// clear, switch on or off.
    Capacity,
}

impl InstanceKind {
    /// Lower-case name, for messages and bindings.
    pub const fn name(self) -> &'static str {
        match self {
            InstanceKind::Fixed => "fixed",
            InstanceKind::Optional => "optional",
            InstanceKind::Capacity => "capacity",
        }
    }
}

/// Where one row sits: its family, the instance of that family, the row within the
/// instance, and the input columns its `L_g L_f^{r−1} h` can touch (the QP's fixed
/// sparsity pattern).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowLayout {
    /// Index into [`BarrierSet::families`].
    pub family: usize,
    /// Which member of an indexed family, indexing [`FamilyInfo::members`]; 0 otherwise.
    pub member: usize,
    /// Which instance of the family (of the member): an obstacle slot, a foothold edge…
    pub instance: usize,
    /// Which row of the instance, indexing [`FamilyInfo::row_names`].
    pub row: usize,
    /// Input columns where `L_g L_f^{r−1} h` can be non-zero.
    pub columns: &'static [usize],
}

/// A control-affine system `ẋ = f(x) + g(x) u`.
pub trait ControlAffine<const NX: usize, const NU: usize> {
    /// The system's name, as in its spec.
    const NAME: &'static str;
    /// What each state is.
    const STATE_NAMES: [&'static str; NX];
    /// What each input is.
    const INPUT_NAMES: [&'static str; NU];
    /// Default lower input limits (the spec's).
    const INPUT_MIN: [f64; NU];
    /// Default upper input limits (the spec's).
    const INPUT_MAX: [f64; NU];

    /// The drift `f(x)`.
    fn drift(x: &[f64; NX]) -> [f64; NX];

    /// The input matrix `g(x)`, row by state.
    fn input_matrix(x: &[f64; NX]) -> [[f64; NU]; NX];

    /// `ẋ = f(x) + g(x) u`.
    fn xdot(x: &[f64; NX], u: &[f64; NU]) -> [f64; NX] {
        let (mut dx, g) = (Self::drift(x), Self::input_matrix(x));
        for (d, row) in dx.iter_mut().zip(&g) {
            *d += row.iter().zip(u).map(|(a, b)| a * b).sum::<f64>();
        }
        dx
    }
}

/// A system's barrier rows, laid out once and evaluated each cycle into preallocated
/// storage. Generated for every spec; hand-written implementations follow the same rules.
///
/// The row layout is fixed at construction (from the capacities), so the QP's sparsity
/// is too; rows that do not apply this cycle (an empty obstacle slot) are flagged
/// inactive, not removed.
pub trait BarrierSet<const NU: usize> {
    /// The state the rows are evaluated at (`[f64; NX]` for generated systems).
    type State;
    /// Everything the rows read at run time besides the state: each family's instances.
    type Params;

    /// The families, indexed by [`RowLayout::family`].
    fn families(&self) -> &[FamilyInfo];
    /// Where each row sits, in row order.
    fn layout(&self) -> &[RowLayout];
    /// The rows as last evaluated, in [`BarrierSet::layout`] order.
    fn rows(&self) -> &[Row<NU>];
    /// Evaluate every row at time `t` (read by time-varying families only), state `x`
    /// and `params`. Must not allocate.
    ///
    /// # Errors
    /// A state, time or parameter outside its domain, or `params` laid out for another
    /// capacity. Rows are left as they were.
    fn evaluate(&mut self, t: f64, x: &Self::State, params: &Self::Params) -> Result<(), CbfError>;

    /// An upper bound on the operations one [`BarrierSet::evaluate`] performs in the
    /// generated kernels it calls (every family, every instance slot up to the parameters'
    /// capacity, culling ignored); `None` where a kernel it calls states no count.
    ///
    /// A generated barrier set sums its kernels' stated counts ([`crate::ops`]) over the
    /// calls `evaluate` makes with every slot filled and nothing culled: a family's
    /// kernel without parameters (and its lower bound) once, and for a family with
    /// parameters each member's state part once and its instance part once per slot; a
    /// composed or framed member per instance from its poses, and the poses once per cycle
    /// (each node of the tree and each placed box, as the cycle's pose cache computes
    /// them). That is what it performs then, in a release build (a debug build also
    /// evaluates each culled row, to check its bound); emptier slots and culled rows only
    /// do less. The count is of the kernels' floating-point operations, not of storing the
    /// rows or checking the parameters. `None` (the default) for a hand-written set.
    fn evaluation_ops(&self) -> Option<crate::ops::OpCount> {
        None
    }

    /// From now on, skip the rows of an instance of family `k` whose family's lower bound
    /// on `h` (declared in the spec, `lower_bound=`) exceeds `thresholds[k]`: they are
    /// stored with [`Row::cull`] instead of evaluated. The filter passes each family's
    /// activation threshold, above which a row takes no part anyway, so culling changes
    /// the cost of an update, never its input. `+∞` (the start) culls nothing. Barrier
    /// sets without bounds ignore it.
    fn cull_above(&mut self, thresholds: &[f64]) {
        let _ = thresholds;
    }

    /// Enclose the rows flagged in `wanted` over every state the plant reaches in
    /// `window` from `x`, into `out` (other rows left as they are): what certifies them
    /// between the samples ([`crate::filter::between_samples`]). Must not allocate.
    /// Generated barrier sets run their kernels on intervals
    /// ([`enclose_generated`](crate::filter::between_samples::enclose_generated)); the
    /// default cannot.
    ///
    /// # Errors
    /// [`NotEnclosed`](crate::filter::between_samples::NotEnclosed): no interval form for
    /// a wanted row, or reachable states that could not be enclosed.
    fn enclose(
        &self,
        window: &crate::filter::between_samples::Window<NU>,
        x: &Self::State,
        params: &Self::Params,
        wanted: &[bool],
        out: &mut [crate::filter::between_samples::RowEnclosure<NU>],
    ) -> Result<(), crate::filter::between_samples::NotEnclosed> {
        let _ = (window, x, params, out);
        Err(crate::filter::between_samples::NotEnclosed::NoIntervalForm {
            row: wanted.iter().position(|&w| w).unwrap_or(0),
        })
    }

    /// Enclose the rows flagged in `wanted` over a given box of states `states` and times
    /// `times`, into `out`: [`BarrierSet::enclose`] without the flow, for a wrapper that
    /// encloses the plant's flow itself (the [joint-torque map](crate::torque::JointTorque),
    /// whose plant is not this set's `ẋ = f + g u`). Must not allocate. Generated barrier
    /// sets run their kernels on intervals
    /// ([`enclose_rows_generated`](crate::filter::between_samples::enclose_rows_generated));
    /// the default cannot.
    ///
    /// # Errors
    /// As [`BarrierSet::enclose`].
    fn enclose_over(
        &self,
        states: &[crate::interval::Interval],
        times: crate::interval::Interval,
        params: &Self::Params,
        wanted: &[bool],
        out: &mut [crate::filter::between_samples::RowEnclosure<NU>],
    ) -> Result<(), crate::filter::between_samples::NotEnclosed> {
        let _ = (states, times, params, out);
        Err(crate::filter::between_samples::NotEnclosed::NoIntervalForm {
            row: wanted.iter().position(|&w| w).unwrap_or(0),
        })
    }

    /// An upper bound on the interval operations one [`BarrierSet::enclose`] performs
    /// with every row wanted: the dynamics' field per evaluation and the rows' kernels
    /// ([`EnclosureOps`](crate::filter::between_samples::EnclosureOps)); `None` (the
    /// default) where either states no count. A wrapper whose flow is its own (the
    /// [joint-torque map](crate::torque::JointTorque)) states its own field and its
    /// refinement of the reached box.
    fn enclosure_ops(&self) -> Option<crate::filter::between_samples::EnclosureOps> {
        None
    }

    /// Whether the system has an objective (a spec's `s.objective(P=…, q=…)`): the filter
    /// then minimises `½ (u − u_ref)ᵀ P (u − u_ref) + qᵀ u` with [`BarrierSet::objective`]'s
    /// `P` and `q` instead of the input weights'. `false` unless implemented.
    fn has_objective(&self) -> bool {
        false
    }

    /// Write the objective's `P(x)` and `q(x)` at time `t` (read by time-varying systems
    /// only), state `x` and `params` into `cost`; called each update when
    /// [`BarrierSet::has_objective`], after [`BarrierSet::evaluate`] accepted the same
    /// arguments. The filter checks `P` (symmetric positive definite,
    /// [`crate::qp::metric`]). Must not allocate.
    fn objective(&self, t: f64, x: &Self::State, params: &Self::Params, cost: &mut Objective<NU>) {
        let _ = (t, x, params, cost);
    }
}

/// A quadratic objective `½ uᵀ P u + qᵀ u` at one state ([`BarrierSet::objective`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Objective<const NU: usize> {
    /// `P`, symmetric positive definite, row by row.
    pub p: [[f64; NU]; NU],
    /// `q`.
    pub q: [f64; NU],
}

impl<const NU: usize> Default for Objective<NU> {
    /// The weights' default: `P = I`, `q = 0`.
    fn default() -> Self {
        Self { p: std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j)))), q: [0.0; NU] }
    }
}

/// Instances of one capacity-sized family, filled at run time up to a capacity fixed at
/// construction: pushing never allocates, and a full set is a typed error.
#[derive(Debug, Clone, PartialEq)]
pub struct Instances<T> {
    what: &'static str,
    items: Vec<T>,
    capacity: usize,
    enabled: bool,
}

impl<T> Instances<T> {
    /// Room for `capacity` instances of `what` (the family's name, for error messages).
    ///
    /// # Errors
    /// `capacity` above [`MAX_INSTANCES`].
    pub fn with_capacity(what: &'static str, capacity: usize) -> Result<Self, CbfError> {
        if capacity > MAX_INSTANCES {
            return Err(CbfError::TooLarge { what, value: capacity, max: MAX_INSTANCES });
        }
        Ok(Self { what, items: Vec::with_capacity(capacity), capacity, enabled: true })
    }

    /// Add one instance.
    ///
    /// # Errors
    /// [`CbfError::CapacityExceeded`] when all slots are filled.
    pub fn push(&mut self, item: T) -> Result<(), CbfError> {
        if self.items.len() == self.capacity {
            return Err(CbfError::CapacityExceeded { what: self.what, capacity: self.capacity });
        }
        self.items.push(item);
        Ok(())
    }

    /// Remove every instance (the capacity stays).
    pub fn clear(&mut self) {
        self.items.clear();
    }

    /// The filled instances.
    pub fn as_slice(&self) -> &[T] {
        &self.items
    }

    /// The filled instances, to change them in place.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.items
    }

    /// The capacity fixed at construction.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Switch the whole set on or off without dropping its instances: while off, their
    /// rows are inactive and their parameters are not read (a swing leg's foothold, kept
    /// through stance). On by default.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// Whether the instances' rows take part (see [`Instances::set_enabled`]).
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }
}

/// `Ok(value)` when it is finite with `|value| ≤` [`STATE_LIMIT`]: the check for a state
/// entry and for every world number measured in the same units (floors, goals, planes).
pub fn coordinate(what: &'static str, value: f64) -> Result<f64, CbfError> {
    within(what, value, -STATE_LIMIT, STATE_LIMIT, "[-1e5, 1e5]")
}

/// `Ok(())` when every state entry is finite with `|x_i| ≤` [`STATE_LIMIT`].
///
/// # Errors
/// [`CbfError::NonFinite`] or [`CbfError::OutOfRange`] naming the first bad entry's kind.
pub fn validate_state(x: &[f64]) -> Result<(), CbfError> {
    for &v in x {
        coordinate("state entry", v)?;
    }
    Ok(())
}

/// `Ok(())` when every runtime parameter is finite with `|p| ≤` [`PARAM_LIMIT`].
///
/// # Errors
/// [`CbfError::NonFinite`] or [`CbfError::OutOfRange`] naming `what`.
pub fn validate_params(what: &'static str, values: &[f64]) -> Result<(), CbfError> {
    for &v in values {
        within(what, v, -PARAM_LIMIT, PARAM_LIMIT, "[-1e6, 1e6]")?;
    }
    Ok(())
}

/// `Ok(())` when `t` is finite with `|t| ≤` [`TIME_LIMIT`].
///
/// # Errors
/// [`CbfError::NonFinite`] or [`CbfError::OutOfRange`].
pub fn validate_time(t: f64) -> Result<(), CbfError> {
    within("time", t, -TIME_LIMIT, TIME_LIMIT, "[-1e9, 1e9]").map(|_| ())
}

/// One generated kernel behind a uniform signature, for tools that iterate over every
/// kernel of a system (the SymEngine cross-check, Python's `call_kernel`).
#[derive(Debug, Clone, Copy)]
pub struct KernelEntry {
    /// The kernel's function name.
    pub name: &'static str,
    /// Inputs in argument order: name and number of scalars (1 for a scalar).
    pub inputs: &'static [(&'static str, usize)],
    /// Outputs in return order: name and number of scalars, flattened as the symbolic
    /// stage lists them (matrices row by row, symmetric matrices by upper triangle).
    pub outputs: &'static [(&'static str, usize)],
    /// The operations one call performs, as the generator stated them for a kernel it
    /// printed as one straight line (`None` for kernels assembled from others, and for
    /// tables written by hand): see [`crate::ops`].
    pub ops: Option<crate::ops::OpCount>,
    /// Call with every input flattened in order into one slice and receive every output
    /// flattened likewise; lengths must equal the sums of `inputs` and `outputs` (the
    /// call panics otherwise: a tool's bug, never a control-path one).
    pub call: fn(&[f64], &mut [f64]),
}

impl KernelEntry {
    /// Its name and slots, without the function.
    pub fn signature(&self) -> KernelSignature {
        KernelSignature { name: self.name, inputs: self.inputs, outputs: self.outputs }
    }
}

/// A kernel's name and its flat inputs and outputs (as [`KernelEntry`] lists them), with
/// no function: what [`DynSystem::kernels`](crate::dynamic::DynSystem::kernels) lists for
/// a linked or a loaded system alike.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KernelSignature {
    /// The kernel's function name.
    pub name: &'static str,
    /// Inputs in argument order: name and number of scalars.
    pub inputs: &'static [(&'static str, usize)],
    /// Outputs in return order: name and number of scalars.
    pub outputs: &'static [(&'static str, usize)],
}

impl KernelSignature {
    /// Numbers in all inputs together.
    pub fn input_len(&self) -> usize {
        self.inputs.iter().map(|(_, n)| n).sum()
    }

    /// Numbers in all outputs together.
    pub fn output_len(&self) -> usize {
        self.outputs.iter().map(|(_, n)| n).sum()
    }

    /// `Ok(())` when `inputs` and `outputs` are exactly as long as the kernel's slots.
    ///
    /// # Errors
    /// [`CbfError::LengthMismatch`] naming which.
    pub fn check_lengths(&self, inputs: &[f64], outputs: &[f64]) -> Result<(), CbfError> {
        let (expected, got) = (self.input_len(), inputs.len());
        if got != expected {
            return Err(CbfError::LengthMismatch { what: "kernel inputs", expected, got });
        }
        let (expected, got) = (self.output_len(), outputs.len());
        if got != expected {
            return Err(CbfError::LengthMismatch { what: "kernel outputs", expected, got });
        }
        Ok(())
    }
}

/// The position and signature of kernel `name` among `kernels`.
///
/// # Errors
/// [`CbfError::UnknownName`] listing the kernels.
pub fn find_kernel(
    system: &'static str,
    kernels: &[KernelSignature],
    name: &str,
) -> Result<(usize, KernelSignature), CbfError> {
    kernels.iter().position(|k| k.name == name).map(|i| (i, kernels[i])).ok_or_else(|| CbfError::UnknownName {
        what: "kernel",
        name: format!("{system}::{name}"),
        known: kernels.iter().map(|k| k.name).collect::<Vec<_>>().join(", "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_condition_on_an_enclosure_performs_no_more_than_its_stated_operations() {
        // The bound's formula run on numbers that count (the one formula of the f64 bound
        // and of its enclosure), with α counted as its two evaluations on the bounds, plus
        // a·u: within condition_enclosure_ops for linear and extended gains of every degree.
        use crate::ops::{Counted, OpCount};
        let cubic = ClassK::extended("s^3", |s| s * s * s);
        for degree in 1..=MAX_RELATIVE_DEGREE {
            for gains in [
                Gains::from_poles(&Poles::repeated(2.0, degree)),
                Gains::with_class_k(&Poles::repeated(2.0, degree), cubic),
            ] {
                let lie = [Counted(0.5); MAX_RELATIVE_DEGREE + 1];
                let (_, bound) = Counted::measure(|| gains.bound_on(&lie, |_, psi| psi));
                let nu = 7;
                let a_u = OpCount { add: nu, mul: nu, ..OpCount::ZERO };
                let stated = Gains::condition_enclosure_ops(nu as usize);
                let counted = bound + a_u;
                assert!(
                    counted.add <= stated.add && counted.mul <= stated.mul && counted.total() <= stated.total(),
                    "degree {degree}: counted {counted}, stated {stated}"
                );
            }
        }
    }

    #[test]
    fn the_bound_enclosure_holds_the_bound_at_every_point_of_its_boxes() {
        // Linear and extended class-K gains of degrees 1 to 4, random boxes of L_f^i h: the
        // f64 bound at 50 points of each box (its two extreme corners among them) lies in
        // the enclosure.
        let cubic = ClassK::extended("s^3", |s| s * s * s);
        let mut seed = 0x5eed_u64;
        let mut draw = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..4000 {
            let degree = 1 + case % MAX_RELATIVE_DEGREE;
            let poles: Vec<f64> = (0..degree).map(|_| 0.5 + 20.0 * draw()).collect();
            let class_k = if case % 2 == 0 { ClassK::LINEAR } else { cubic };
            let gains = Gains::with_class_k(&Poles::new(&poles).unwrap(), class_k);
            let mut boxes = [Interval::point(0.0); MAX_RELATIVE_DEGREE + 1];
            for b in &mut boxes[..=degree] {
                let (centre, width) = (4.0 * draw() - 2.0, 0.1 * draw());
                *b = Interval::new(centre - width, centre + width);
            }
            let enclosure = gains.bound_enclosure(&boxes);
            assert!(enclosure.is_finite(), "case {case}");
            for k in 0..50 {
                let lie: [f64; MAX_RELATIVE_DEGREE + 1] = std::array::from_fn(|i| {
                    let b = boxes[i];
                    let at = if k < 2 { k as f64 } else { draw() };
                    b.lo + at * (b.hi - b.lo)
                });
                let value = gains.bound(&lie);
                assert!(enclosure.contains(value), "case {case}: {value} outside {enclosure}");
            }
        }
    }

    #[test]
    fn poles_from_array_in_a_constant_equal_the_run_time_conversion() {
        const POLES: Poles = Poles::from_array([3.0, 4.0, 5.0]);
        assert_eq!(POLES, Poles::from([3.0, 4.0, 5.0]));
        assert_eq!(POLES.as_slice(), &[3.0, 4.0, 5.0]);
        assert_eq!(Gains::from_poles(&POLES).as_slice(), &[60.0, 47.0, 12.0]);
    }

    #[test]
    fn gains_are_the_coefficients_of_the_pole_polynomial_expanded_by_hand() {
        // (s + p): k0 = p. (s+1)(s+2)(s+3)(s+4) = s⁴ + 10 s³ + 35 s² + 50 s + 24.
        assert_eq!(Gains::from_poles(&Poles::from([7.0])).as_slice(), &[7.0]);
        assert_eq!(Gains::from_poles(&Poles::from([2.0, 3.0])).as_slice(), &[6.0, 5.0]);
        assert_eq!(Gains::from_poles(&Poles::from([1.0, 2.0, 3.0, 4.0])).as_slice(), &[24.0, 50.0, 35.0, 10.0]);
        // b = L_f^r h + Σ k_i L_f^i h, for every degree.
        let lie = [1.0, 2.0, 3.0, 4.0, 5.0];
        let bound = |poles: &[f64]| Gains::from_poles(&Poles::new(poles).unwrap()).bound(&lie);
        assert_eq!(bound(&[7.0]), 2.0 + 7.0);
        assert_eq!(bound(&[2.0, 3.0]), 3.0 + 5.0 * 2.0 + 6.0);
        assert_eq!(bound(&[3.0, 4.0, 5.0]), 4.0 + 12.0 * 3.0 + 47.0 * 2.0 + 60.0);
        assert_eq!(bound(&[1.0, 2.0, 3.0, 4.0]), 5.0 + 10.0 * 4.0 + 35.0 * 3.0 + 50.0 * 2.0 + 24.0);
        assert!(Poles::new(&[]).is_err() && Poles::new(&[1.0; 5]).is_err() && Gains::new(&[1.0; 5]).is_err());
    }

    #[test]
    fn an_extended_class_k_term_is_psi_dot_plus_the_last_pole_times_alpha_of_psi() {
        let lie = [0.5, -2.0, 3.0, -4.0, 5.0];
        let cube = ClassK::extended("s**3", |s| s * s * s);
        let gains = |poles: &[f64], alpha| Gains::with_class_k(&Poles::new(poles).unwrap(), alpha);
        // Degree 1: ḣ + p α(h) = −2 + 7 · 0.125.
        assert_eq!(gains(&[7.0], cube).bound(&lie), -2.0 + 7.0 * 0.125);
        // Degree 2, poles (2, 3): ψ = ḣ + 2h = −1, ψ̇ = ḧ + 2ḣ = −1, so b = −1 + 3 · (−1)³.
        assert_eq!(gains(&[2.0, 3.0], cube).bound(&lie), -1.0 - 3.0);
        // Degree 3, poles (1, 2, 4): ψ = ḧ + 3ḣ + 2h = −2, ψ̇ = h⁽³⁾ + 3ḧ + 2ḣ = 1: b = 1 + 4 · (−8).
        assert_eq!(gains(&[1.0, 2.0, 4.0], cube).bound(&lie), 1.0 - 32.0);
        // α(s) = s written as a function is the plain ECBF, for every degree.
        let identity = ClassK::extended("s", |s| s);
        for poles in [&[7.0][..], &[2.0, 3.0], &[3.0, 4.0, 5.0], &[1.0, 2.0, 3.0, 4.0]] {
            let linear = gains(poles, ClassK::LINEAR).bound(&lie);
            assert!((gains(poles, identity).bound(&lie) - linear).abs() <= 1e-12 * linear.abs().max(1.0));
        }
        assert_eq!(gains(&[2.0, 3.0], cube).class_k(), cube);
        assert_eq!(gains(&[2.0, 3.0], cube).as_slice(), &[6.0, 5.0]); // the linear gains, for the domain checks
        assert!(gains(&[2.0], ClassK::LINEAR).class_k().is_linear() && !cube.is_linear());
    }

    #[test]
    fn a_stored_row_keeps_only_its_own_derivatives_and_columns() {
        let mut row = Row::<3> { lie: [9.0; MAX_RELATIVE_DEGREE + 1], lg: [9.0; 3], active: false, culled: true };
        row.store(&[1.0, 2.0, 3.0], &[4.0], &[2]);
        assert_eq!(row, Row { lie: [1.0, 2.0, 3.0, 0.0, 0.0], lg: [0.0, 0.0, 4.0], active: true, culled: false });
    }
}
