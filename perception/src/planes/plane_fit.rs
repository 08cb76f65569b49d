//! Least-squares plane fits: a weighted centroid and covariance, its eigenvalues, and the
//! normal as the covariance's null direction.

use nalgebra::{Matrix3, Vector3};

/// A least-squares plane: where it passes, which way it faces, how far the points bend
/// away from it, and how far they scatter about it.
pub(super) struct Fit {
    pub(super) centroid: Vector3<f64>,
    pub(super) normal: Vector3<f64>,
    /// The smallest eigenvalue of the scatter over their sum.
    pub(super) curvature: f64,
    /// Weighted mean square distance of the points from the plane \[m²\].
    pub(super) variance: f64,
}

/// Weighted least-squares plane through `points[idx]`, or `None` when they span no plane
/// (fewer than three, or all on one point or one line). One pass: the sums are taken
/// about the first point, which keeps them as well conditioned as about the centroid for
/// a neighbourhood, and the scatter is their second moment less the mean's.
pub(super) fn fit(points: &[Vector3<f64>], weights: &[f64], idx: impl Iterator<Item = usize>) -> Option<Fit> {
    let mut idx = idx.peekable();
    let origin = points[*idx.peek()?];
    let (mut count, mut total_weight) = (0usize, 0.0);
    let (mut first, mut second) = (Vector3::zeros(), Matrix3::zeros());
    for i in idx {
        let (d, w) = (points[i] - origin, weights[i]);
        count += 1;
        total_weight += w;
        first += d * w;
        second += d * d.transpose() * w;
    }
    if count < 3 {
        return None;
    }
    let mean = first / total_weight;
    let cov = second - mean * first.transpose();
    let centroid = origin + mean;
    let [smallest, middle, largest] = symmetric_eigenvalues(&cov);
    let total = smallest + middle + largest;
    if total.is_nan() || total <= 1e-18 {
        return None;
    }
    // A line of points has two vanishing eigenvalues: no plane.
    if middle < 1e-9 * total {
        return None;
    }
    let normal = null_direction(&(cov - Matrix3::identity() * smallest))?;
    Some(Fit { centroid, normal, curvature: smallest.max(0.0) / total, variance: smallest.max(0.0) / total_weight })
}

/// Eigenvalues of a symmetric 3×3 matrix, ascending, in closed form (the trigonometric
/// solution of the characteristic cubic): an iterative decomposition per point was most
/// of the normals' cost.
pub(super) fn symmetric_eigenvalues(a: &Matrix3<f64>) -> [f64; 3] {
    let off = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    let q = a.trace() / 3.0;
    let spread = (a[(0, 0)] - q).powi(2) + (a[(1, 1)] - q).powi(2) + (a[(2, 2)] - q).powi(2) + 2.0 * off;
    if spread <= f64::MIN_POSITIVE {
        return [q; 3];
    }
    let p = (spread / 6.0).sqrt();
    let r = ((a - Matrix3::identity() * q) / p).determinant() / 2.0;
    let phi = r.clamp(-1.0, 1.0).acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    [smallest, 3.0 * q - largest - smallest, largest]
}

/// A unit vector `m` maps to (nearly) zero, for `m` of rank two: the longest cross
/// product of two of its rows, which are all perpendicular to that direction.
pub(super) fn null_direction(m: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let rows = [m.row(0).transpose(), m.row(1).transpose(), m.row(2).transpose()];
    let best = [rows[0].cross(&rows[1]), rows[0].cross(&rows[2]), rows[1].cross(&rows[2])]
        .into_iter()
        .max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))?;
    let norm = best.norm();
    (norm > 0.0 && norm.is_finite()).then(|| best / norm)
}
