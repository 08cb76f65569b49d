//! Sphere vs oriented box: the exact signed distance, and a smooth clearance whose sign
//! is a proof.
//!
//! Tachyon 3's toe–edge rows keep each toe sphere out of the edge cuboids with the
//! barrier built here (`symbolic/families/sphere_box.py` builds, differentiates and
//! emits it; the same formula is the `toe_edge` family). The reference paper's eq. 11
//! used a superellipsoid inscribed in the cuboid grown by the toe radius instead. That
//! set is not conservative: near the cuboid's edges and corners its zero level lies
//! inside the grown box, so a toe the barrier called safe could touch the cuboid (the
//! stairs run measured −0.6 mm). It was replaced by this certified barrier.
//!
//! # The barrier
//! With `rel = Rᵀ(p − c)` the sphere's centre in the box frame, `a` the half extents and
//! `ε = 1/α` the smoothing length:
//!
//! * `qᵢ = s(relᵢ) − aᵢ`, with `s(x) = √(x² + ε²) − ε`, a smooth `|x|` that never exceeds
//!   it and undershoots it by at most `ε`;
//! * `gᵢ = (qᵢ + √(qᵢ² + 4ε²))/2`, a smooth, increasing `max(qᵢ, 0)` that overshoots it by
//!   `(√(qᵢ² + 4ε²) − |qᵢ|)/2 ∈ (0, ε]`;
//! * `d = √(g_x² + g_y² + g_z² + δ²)` with `δ = 10⁻³·ε`;
//! * `h = d − r − m` with the **certified margin** `m = √3·ε + δ` ([`margin`]).
//!
//! # Certificate
//! Let `D = ‖max(|rel| − a, 0)‖` be the exact distance from the centre to the solid box.
//! `s ≤ |·|` and the smooth max is increasing, so `0 < gᵢ ≤ max(|relᵢ| − aᵢ, 0) + ε`. The
//! norm grows with each non-negative entry, so by the triangle inequality
//! `‖g‖ ≤ D + ‖ε·(1, 1, 1)‖ = D + √3·ε`, and the floor adds at most `δ`: `d ≤ D + m`. So
//! **`h ≥ 0` implies `D ≥ r`**: the centre is outside the box and at least `r` from it,
//! and the sphere does not reach into the box ([`exact_distance`] `≥ 0`). The other way,
//! `gᵢ ≥ max(qᵢ, 0)` and `qᵢ ≥ |relᵢ| − aᵢ − ε`, so while the centre is outside the box
//! `h ≤ exact distance ≤ h + `[`conservatism`]` (= m + √3·ε`, 2.3 mm at α = 1500). Along
//! a face `s` undershoots by about `ε`, so a sphere held at `h = 0` there keeps about
//! `m + ε` of exact clearance. Inside the box `h` stays within `[−r − m, −r]`: the barrier
//! is flat there and only keeps the centre outside.
//!
//! The smooth SAT's `x·tanh(αx)` and a softplus `ln(1 + e^{αq})/α` give the same
//! proof (overshoot `ln2/α`), but cost three `tanh`, six `exp` and three `ln` per sphere
//! (a six-toe kernel at 7× the superellipsoid's cost, against 3.4× for these square roots)
//! and need a runtime shift against overflow; these need none.
//!
//! # Rounding guard
//! The kernels compute `h` in f64. With `u = f64::EPSILON / 2`, `Δ = p − c` and
//! `S = ‖Δ‖₁ + Σaᵢ + r + |h| + m`: `rel` is off by `≲ 5u·‖Δ‖₁` (plus `≲ 32u·‖Δ‖₁` for a
//! rotation orthonormal only to `8·EPSILON`, as [`OrientedBox`] stores them); `s`, the
//! subtraction of `aᵢ` and the smooth max are 1-Lipschitz and each adds `≲ 4u` of the
//! sizes it combines (`≲ 4u·(|relᵢ| + aᵢ + ε)`, the smooth max's cancellation for
//! `qᵢ ≪ 0` included); the norm is 1-Lipschitz and adds `≲ 3u·d`, the final subtractions
//! `≲ 5u·(d + r + m)`. Over the three axes that is `≲ 100u·S`. [`certified_clearance`]
//! subtracts [`ROUNDING_GUARD`]` · S` with `ROUNDING_GUARD = 256·EPSILON = 512u`, five
//! times the tally; at robot scale (`S ≈ 2` m) that is `≈ 1e-13` m.
//!
//! # Domain
//! Boxes are [`OrientedBox`]es (its [domain](crate::geometry#domain)); a [`Sphere`]'s
//! centre lies within ±[`MAX_COORDINATE`] and its radius in `[0, `[`MAX_HALF_EXTENT`]`]`;
//! `alpha` lies in [`ALPHA_MIN`] ..= [`ALPHA_MAX`], the smooth SAT's range. There every
//! kernel output is finite: the formula is algebraic (squares, square roots, divisions
//! by `d ≥ δ > 0` and by square roots of sums with `ε² > 0`), and its squares stay far
//! below overflow.
//!
//! ```
//! use cbfgen::sphere_box::{self, Smoothing, Sphere};
//! use cbfgen::OrientedBox;
//! use nalgebra::Vector3;
//! // A stair nosing, and a toe of radius 0.1 m 5 cm in front of its face.
//! let edge = OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(0.0125, 0.5, 0.0125))?;
//! let toe = Sphere::new(Vector3::new(0.1625, 0.0, 0.0), 0.1)?;
//! let exact = sphere_box::exact_distance(toe.center(), toe.radius(), &edge);
//! assert!((exact - 0.05).abs() < 1e-12);
//! let p = Smoothing::default();
//! let h = sphere_box::certified_clearance(&toe, &edge, &p);
//! assert!(h <= exact && exact - h <= sphere_box::conservatism(&p));
//! assert!(sphere_box::certified_separated(&toe, &edge, &p));
//! // 0.5 mm in front of the face: apart, but within the margin, so not certified.
//! let close = Sphere::new(Vector3::new(0.113, 0.0, 0.0), 0.1)?;
//! assert!(!sphere_box::certified_separated(&close, &edge, &p));
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use crate::error::{within, CbfError};
use crate::generated::sphere_box as gen;
use crate::geometry::{OrientedBox, MAX_COORDINATE, MAX_HALF_EXTENT};
use nalgebra::{Matrix3, Vector3};

