//! Exact (non-smooth) Separating Axis Theorem for two oriented boxes.
//!
//! This is the reference the smooth SAT is checked against, so it is written
//! independently of the symbolic stage, in the world frame, with unit axes.

use crate::geometry::OrientedBox;
use nalgebra::Vector3;

/// Cross axes shorter than this (edges within ~1e-6 rad of parallel) carry no
/// separating information: the face axes already decide those configurations.
const PARALLEL_EDGE_NORM: f64 = 1e-6;

/// Half the length of the box's projection onto the unit axis `n`.
fn projected_radius(b: &OrientedBox, n: &Vector3<f64>) -> f64 {
    let r = b.rotation().matrix();
    (0..3).map(|k| b.half_extents()[k] * n.dot(&r.column(k)).abs()).sum()
}

/// Signed separation along the unit axis `n`: > 0 is a gap, < 0 an overlap.
fn gap_along(a: &OrientedBox, b: &OrientedBox, n: &Vector3<f64>) -> f64 {
    (b.center() - a.center()).dot(n).abs() - projected_radius(a, n) - projected_radius(b, n)
}

/// The largest gap over the 15 candidate axes (6 face normals, 9 edge cross products,
/// all normalised). Positive: the boxes are separated by at least this distance.
/// Negative or zero: they overlap or touch, and minus the value is the smallest
/// translation along a candidate axis that would part them.
pub fn separation(a: &OrientedBox, b: &OrientedBox) -> f64 {
    separation_with_axis(a, b).0
}

/// [`separation`] and the unit candidate axis that gives it: the separating axis of
/// boxes apart, the direction of least overlap of boxes that overlap. Its sign is
/// arbitrary (an axis, not a normal).
pub fn separation_with_axis(a: &OrientedBox, b: &OrientedBox) -> (f64, Vector3<f64>) {
    let ra = a.rotation().matrix();
    let rb = b.rotation().matrix();
    let mut best = (f64::NEG_INFINITY, Vector3::z());
    let mut consider = |n: Vector3<f64>| {
        let gap = gap_along(a, b, &n);
        if gap > best.0 {
            best = (gap, n);
        }
    };
    for k in 0..3 {
        consider(ra.column(k).into_owned());
        consider(rb.column(k).into_owned());
    }
    for i in 0..3 {
        for j in 0..3 {
            let n = ra.column(i).cross(&rb.column(j));
            let norm = n.norm();
            if norm > PARALLEL_EDGE_NORM {
                consider(n / norm);
            }
        }
    }
    best
}

/// True if the boxes' interiors intersect (touching boxes do not overlap).
pub fn overlaps(a: &OrientedBox, b: &OrientedBox) -> bool {
    separation(a, b) < 0.0
}
