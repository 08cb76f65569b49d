//! Oriented boxes: the shapes the SAT and SSAT kernels take.
//!
//! # Domain
//! [`OrientedBox::new`] accepts centre coordinates within ±[`MAX_COORDINATE`], half
//! extents between [`MIN_HALF_EXTENT`] and [`MAX_HALF_EXTENT`], and rotations within
//! [`ROTATION_TOLERANCE`] of SO(3). The bounds keep every box resolvable in f64 wherever
//! it sits, and, with the α domain of [`SmoothParams`](crate::ssat::SmoothParams), keep
//! the smooth SAT's products `α·size` away from the two places its arithmetic breaks:
//!
//! * A coordinate of 10⁶ m is resolved to `ε·10⁶ ≈ 2.2e-10` m, so a 10⁻⁶ m half extent
//!   spans over 4 000 rounding steps of its own centre even at the edge of the domain,
//!   and the largest-to-smallest extent ratio, 10¹⁰, is far inside f64's 4.5·10¹⁵.
//! * With α ∈ [10⁻⁶, 10⁹] 1/m, `α·half extent ∈ [10⁻¹², 10¹³]`. Outside that band the
//!   unguarded test `h − m ≥ 0` was measured to certify overlapping pairs: below
//!   `α·size ≈ 2e-16` (near `ε·ln 15`) an overlap's `h − m` drowns in the rounding of the
//!   smooth max's `ln(15)/α` and reads 0; from `α·size ≈ 1e16` (near `1/ε`) the √
//!   variants' absolute margin `1/α` is smaller than the rounding of an extent. The band
//!   keeps three decades from both, and the certificate's rounding guard covers the rest
//!   (see [`ssat`](crate::ssat#rounding-guard)).
//! * 10⁴ m (a 20 km box) is larger than any obstacle a robot's safety filter meets and
//!   keeps the largest box well inside the coordinate domain.

use crate::error::{finite, positive, within, CbfError};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// How far from orthonormal (largest entry of `|RᵀR − I|`) a rotation may be and still be
/// accepted; [`OrientedBox::new`] stores such a rotation as its nearest proper rotation.
pub const ROTATION_TOLERANCE: f64 = 1e-9;

/// Rotations built in f64 (from a quaternion, Euler angles, products) are orthonormal to
/// a few ε; those are stored bit for bit, anything further off is projected.
const ORTHONORMAL_TO_ROUNDING: f64 = 8.0 * f64::EPSILON;

/// Largest accepted |centre coordinate|, in metres (see the [module docs](self#domain)).
pub const MAX_COORDINATE: f64 = 1e6;
const COORDINATE_RANGE: &str = "[-1e6, 1e6] m";

/// Smallest accepted half extent, in metres (see the [module docs](self#domain)).
pub const MIN_HALF_EXTENT: f64 = 1e-6;

/// Largest accepted half extent, in metres (see the [module docs](self#domain)).
pub const MAX_HALF_EXTENT: f64 = 1e4;
const HALF_EXTENT_RANGE: &str = "[1e-6, 1e4] m";

/// A box with a pose: centre and rotation in the world frame, half extents along its
/// own axes. Construction validates, so every `OrientedBox` is a real, finite box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    center: Vector3<f64>,
    rotation: Rotation3<f64>,
    half_extents: Vector3<f64>,
}

