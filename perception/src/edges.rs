//! Edge cuboids from planes: one along each hull edge of an upward-facing plane where the
//! terrain drops beyond it to a lower plane that was seen there (a step's nosing), tucked
//! into the corner as the filter's edge cuboids are; and the floor height under a point.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::planes::Plane;
use cbfgen::error::{within, CbfError};
use cbfgen::geometry::OrientedBox;

/// What makes a hull edge a nosing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeSettings {
    /// Largest tilt of a plane that counts as a floor or tread \[rad\].
    pub max_tilt: f64,
    /// Shortest edge that gets a cuboid \[m\].
    pub min_length: f64,
    /// Smallest drop to the plane beyond the edge \[m\].
    pub min_drop: f64,
    /// How far beyond the edge the lower plane is looked for \[m\].
    pub probe: f64,
    /// Half side of the cuboid's square section \[m\].
    pub half_section: f64,
    /// A hull vertex within this of the chord of its neighbours' run is inside one
    /// straight edge \[m\]: a noisy nosing's hull is many short, nearly collinear
    /// segments.
    pub straightness: f64,
    /// Fewest points per metre that must lie on the plane along an edge (within
    /// `2 · half_section` of it): a hull chord across a sparsely seen corner is no edge.
    pub min_support: f64,
    /// The sensor, if known. Beyond an edge on the far side of the plane from it (a
    /// platform's far side), the edge's own shadow hides the floor next to the drop:
    /// the lower plane is then also looked for where the shadow from this point would
    /// end, within `shadow` of it.
    pub viewpoint: Option<Vector3<f64>>,
    /// Depth of the strip past the shadow's expected end (from half its length) in
    /// which the lower plane is looked for \[m\].
    pub shadow: f64,
}

impl Default for EdgeSettings {
    /// Treads within 10° of level, edges of 10 cm or more (hull wiggles under 3 cm merged),
    /// drops of 4 cm or more looked for 8 cm beyond the edge (no viewpoint: no shadow
    /// search), 2.5 cm half sections (Tachyon 3's stairs).
    fn default() -> Self {
        Self {
            max_tilt: 10f64.to_radians(),
            min_length: 0.1,
            min_drop: 0.04,
            probe: 0.08,
            half_section: 0.025,
            straightness: 0.03,
            min_support: 100.0,
            viewpoint: None,
            shadow: 0.6,
        }
    }
}

impl EdgeSettings {
    /// `Ok` when every setting is usable.
    ///
    /// # Errors
    /// A setting outside its domain, named.
    pub fn validate(&self) -> Result<(), CbfError> {
        within("max tilt [rad]", self.max_tilt, 0.0, std::f64::consts::FRAC_PI_2, "[0, pi/2]")?;
        within("min edge length [m]", self.min_length, 0.0, 100.0, "[0, 100]")?;
        within("min drop [m]", self.min_drop, 0.0, 100.0, "[0, 100]")?;
        within("probe [m]", self.probe, 1e-4, 10.0, "[1e-4, 10]")?;
        within("edge half section [m]", self.half_section, 1e-4, 1.0, "[1e-4, 1]")?;
        within("straightness [m]", self.straightness, 0.0, 1.0, "[0, 1]")?;
        within("min support [1/m]", self.min_support, 0.0, 1e9, "[0, 1e9]")?;
        within("shadow [m]", self.shadow, 0.0, 100.0, "[0, 100]")?;
        for &c in self.viewpoint.iter().flatten() {
            within("edge viewpoint [m]", c, -1e5, 1e5, "[-1e5, 1e5]")?;
        }
        Ok(())
    }
}

/// Fewest points of the lower plane that must lie around the probe beyond an edge.
const MIN_SEEN_BELOW: usize = 5;

fn is_level(p: &Plane, s: &EdgeSettings) -> bool {
    p.normal.z >= s.max_tilt.cos() && p.polygon.len() >= 3
}

