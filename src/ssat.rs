//! Smooth Separating Axis Theorem (SSAT): a twice-differentiable box–box barrier.
//!
//! `h = smax(y_1, …, y_15)` over the candidate separating axes of two boxes, with the
//! non-smooth `max` and `|·|` of the exact SAT replaced by smooth surrogates (Tachyon 3
//! paper, eq. 7–10). The formula is built, differentiated and emitted by the symbolic
//! stage (`symbolic/families/ssat.py`); this module is the safe API over those kernels.
//!
//! # Variants
//! The paper's Table I compares smooth maxima ([`SmoothMax`]: log-sum-exp, Boltzmann)
//! and smooth absolute values ([`SmoothAbs`]: `x·tanh(αx)`, `√(x² + ε²)`); all four
//! combinations are generated. The default, LSE + x·tanh, is the paper's choice, and it
//! is kept for safety, not speed. On our Table I (`docs/benchmarks.md`), LSE + √ is
//! faster: 0.80× the default's value, 0.81× with derivatives. But √ overstates the
//! centre term by up to `1/α` whatever the boxes' size, whereas x·tanh understates the
//! extents by at most `0.2785/α_rot` per metre of them, so the default's
//! [certified margin](#certified-margin) is the smaller one. For the stair body–edge pair
//! at α = α_rot = 200 it is 15.9 mm against 18.5 mm: 2.6 mm less clearance the filter must
//! hold. Boltzmann has a smaller margin still, but its error below the max has no
//! constant bound and its zero level set is not convex (the paper's Fig. 6,
//! `examples/fig6_ssat_boundary.rs`); with derivatives it is 1.3× slower. Any variant is
//! chosen by name with [`SmoothParams::with_variant`].
//!
//! # Certified margin
//! A smooth `h ≥ 0` does not by itself prove the boxes are apart: the surrogates err.
//! [`certified_margin`] returns `m` such that **`h − m ≥ 0` implies the exact boxes do
//! not overlap** in exact arithmetic ([`certified_separated`] also covers rounding, see
//! [Rounding guard](#rounding-guard)). Derivation, per axis `i` with exact
//! (unnormalised) value `ŷ_i`:
//!
//! * `|x| − x·tanh(αx) ∈ [0, c/α]` with `c = max_u u(1 − tanh u) ≈ 0.2785`, and
//!   `√(x² + ε²) − |x| ∈ [0, ε]`. The centre term `|n·Δp|` enters `y_i` with a plus sign,
//!   so only a surrogate that *overstates* `|x|` (√, by ≤ ε) can raise `y_i`; the extent
//!   terms enter with a minus sign, so only one that *understates* (x·tanh, by
//!   ≤ `c/α_rot` per unit half extent) can. Summing gives `y_i − ŷ_i ≤ e_i`.
//! * The parallel-edge term (see below) only lowers `y_i`.
//! * `0 ≤ LSE − max ≤ ln(15)/α`; the Boltzmann operator never exceeds the max.
//!
//! So `h ≤ max_i y_i + o ≤ max_i (ŷ_i + e_i) + o` with `o` the smooth max's overshoot,
//! and `m = o + max_i e_i` gives: `h ≥ m ⇒ ŷ_k ≥ 0` for some axis `k`, i.e. the boxes are
//! separated (or touching) along that axis. The margin kernels are generated from the
//! same per-axis bounds as the formula, so the two cannot drift apart.
//!
//! # Rounding guard
//! That argument is about exact `h` and `m`; the kernels compute them in f64. With
//! `u = f64::EPSILON / 2` (unit roundoff), `Δp = p_B − p_A`, `D` the sum of the six half
//! extents and `S = ‖Δp‖₁ + D + |h| + m` the problem's scale, every quantity the kernels
//! form is a short sum of products bounded by one of the terms of `S`, so the rounding
//! error of the computed `h − m` is a multiple of `u·S`. Tallied per step, all errors
//! aligned:
//!
//! * the transcendental functions are the runtime's own ([`crate::lanes`]), each within a
//!   stated distance of the correctly rounded value: `tanh` within
//!   [`TANH_MAX_ULP`](crate::lanes::TANH_MAX_ULP)` = 2` ulp (relative error `≤ 4u`),
//!   `exp` and `ln` within [`EXP_MAX_ULP`](crate::lanes::EXP_MAX_ULP)` =`
//!   [`LN_MAX_ULP`](crate::lanes::LN_MAX_ULP)` = 1` ulp (`≤ 2u`); the tally below counts
//!   those bounds, and a compile-time check stops the build if they grow;
//! * an axis's centre term: the projection `n·Δp` (at most two rotated products of
//!   `Δp`) `≲ 18u·‖Δp‖₁`, then its smoothed `|·|` (Lipschitz ≤ 1.2) and that
//!   surrogate's own rounding, `≲ 5.5u` of its size (`x·tanh`: `4u` from `tanh`, `1.5u`
//!   from the products; √: `≲ 2.5u·(|x| + 1/α)`, `1/α ≤ m`);
//! * its extent terms and the parallel-edge term `D·R⁸`: `≲ 45u·D`, plus `≲ 15u·|y_i|`
//!   for the √ surrogate, whose extent terms can exceed `D` when `alpha_rot < 1`;
//! * so each `y_i` is off by `≲ 85u·S` on the axes that carry weight (`|y_i| ≲ |h| + m`
//!   there; axes far below the max are damped by their weight). The smooth max passes
//!   that on with a Lipschitz constant of 1 (LSE) or `≲ 2` (Boltzmann) and adds
//!   `≲ 35u·S` of its own rounding: for LSE the 15 `exp` (`2u` each, relative) and their
//!   sum (`14u`) make `Σ` relatively `≲ 16u` off, which `ln` (`2u` of `ln Σ ≤ ln 15`)
//!   passes on as `≲ 22u/α ≤ 8u·m`; the Boltzmann weights' `exp` and the weighted mean
//!   `≲ 35u` of the largest `|y_i|`;
//! * the margin kernel `≲ 10u·m` and the final subtraction `u·|h − m|`;
//! * stored rotations are orthonormal to `8·EPSILON` ([`OrientedBox::new`] projects
//!   them), and the frame algebra that assumes `RᵀR = I` adds `≲ 16u·(‖Δp‖₁ + D)`.
//!
//! That is at most `≈ 240u·S ≈ 120·EPSILON·S`. The guard is [`ROUNDING_GUARD`]` · S`
//! with `ROUNDING_GUARD = 256·EPSILON`, above the tally: [`certified_separated`] accepts
//! only when `h − m − 256·EPSILON·S ≥ 0`, which is [`certified_clearance`] `≥ 0`. At robot
//! scale (0.5 m boxes 1 m apart, `S ≈ 6` m) the guard is `≈ 3e-13` m; it only decides
//! near the edges of the [domain](#domain). The tests measure the real rounding with
//! the swapped pair: `h(A, B) = h(B, A)` in exact arithmetic, computed along different
//! paths.
//!
//! # Domain
//! `alpha` [1/m] and `alpha_rot` [–] each lie between [`ALPHA_MIN`] and [`ALPHA_MAX`];
//! boxes lie in the [`geometry` domain](crate::geometry#domain). Measured on that
//! domain's corners (extreme extents, coordinates, touching and coincident placements,
//! exact and generic rotations), all four variants' value, gradient, Hessian and margin
//! stay finite for α from 1e-154 to 1e77 (√ overflows `1/α²` below; the Boltzmann-√
//! Hessian's `α⁴`-sized terms overflow above) and α_rot from 1e-154 up. The domain sits
//! far inside that and is chosen for meaning:
//!
//! * [`ALPHA_MIN`] = 1e-6 1/m: a smoothing length `1/α` of 10⁶ m, the size of the
//!   coordinate domain; smoother than that, `h` carries no information about the boxes.
//! * [`ALPHA_MAX`] = 1e9 1/m: a smoothing length of 1 nm, a thousandth of the smallest
//!   box. For `alpha_rot`, 1e-9 is the rotation tolerance: sharper smoothing of rotation
//!   entries than they are trusted to is meaningless.
//! * Together with the box domain, `α·size ∈ [1e-12, 1e13]`, three decades from where
//!   the unguarded certificate was measured to fail (see the
//!   [`geometry` domain](crate::geometry#domain)).
//!
//! # Parallel edges and overflow
//! An edge–edge axis `eᵢ × fⱼ` vanishes for parallel edges, which would pin its `y` at 0
//! and make overlapping, yaw-aligned boxes read as touching. Each such axis is lowered by
//! `D·Rᵢⱼ⁸` (`D` = sum of all half extents), which puts it at `−D` (below every face
//! axis) exactly when it carries no information. The smooth max is evaluated shifted by
//! the largest `y`, so it is finite at any distance.
//!
//! ```
//! use cbfgen::{OrientedBox, ssat::{self, SmoothParams}};
//! use nalgebra::Vector3;
//! let a = OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(0.5, 0.3, 0.1))?;
//! let b = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, 0.5), Vector3::new(0.2, 0.2, 0.2))?;
//! let p = SmoothParams::default();
//! let h = ssat::ssat(&a, &b, &p);
//! assert!(h > 0.0 && ssat::certified_separated(&a, &b, &p));
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use crate::error::{positive, within, CbfError};
use crate::generated::ssat as gen;
use crate::geometry::OrientedBox;
use nalgebra::{Matrix3, Vector3};