impl OrientedBox {
    /// A box centred at `center`, rotated by `rotation` (columns = the box's axes in the
    /// world frame), with `half_extents` along those axes.
    ///
    /// # Errors
    /// [`CbfError::NonFinite`] for a NaN or infinite input; [`CbfError::NotPositive`] for
    /// a half extent ≤ 0; [`CbfError::OutOfRange`] for a centre coordinate beyond
    /// ±[`MAX_COORDINATE`] or a half extent outside [`MIN_HALF_EXTENT`] ..=
    /// [`MAX_HALF_EXTENT`]; [`CbfError::NotARotation`] for a rotation further than
    /// [`ROTATION_TOLERANCE`] from orthonormal or with det < 0 (a reflection).
    ///
    /// A rotation that is accepted but further from orthonormal than rounding is stored
    /// as its nearest proper rotation: the SAT and SSAT kernels assume `RᵀR = I`, and a
    /// skew of 1e-9 would move a 10 km box's faces by ~1e-5 m, far more than the smooth
    /// SAT's certified margin at large α. So every `OrientedBox` is a box, and the one
    /// both kernels see.
    ///
    /// ```
    /// use cbfgen::OrientedBox;
    /// use nalgebra::{Rotation3, Vector3};
    /// let body = OrientedBox::new(Vector3::new(0.0, 0.0, 0.3),
    ///                             Rotation3::from_euler_angles(0.0, 0.1, 0.0),
    ///                             Vector3::new(0.45, 0.25, 0.1))?;
    /// assert_eq!(body.half_extents().x, 0.45);
    /// # Ok::<(), cbfgen::CbfError>(())
    /// ```
    pub fn new(center: Vector3<f64>, rotation: Rotation3<f64>, half_extents: Vector3<f64>) -> Result<Self, CbfError> {
        for &c in center.iter() {
            within("box centre coordinate", c, -MAX_COORDINATE, MAX_COORDINATE, COORDINATE_RANGE)?;
        }
        for &h in half_extents.iter() {
            positive("box half extent", h)?;
            within("box half extent", h, MIN_HALF_EXTENT, MAX_HALF_EXTENT, HALF_EXTENT_RANGE)?;
        }
        let m = rotation.matrix();
        for &r in m.iter() {
            finite("rotation entry", r)?;
        }
        let deviation = orthonormality_error(m);
        if deviation > ROTATION_TOLERANCE || m.determinant() < 0.0 {
            return Err(CbfError::NotARotation { deviation, determinant: m.determinant() });
        }
        let rotation = if deviation > ORTHONORMAL_TO_ROUNDING {
            Rotation3::from_matrix_unchecked(nearest_rotation(*m))
        } else {
            rotation
        };
        Ok(Self { center, rotation, half_extents })
    }

    /// An axis-aligned box.
    pub fn axis_aligned(center: Vector3<f64>, half_extents: Vector3<f64>) -> Result<Self, CbfError> {
        Self::new(center, Rotation3::identity(), half_extents)
    }

    /// Centre, world frame \[m\].
    pub fn center(&self) -> &Vector3<f64> {
        &self.center
    }

    /// Orientation: its columns are the box's axes in the world frame (a proper rotation,
    /// orthonormal to rounding).
    pub fn rotation(&self) -> &Rotation3<f64> {
        &self.rotation
    }

    /// Half extents along the box's own axes \[m\].
    pub fn half_extents(&self) -> &Vector3<f64> {
        &self.half_extents
    }

    /// The same box moved to `center` (validated like [`OrientedBox::new`]).
    pub fn with_center(&self, center: Vector3<f64>) -> Result<Self, CbfError> {
        Self::new(center, self.rotation, self.half_extents)
    }

    /// (centre, rotation matrix, half extents): the arguments every generated kernel takes
    /// for a box, in the types generated `Params` hold them in.
    pub fn kernel_args(&self) -> (Vector3<f64>, Matrix3<f64>, Vector3<f64>) {
        (self.center, *self.rotation.matrix(), self.half_extents)
    }
}

/// Largest entry of `|MᵀM − I|`.
fn orthonormality_error(m: &Matrix3<f64>) -> f64 {
    (m.transpose() * m - Matrix3::identity()).abs().max()
}

/// The orthogonal polar factor of `m` (its nearest orthogonal matrix, a rotation for
/// det > 0) by Newton–Schulz steps `X ← X (3I − XᵀX) / 2`. They converge quadratically:
/// from the 1e-9 of [`ROTATION_TOLERANCE`], one step reaches rounding.
fn nearest_rotation(m: Matrix3<f64>) -> Matrix3<f64> {
    let mut x = m;
    for _ in 0..3 {
        if orthonormality_error(&x) <= ORTHONORMAL_TO_ROUNDING {
            break;
        }
        x = x * (Matrix3::identity() * 3.0 - x.transpose() * x) * 0.5;
    }
    x
}
