//! The Tachyon 3 paper's Fig. 6 scene: the 2-D SAT collision boundary, drawn from the
//! 3-D SSAT kernels.
//!
//! Box A is fixed at the origin; box B, yawed 10°, moves in the XY plane. Both are prisms
//! [`HALF_HEIGHT`] tall about the same z centre, so the 3-D SAT reduces to the 2-D one:
//! the z face axis and the four edge–edge axes that point along z read at least
//! `0.17·2·HALF_HEIGHT` of overlap, far below the in-plane axes, and the four edge–edge
//! axes of an in-plane edge with a z edge are the in-plane face normals again. So the
//! kernel's 15 axes are the 2-D SAT's four face normals, each twice, and the z-axis
//! ones, which weigh `exp(−α·7 m)` or less in the smooth max. The duplicates leave the
//! Boltzmann operator (a weighted mean) unchanged and raise log-sum-exp by `ln 2/α`: the
//! LSE curve drawn is the 2-D LSE's level set `h₂ = −ln 2/α`, a level set of the same
//! function, not a different shape.
//!
//! A boundary point is where `h` changes sign on a ray from A's centre, found by a scan
//! outward and bisection ([`boundary`]); [`sign_changes`] counts the crossings on a ray,
//! to check that the first crossing is the only one.

use cbfgen::OrientedBox;
use nalgebra::{Rotation3, Vector3};
use std::f64::consts::PI;

/// Box A's half extents in the plane \[m\].
pub const HALF_A: (f64, f64) = (0.6, 0.4);
/// Box B's half extents in the plane \[m\].
pub const HALF_B: (f64, f64) = (0.3, 0.2);
/// Box B's yaw, the paper's 10°.
pub const YAW_B_DEG: f64 = 10.0;
/// Both prisms' half height \[m\]: tall enough that the z axes weigh nothing (see the
/// module docs).
pub const HALF_HEIGHT: f64 = 20.0;
/// Rays are scanned out to this distance from A's centre \[m\].
pub const R_MAX: f64 = 5.0;

/// Box A, fixed at the origin.
pub fn box_a() -> OrientedBox {
    OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(HALF_A.0, HALF_A.1, HALF_HEIGHT))
        .expect("fixed sizes are valid")
}

/// Box B with its centre at `(x, y, 0)`.
pub fn box_b(x: f64, y: f64) -> OrientedBox {
    OrientedBox::new(
        Vector3::new(x, y, 0.0),
        Rotation3::from_axis_angle(&Vector3::z_axis(), YAW_B_DEG.to_radians()),
        Vector3::new(HALF_B.0, HALF_B.1, HALF_HEIGHT),
    )
    .expect("fixed sizes are valid")
}

/// The value of `h(A, B)` along the ray at angle `theta` from A's centre, at distance `r`.
fn on_ray(h: &impl Fn(&OrientedBox, &OrientedBox) -> f64, a: &OrientedBox, theta: f64, r: f64) -> f64 {
    h(a, &box_b(r * theta.cos(), r * theta.sin()))
}

/// Scan steps per ray, out to [`R_MAX`]: 2.5 mm apart.
pub const SCAN: usize = 2000;

/// Times `h` changes sign on the ray at angle `theta`, sampled at [`SCAN`] points out to
/// [`R_MAX`].
pub fn sign_changes(h: impl Fn(&OrientedBox, &OrientedBox) -> f64, theta: f64) -> usize {
    let a = box_a();
    let signs: Vec<bool> = (0..=SCAN).map(|k| on_ray(&h, &a, theta, R_MAX * k as f64 / SCAN as f64) >= 0.0).collect();
    signs.windows(2).filter(|w| w[0] != w[1]).count()
}

/// B's centre positions where `h` first turns non-negative on `rays` rays evenly spread
/// over the full turn, in order of angle: the boundary as a closed polygon (last point
/// not repeated).
///
/// # Panics
/// If `h` is not negative at A's centre or not non-negative at [`R_MAX`] on some ray:
/// then there is no collision boundary to trace.
pub fn boundary(h: impl Fn(&OrientedBox, &OrientedBox) -> f64, rays: usize) -> Vec<(f64, f64)> {
    let a = box_a();
    (0..rays)
        .map(|k| {
            let theta = 2.0 * PI * k as f64 / rays as f64;
            let f = |r: f64| on_ray(&h, &a, theta, r);
            assert!(f(0.0) < 0.0, "h ≥ 0 with the centres together");
            // The first sample at or above zero brackets the first crossing.
            let step = R_MAX / SCAN as f64;
            let k = (1..=SCAN).find(|&k| f(step * k as f64) >= 0.0).expect("h < 0 out to R_MAX");
            let (mut lo, mut hi) = (step * (k - 1) as f64, step * k as f64);
            while hi - lo > 1e-12 {
                let mid = 0.5 * (lo + hi);
                if f(mid) >= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            (hi * theta.cos(), hi * theta.sin())
        })
        .collect()
}

/// The signed turn at each vertex of the closed polygon `p`, the sine of the angle between
/// the edges in and out: all of one sign for a convex polygon (positive when
/// counter-clockwise).
pub fn turns(p: &[(f64, f64)]) -> Vec<f64> {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b, c) = (p[(i + n - 1) % n], p[i], p[(i + 1) % n]);
            let (e, f) = ((b.0 - a.0, b.1 - a.1), (c.0 - b.0, c.1 - b.1));
            (e.0 * f.1 - e.1 * f.0) / (e.0.hypot(e.1) * f.0.hypot(f.1))
        })
        .collect()
}