/// Height of the highest level plane over `(x, y)` other than `skip`, if any.
pub fn floor_height(planes: &[Plane], x: f64, y: f64, max_tilt: f64, skip: Option<usize>) -> Option<f64> {
    let probe = Vector3::new(x, y, 0.0);
    planes
        .iter()
        .enumerate()
        .filter(|&(k, p)| Some(k) != skip && p.normal.z >= max_tilt.cos() && p.covers_xy(&probe))
        .map(|(_, p)| p.height_at(x, y))
        .max_by(f64::total_cmp)
}

/// The straight edges of a closed counter-clockwise polygon: Douglas–Peucker with
/// tolerance `tol`, so a vertex stays only where the outline leaves the chord by more than
/// `tol`; each edge then moved out to the mean offset of the vertices it stands for.
fn straight_edges(polygon: &[Vector3<f64>], tol: f64) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let n = polygon.len();
    if n < 3 {
        return Vec::new();
    }
    // Split the closed outline at its two farthest-apart vertices.
    let (a, b) = (0..n)
        .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
        .max_by(|&(i, j), &(k, l)| {
            (polygon[i] - polygon[j]).norm_squared().total_cmp(&(polygon[k] - polygon[l]).norm_squared())
        })
        .unwrap_or((0, n / 2));
    let mut keep = vec![false; n];
    keep[a] = true;
    keep[b] = true;
    let mut stack = vec![(a, b), (b, a + n)];
    while let Some((i, j)) = stack.pop() {
        let (p, q) = (polygon[i % n], polygon[j % n]);
        let chord = q - p;
        let far = (i + 1..j)
            .map(|k| (k, (polygon[k % n] - p).cross(&chord).norm() / chord.norm().max(f64::MIN_POSITIVE)))
            .max_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((k, _)) = far.filter(|&(_, d)| d > tol) {
            keep[k % n] = true;
            stack.push((i, k));
            stack.push((k, j));
        }
    }
    // Each kept chord, moved out to the mean offset of the hull vertices it stands for
    // (ends included): the chord cuts inside the hull by up to `tol`, while the single
    // outermost vertex is as likely an outlier as the edge.
    let kept: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
    (0..kept.len())
        .map(|k| {
            let (i, j) = (kept[k], kept[(k + 1) % kept.len()]);
            let (p, q) = (polygon[i], polygon[j]);
            let along = (q - p).normalize();
            let outward = Vector3::new(along.y, -along.x, 0.0);
            let run = if j > i { j - i } else { j + n - i };
            let out = (0..=run).map(|m| (polygon[(i + m) % n] - p).dot(&outward)).sum::<f64>() / (run + 1) as f64;
            let out = out.max(0.0);
            (p + outward * out, q + outward * out)
        })
        .collect()
}

/// Points of `points` on `plane` (within `band`) and within `band` of the segment `a`–`b`.
fn support(points: &[Vector3<f64>], plane: &Plane, a: &Vector3<f64>, b: &Vector3<f64>, band: f64) -> usize {
    let ab = b - a;
    let len2 = ab.norm_squared();
    // The segment's box, grown by the band, turns most points away in six comparisons.
    let (lo, hi) = (a.inf(b).add_scalar(-band), a.sup(b).add_scalar(band));
    points
        .iter()
        .filter(|p| {
            (0..3).all(|c| p[c] >= lo[c] && p[c] <= hi[c]) && plane.distance(p).abs() <= band && {
                let t = ((*p - a).dot(&ab) / len2).clamp(0.0, 1.0);
                (*p - (a + ab * t)).norm() <= band
            }
        })
        .count()
}

/// The edge cuboids of `planes`, found in `points` (the cloud they were segmented from,
/// which says how well each hull edge is supported). Each cuboid's local x runs along its
/// edge (level), its local y points into the plane above the edge (away from the drop)
/// and its local z up.
///
/// # Errors
/// Invalid settings.
pub fn edge_cuboids(planes: &[Plane], points: &[Vector3<f64>], s: &EdgeSettings) -> Result<Vec<OrientedBox>, CbfError> {
    Ok(found_edges(planes, points, s)?.into_iter().map(|e| e.cuboid).collect())
}