/// Smallest accepted `alpha` [1/m] and `alpha_rot` [–] (see the [module docs](self#domain)).
pub const ALPHA_MIN: f64 = 1e-6;

/// Largest accepted `alpha` [1/m] and `alpha_rot` [–] (see the [module docs](self#domain)).
pub const ALPHA_MAX: f64 = 1e9;
const ALPHA_RANGE: &str = "[1e-6, 1e9]";

/// The certificate's rounding guard relative to the problem's scale `S` (see the
/// [module docs](self#rounding-guard)): above the tallied rounding error of `h − m`.
pub const ROUNDING_GUARD: f64 = 256.0 * f64::EPSILON;

// The guard's tally assumes these bounds of the transcendentals the kernels call; looser
// ones need the tally redone before the guard is trusted.
const _: () = assert!(
    crate::lanes::TANH_MAX_ULP <= 2 && crate::lanes::EXP_MAX_ULP <= 1 && crate::lanes::LN_MAX_ULP <= 1,
    "the SSAT rounding guard's tally counts tanh <= 2 ulp, exp and ln <= 1 ulp"
);

/// The smooth replacement for `max(y_1..y_15)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SmoothMax {
    /// Log-sum-exp: `(1/α) ln Σ exp(α yᵢ)`; convex, overshoots the max by ≤ ln(15)/α.
    #[default]
    Lse,
    /// Boltzmann operator: softmax-weighted mean; never above the max, not convex.
    Boltzmann,
}

