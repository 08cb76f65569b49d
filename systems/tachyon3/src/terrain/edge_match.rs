//! Perceived edge cuboids held against the terrain's true ones: for each true nosing, the
//! found cuboid whose axis passes closest to its centre, how far off and how skewed.

use nalgebra::Vector3;

use cbfgen::geometry::OrientedBox;

/// A found cuboid's axis farther than this from a true nosing's centre \[m\] is not its.
pub const MATCH_DISTANCE: f64 = 0.05;

/// The found cuboid matched to one true nosing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeMatch {
    /// Index of the cuboid among those found.
    pub found: usize,
    /// Distance from the true nosing's centre to the found cuboid's axis \[m\].
    pub offset: f64,
    /// Angle between the found axis and the nosing's line (y) \[deg\], 0 to 90.
    pub skew_deg: f64,
    /// The found cuboid's length along its axis \[m\].
    pub length: f64,
}

/// For each of `truth` (nosings along y), the cuboid of `found` (axis along its local x)
/// whose axis passes closest to the nosing's centre, if within [`MATCH_DISTANCE`].
pub fn match_nosings(truth: &[OrientedBox], found: &[OrientedBox]) -> Vec<Option<EdgeMatch>> {
    let axis = |c: &OrientedBox| c.rotation().matrix().column(0).into_owned();
    truth
        .iter()
        .map(|nosing| {
            let (index, offset) = found
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    let d = nosing.center() - c.center();
                    (k, (d - axis(c) * d.dot(&axis(c))).norm())
                })
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            let cuboid = &found[index];
            let along = axis(cuboid);
            (offset < MATCH_DISTANCE).then(|| EdgeMatch {
                found: index,
                offset,
                skew_deg: along.angle(&Vector3::y()).min(along.angle(&-Vector3::y())).to_degrees(),
                length: 2.0 * cuboid.half_extents().x,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    #[test]
    fn each_nosing_gets_the_cuboid_whose_axis_passes_nearest() {
        let half = Vector3::new(0.02, 1.0, 0.02);
        let truth = [
            OrientedBox::axis_aligned(Vector3::new(0.3, 0.0, 0.15), half).unwrap(),
            OrientedBox::axis_aligned(Vector3::new(0.65, 0.0, 0.3), half).unwrap(),
        ];
        // Found cuboids run along their local x: turned 90° about z to lie along y. The
        // first sits 1 cm behind nosing 0 and 3° off y; the second is far from both.
        let along_y = |deg: f64| Rotation3::from_axis_angle(&Vector3::z_axis(), (90.0 + deg).to_radians());
        let found = [
            OrientedBox::new(Vector3::new(2.0, 0.0, 0.3), along_y(0.0), Vector3::new(0.8, 0.02, 0.02)).unwrap(),
            OrientedBox::new(Vector3::new(0.29, 0.4, 0.15), along_y(3.0), Vector3::new(0.9, 0.02, 0.02)).unwrap(),
        ];
        let matched = match_nosings(&truth, &found);
        let m = matched[0].expect("nosing 0 is matched");
        assert_eq!(m.found, 1);
        // The axis through (0.29, 0.4) at 93° from x passes the nosing's centre at
        // |(0.01, −0.4)·n| with n the axis's normal (cos 3°, sin 3°)... in the plane.
        let n = Vector3::new(3f64.to_radians().cos(), 3f64.to_radians().sin(), 0.0);
        let expected = (Vector3::new(0.3 - 0.29, -0.4, 0.0)).dot(&n).abs();
        assert!((m.offset - expected).abs() < 1e-12, "{} vs {expected}", m.offset);
        assert!((m.skew_deg - 3.0).abs() < 1e-9 && (m.length - 1.8).abs() < 1e-12, "{m:?}");
        assert_eq!(matched[1], None, "nothing within 5 cm of nosing 1");
    }
}
