//! Oriented boxes: the shapes the SAT and SSAT kernels take.

use crate::error::{finite, positive, CbfError};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// How far from orthonormal a rotation may be and still be accepted.
pub const ROTATION_TOLERANCE: f64 = 1e-9;

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
    /// Non-finite centre or rotation, half extents that are not strictly positive, or a
    /// rotation further than [`ROTATION_TOLERANCE`] from orthonormal with det +1.
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
    pub fn new(
        center: Vector3<f64>,
        rotation: Rotation3<f64>,
        half_extents: Vector3<f64>,
    ) -> Result<Self, CbfError> {
        for &c in center.iter() {
            finite("box centre", c)?;
        }
        for &h in half_extents.iter() {
            positive("box half extent", h)?;
        }
        let m = rotation.matrix();
        for &r in m.iter() {
            finite("rotation entry", r)?;
        }
        let deviation = (m.transpose() * m - Matrix3::identity()).abs().max();
        if deviation > ROTATION_TOLERANCE || m.determinant() < 0.0 {
            return Err(CbfError::NotARotation { deviation, determinant: m.determinant() });
        }
        Ok(Self { center, rotation, half_extents })
    }

    /// An axis-aligned box.
    pub fn axis_aligned(center: Vector3<f64>, half_extents: Vector3<f64>) -> Result<Self, CbfError> {
        Self::new(center, Rotation3::identity(), half_extents)
    }

    pub fn center(&self) -> &Vector3<f64> {
        &self.center
    }

    pub fn rotation(&self) -> &Rotation3<f64> {
        &self.rotation
    }

    pub fn half_extents(&self) -> &Vector3<f64> {
        &self.half_extents
    }

    /// The same box moved to `center` (validated like [`OrientedBox::new`]).
    pub fn with_center(&self, center: Vector3<f64>) -> Result<Self, CbfError> {
        Self::new(center, self.rotation, self.half_extents)
    }

    /// Arguments in the layout the generated kernels take.
    pub(crate) fn kernel_args(&self) -> ([f64; 3], [f64; 9], [f64; 3]) {
        let m = self.rotation.matrix();
        (
            [self.center.x, self.center.y, self.center.z],
            [m[(0, 0)], m[(0, 1)], m[(0, 2)], m[(1, 0)], m[(1, 1)], m[(1, 2)], m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            [self.half_extents.x, self.half_extents.y, self.half_extents.z],
        )
    }
}