/// The smooth replacement for `|x|`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SmoothAbs {
    /// `x·tanh(αx)`: never above `|x|`, at most ≈0.2785/α below it.
    #[default]
    XTanh,
    /// `√(x² + ε²)` with `ε = 1/α`: never below `|x|`, at most ε above it.
    Sqrt,
}

/// Smoothing parameters of the SSAT.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothParams {
    alpha: f64,
    alpha_rot: f64,
    max: SmoothMax,
    abs: SmoothAbs,
}

impl SmoothParams {
    /// `alpha` [1/m] sharpens the smooth max and the smooth `|·|` of distances;
    /// `alpha_rot` [–] sharpens the smooth `|·|` of rotation-matrix entries. Larger is
    /// closer to the exact SAT (smaller margin) but more curved (stiffer barrier).
    ///
    /// # Errors
    /// [`CbfError::NonFinite`] or [`CbfError::NotPositive`] for a value that is not a
    /// positive number, [`CbfError::OutOfRange`] for one outside [`ALPHA_MIN`] ..=
    /// [`ALPHA_MAX`] (see the [module docs](self#domain) for why).
    pub fn new(alpha: f64, alpha_rot: f64) -> Result<Self, CbfError> {
        let sharpness = |what, value| {
            positive(what, value)?;
            within(what, value, ALPHA_MIN, ALPHA_MAX, ALPHA_RANGE)
        };
        Ok(Self {
            alpha: sharpness("SSAT alpha", alpha)?,
            alpha_rot: sharpness("SSAT alpha_rot", alpha_rot)?,
            max: SmoothMax::default(),
            abs: SmoothAbs::default(),
        })
    }

    /// The same sharpness with another Table I variant.
    pub fn with_variant(self, max: SmoothMax, abs: SmoothAbs) -> Self {
        Self { max, abs, ..self }
    }

    /// Sharpness of the smooth max and of the smooth `|·|` of distances \[1/m\].
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// Sharpness of the smooth `|·|` of rotation-matrix entries \[–\].
    pub fn alpha_rot(&self) -> f64 {
        self.alpha_rot
    }

    /// The Table I variant: which smooth max and which smooth `|·|`.
    pub fn variant(&self) -> (SmoothMax, SmoothAbs) {
        (self.max, self.abs)
    }
}

impl Default for SmoothParams {
    /// α = α_rot = 200: about 14 mm of LSE overshoot and, for a 1 m box, under 3 mm of
    /// extent smoothing. A compromise between margin and barrier curvature.
    fn default() -> Self {
        Self { alpha: 200.0, alpha_rot: 200.0, max: SmoothMax::Lse, abs: SmoothAbs::XTanh }
    }
}

/// The smooth SAT value with its gradient and Hessian with respect to box B's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsatDerivatives {
    /// `h`, in metres.
    pub value: f64,
    /// `∂h/∂p_B`, world frame.
    pub gradient: Vector3<f64>,
    /// `∂²h/∂p_B²`, world frame, symmetric.
    pub hessian: Matrix3<f64>,
}