pub use crate::ssat::{ALPHA_MAX, ALPHA_MIN};

const ALPHA_RANGE: &str = "[1e-6, 1e9]";
const COORDINATE_RANGE: &str = "[-1e6, 1e6] m";
const RADIUS_RANGE: &str = "[0, 1e4] m";

/// The certificate's rounding guard relative to the problem's scale `S` (see the
/// [module docs](self#rounding-guard)).
pub const ROUNDING_GUARD: f64 = 256.0 * f64::EPSILON;

/// The default sharpness, 1500 /m: a smoothing length of 0.67 mm and a certified margin
/// of 1.2 mm, the scale of a legged robot's feet and a step's edge. A system chooses its
/// own in its spec (Tachyon 3's is `toe_alpha` in `systems/tachyon3/spec/tachyon3.toml`).
pub const DEFAULT_ALPHA: f64 = 1500.0;

/// A sphere: centre in the world frame and radius, validated into the
/// [domain](self#domain).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    center: Vector3<f64>,
    radius: f64,
}

impl Sphere {
    /// # Errors
    /// [`CbfError::NonFinite`] for a NaN or infinite input, [`CbfError::OutOfRange`] for
    /// a centre coordinate beyond ±[`MAX_COORDINATE`] or a radius outside
    /// `[0, `[`MAX_HALF_EXTENT`]`]`.
    pub fn new(center: Vector3<f64>, radius: f64) -> Result<Self, CbfError> {
        for &c in center.iter() {
            within("sphere centre coordinate", c, -MAX_COORDINATE, MAX_COORDINATE, COORDINATE_RANGE)?;
        }
        within("sphere radius", radius, 0.0, MAX_HALF_EXTENT, RADIUS_RANGE)?;
        Ok(Self { center, radius })
    }

    /// Centre, world frame \[m\].
    pub fn center(&self) -> &Vector3<f64> {
        &self.center
    }

    /// Radius \[m\].
    pub fn radius(&self) -> f64 {
        self.radius
    }
}

/// The barrier's sharpness `alpha` \[1/m\], the inverse of its smoothing length `ε`:
/// larger is a smaller margin (`≈ 1.73/α`) but a more curved barrier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Smoothing {
    alpha: f64,
}

impl Smoothing {
    /// # Errors
    /// [`CbfError::NonFinite`] for NaN or ±∞, [`CbfError::OutOfRange`] outside
    /// [`ALPHA_MIN`] ..= [`ALPHA_MAX`].
    pub fn new(alpha: f64) -> Result<Self, CbfError> {
        Ok(Self { alpha: within("sphere-box alpha", alpha, ALPHA_MIN, ALPHA_MAX, ALPHA_RANGE)? })
    }