/// An edge found in the planes: its cuboid and the level below its drop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoundEdge {
    /// The cuboid along the edge, as [`edge_cuboids`] gives it.
    pub cuboid: OrientedBox,
    /// Height of the plane seen beyond the drop, below the edge \[m\]: where the riser
    /// under the edge ends.
    pub lower: f64,
}

/// [`edge_cuboids`], each with the height of the level below its drop.
///
/// # Errors
/// Invalid settings.
pub fn found_edges(planes: &[Plane], points: &[Vector3<f64>], s: &EdgeSettings) -> Result<Vec<FoundEdge>, CbfError> {
    s.validate()?;
    let mut out = Vec::new();
    for (k, plane) in planes.iter().enumerate().filter(|(_, p)| is_level(p, s)) {
        for (a, b) in straight_edges(&plane.polygon, s.straightness) {
            let along = b - a;
            let length = along.norm();
            if length < s.min_length {
                continue;
            }
            let axis = along / length;
            // The polygon is counter-clockwise seen from above: outward is to the right.
            let outward = Vector3::new(axis.y, -axis.x, 0.0).normalize();
            let mid = (a + b) / 2.0;
            let probe = mid + outward * s.probe;
            let Some(lower) = floor_height(planes, probe.x, probe.y, s.max_tilt, Some(k)) else { continue };
            let top = plane.height_at(mid.x, mid.y);
            if top - lower < s.min_drop
                || (support(points, plane, &a, &b, 2.0 * s.half_section) as f64) < s.min_support * length
            {
                continue;
            }
            // The lower side must have been seen beyond the edge: beyond a hull chord
            // across a sparsely scanned corner, the floor is hidden under the plane
            // itself. It is looked for at three points along the edge (a wheel in front of
            // the sensor shades a strip of floor, which may be the middle), next to the
            // edge or, for a drop on the far side from the viewpoint, where the edge's
            // shadow from it ends.
            let shadow = s.viewpoint.filter(|v| v.z > top && (mid - v).dot(&outward) > 0.0).map(|v| {
                let behind = (mid - v).dot(&outward);
                0.5 * behind * (top - lower) / (v.z - top)
            });
            // Every probe below lies within `reach` of the edge: one pass gathers the
            // lower plane's points there, and the probes count among those.
            let reach = shadow.map_or(2.0 * s.probe, |from| (2.0 * s.probe).max(from + s.shadow)) + s.probe;
            let (lo, hi) = (a.inf(&b).xy().add_scalar(-reach), a.sup(&b).xy().add_scalar(reach));
            let below: Vec<Vector3<f64>> = points
                .iter()
                .filter(|p| {
                    (p.z - lower).abs() <= s.half_section && p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y
                })
                .copied()
                .collect();
            let seen_below = [0.25, 0.5, 0.75]
                .into_iter()
                .map(|f| {
                    let at = a + (b - a) * f;
                    let beyond = at + outward * s.probe;
                    let near = below.iter().filter(|p| (p.xy() - beyond.xy()).norm() <= s.probe).count();
                    let far = |from: f64| {
                        below
                            .iter()
                            .filter(|p| {
                                let d = *p - at;
                                let out = d.dot(&outward);
                                let across = (d - outward * out).xy().norm();
                                out > from && out <= from + s.shadow && across <= s.probe
                            })
                            .count()
                    };
                    if near >= MIN_SEEN_BELOW {
                        near
                    } else {
                        shadow.map_or(near, far)
                    }
                })
                .max()
                .unwrap_or(0);
            if seen_below < MIN_SEEN_BELOW {
                continue;
            }
            let h = s.half_section;
            let center = Vector3::new(mid.x, mid.y, top) - outward * h - Vector3::z() * h;
            // The cuboid's long axis along the edge, levelled; its y axis into the plane
            // above (away from the drop), as `edge_cuboids` documents; its section square.
            let x_axis = Vector3::new(axis.x, axis.y, 0.0).normalize();
            let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
                x_axis,
                Vector3::z().cross(&x_axis),
                Vector3::z(),
            ]));
            out.push(FoundEdge {
                cuboid: OrientedBox::new(center, rotation, Vector3::new(length / 2.0, h, h))?,
                lower,
            });
        }
    }
    Ok(out)
}