/// Smooth separation of `a` and `b`: > 0 reads as apart, < 0 as overlapping.
/// Finite for any pair of boxes and any parameters (both are validated into their
/// [domains](self#domain)).
#[inline]
pub fn ssat(a: &OrientedBox, b: &OrientedBox, params: &SmoothParams) -> f64 {
    let ((pa, ra, ha), (pb, rb, hb)) = (a.kernel_args(), b.kernel_args());
    let (al, ar) = (params.alpha, params.alpha_rot);
    match (params.max, params.abs) {
        (SmoothMax::Lse, SmoothAbs::XTanh) => gen::ssat_lse_xtanh(&pa, &ra, &ha, &pb, &rb, &hb, al, ar),
        (SmoothMax::Lse, SmoothAbs::Sqrt) => gen::ssat_lse_sqrt(&pa, &ra, &ha, &pb, &rb, &hb, al, ar),
        (SmoothMax::Boltzmann, SmoothAbs::XTanh) => gen::ssat_boltzmann_xtanh(&pa, &ra, &ha, &pb, &rb, &hb, al, ar),
        (SmoothMax::Boltzmann, SmoothAbs::Sqrt) => gen::ssat_boltzmann_sqrt(&pa, &ra, &ha, &pb, &rb, &hb, al, ar),
    }
}

/// [`ssat`] with its gradient and Hessian with respect to box B's centre.
#[inline]
pub fn ssat_with_derivatives(a: &OrientedBox, b: &OrientedBox, params: &SmoothParams) -> SsatDerivatives {
    let ((pa, ra, ha), (pb, rb, hb)) = (a.kernel_args(), b.kernel_args());
    let (al, ar) = (params.alpha, params.alpha_rot);
    let (value, g, h) = match (params.max, params.abs) {
        (SmoothMax::Lse, SmoothAbs::XTanh) => gen::ssat_lse_xtanh_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, al, ar),
        (SmoothMax::Lse, SmoothAbs::Sqrt) => gen::ssat_lse_sqrt_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, al, ar),
        (SmoothMax::Boltzmann, SmoothAbs::XTanh) => {
            gen::ssat_boltzmann_xtanh_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, al, ar)
        }
        (SmoothMax::Boltzmann, SmoothAbs::Sqrt) => {
            gen::ssat_boltzmann_sqrt_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, al, ar)
        }
    };
    SsatDerivatives { value, gradient: Vector3::from(g), hessian: Matrix3::from_fn(|i, j| h[i][j]) }
}

/// The certified margin `m` of [`ssat`] for these two boxes' sizes: `ssat − m ≥ 0` in
/// exact arithmetic implies the boxes do not overlap (see the module docs for the
/// derivation). [`certified_clearance`] adds the guard against rounding.
pub fn certified_margin(a: &OrientedBox, b: &OrientedBox, params: &SmoothParams) -> f64 {
    let (ha, hb) = (a.kernel_args().2, b.kernel_args().2);
    let (al, ar) = (params.alpha, params.alpha_rot);
    match (params.max, params.abs) {
        (SmoothMax::Lse, SmoothAbs::XTanh) => gen::ssat_lse_xtanh_margin(&ha, &hb, al, ar),
        (SmoothMax::Lse, SmoothAbs::Sqrt) => gen::ssat_lse_sqrt_margin(&ha, &hb, al, ar),
        (SmoothMax::Boltzmann, SmoothAbs::XTanh) => gen::ssat_boltzmann_xtanh_margin(&ha, &hb, al, ar),
        (SmoothMax::Boltzmann, SmoothAbs::Sqrt) => gen::ssat_boltzmann_sqrt_margin(&ha, &hb, al, ar),
    }
}

/// `h − m − g`: the smooth SAT value less its certified margin less the rounding guard
/// `g` = [`ROUNDING_GUARD`]` · (‖p_B − p_A‖₁ + D + |h| + m)` (see the
/// [module docs](self#rounding-guard)). `≥ 0` proves the boxes do not overlap; the
/// value is not a distance (edge–edge axes are unnormalised), only its sign is certified.
pub fn certified_clearance(a: &OrientedBox, b: &OrientedBox, params: &SmoothParams) -> f64 {
    let h = ssat(a, b, params);
    let m = certified_margin(a, b, params);
    let offset = (b.center() - a.center()).abs().sum();
    let extents = a.half_extents().sum() + b.half_extents().sum();
    h - m - ROUNDING_GUARD * (offset + extents + h.abs() + m)
}

/// [`certified_clearance`] `≥ 0`: a proof that the boxes do not overlap, rounding
/// included.
pub fn certified_separated(a: &OrientedBox, b: &OrientedBox, params: &SmoothParams) -> bool {
    certified_clearance(a, b, params) >= 0.0
}