    /// Sharpness \[1/m\].
    pub fn alpha(&self) -> f64 {
        self.alpha
    }
}

impl Default for Smoothing {
    /// [`DEFAULT_ALPHA`].
    fn default() -> Self {
        Self { alpha: DEFAULT_ALPHA }
    }
}

/// The clearance with its gradient and Hessian with respect to the sphere's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearanceDerivatives {
    /// `h` \[m\].
    pub value: f64,
    /// `∂h/∂p`, world frame.
    pub gradient: Vector3<f64>,
    /// `∂²h/∂p²`, world frame, symmetric.
    pub hessian: Matrix3<f64>,
}

/// Exact signed distance between the sphere (`center`, `radius`) and the solid box `b`:
/// the gap between their surfaces when apart, negative when they overlap (minus the
/// depth of the centre inside the box, minus the radius, once the centre is inside).
///
/// Not validated, so it suits any caller: a NaN or infinite `center` or `radius`
/// gives NaN (never a finite answer).
pub fn exact_distance(center: &Vector3<f64>, radius: f64, b: &OrientedBox) -> f64 {
    if !(center.iter().all(|c| c.is_finite()) && radius.is_finite()) {
        return f64::NAN;
    }
    let local = b.rotation().inverse() * (center - b.center());
    let half = b.half_extents();
    // Per axis: how far the centre lies beyond the face pair (negative inside the slab).
    let beyond = Vector3::from_fn(|i, _| local[i].abs() - half[i]);
    let outside = beyond.map(|v| v.max(0.0)).norm();
    let inside = beyond.max().min(0.0);
    outside + inside - radius
}

/// The smooth clearance `h = d − r − m` (the generated kernel): `h ≥ 0` proves the
/// sphere and the box are apart in exact arithmetic; [`certified_clearance`] adds the
/// rounding guard. In metres; see the [module docs](self#certificate) for its bounds.
#[inline]
pub fn clearance(sphere: &Sphere, b: &OrientedBox, p: &Smoothing) -> f64 {
    let (c, r, a) = b.kernel_args();
    gen::certified_clearance(&sphere.center, &c, &r, &a, sphere.radius, p.alpha)
}

/// [`clearance`] with its gradient and Hessian with respect to the sphere's centre.
#[inline]
pub fn clearance_with_derivatives(sphere: &Sphere, b: &OrientedBox, p: &Smoothing) -> ClearanceDerivatives {
    let (c, r, a) = b.kernel_args();
    let (value, g, h) = gen::certified_clearance_derivatives(&sphere.center, &c, &r, &a, sphere.radius, p.alpha);
    ClearanceDerivatives { value, gradient: Vector3::from(g), hessian: Matrix3::from_fn(|i, j| h[i][j]) }
}

/// The certified margin `m = √3·ε + δ` that [`clearance`] already subtracts \[m\].
pub fn margin(p: &Smoothing) -> f64 {
    gen::certified_clearance_margin(p.alpha)
}

/// Upper bound on `exact_distance − clearance` while the sphere's centre is outside the
/// box: `m + √3·ε` \[m\].
pub fn conservatism(p: &Smoothing) -> f64 {
    gen::certified_clearance_conservatism(p.alpha)
}

/// [`clearance`] less the rounding guard [`ROUNDING_GUARD`]` · S`, `S = ‖p − c‖₁ + Σaᵢ +
/// r + |h| + m` (see the [module docs](self#rounding-guard)). `≥ 0` proves the sphere
/// does not reach into the box, rounding included; a lower bound on [`exact_distance`]
/// while the centre is outside the box.
pub fn certified_clearance(sphere: &Sphere, b: &OrientedBox, p: &Smoothing) -> f64 {
    let h = clearance(sphere, b, p);
    let m = margin(p);
    let scale = (sphere.center - b.center()).abs().sum() + b.half_extents().sum() + sphere.radius + h.abs() + m;
    h - ROUNDING_GUARD * scale
}

/// [`certified_clearance`] `≥ 0`: a proof that the sphere and the box do not overlap.
pub fn certified_separated(sphere: &Sphere, b: &OrientedBox, p: &Smoothing) -> bool {
    certified_clearance(sphere, b, p) >= 0.0
}
