//! RANSAC refits of a grown region (after Schnabel et al.): hypotheses from random
//! triples, the best plane by inliers, split into up to a few planes per region.

use super::plane_fit::{fit, Fit};
use nalgebra::Vector3;
use rand::Rng;

use super::{Cloud, Plane, SegmentSettings};

/// The inlier distance of a plane through `members`: three times the median scatter of
/// their neighbourhoods about their local planes, within \[a quarter, all\] of the
/// setting. The setting is for raw returns; averaged map voxels scatter a millimetre or
/// two, and a centimetre would let a plane tilted through the treads of a shallow flight
/// (a ramp) gather as many inliers as one tread.
pub(super) fn inlier_distance(cloud: &Cloud<'_>, members: &[usize], s: &SegmentSettings) -> f64 {
    let mut scatter: Vec<f64> = members.iter().map(|&i| cloud.scatter[i]).filter(|d| d.is_finite()).collect();
    if scatter.is_empty() {
        return s.ransac_distance;
    }
    let mid = scatter.len() / 2;
    let (_, median, _) = scatter.select_nth_unstable_by(mid, f64::total_cmp);
    (3.0 * *median).clamp(0.25 * s.ransac_distance, s.ransac_distance)
}

/// Fewest RANSAC hypotheses per plane.
pub(super) const MIN_HYPOTHESES: usize = 20;

/// Refits of a RANSAC plane on its connected inliers.
pub(super) const LOCAL_STEPS: usize = 2;

/// Most planes one region is split into.
pub(super) const MAX_PLANES_PER_REGION: usize = 8;

/// The planes of a region: RANSAC, then again on what the plane left, while enough is
/// left. A region can hold more than one plane: below a step lower than the neighbour
/// radius, the normals turn from floor to riser to tread in small steps, and growth runs
/// over the edge.
pub(super) fn refine(
    cloud: &Cloud<'_>,
    region: &[usize],
    s: &SegmentSettings,
    rng: &mut impl Rng,
) -> Vec<(Plane, Vec<usize>)> {
    let points = cloud.points;
    let distance = inlier_distance(cloud, region, s);
    let cos_max = s.max_normal_angle.cos();
    let mut planes: Vec<(Plane, Vec<usize>)> = Vec::new();
    let mut left = region.to_vec();
    let mut taken = vec![false; points.len()];
    let mut scratch = vec![0u8; points.len()];
    for _ in 0..MAX_PLANES_PER_REGION {
        if left.len() < s.min_plane_points {
            break;
        }
        let Some((plane, inliers)) = best_plane(cloud, &left, distance, s, rng, &mut scratch) else { break };
        for &i in &inliers {
            taken[i] = true;
        }
        // The plane's noise tails go with it: the points beyond the inlier distance but
        // within three of it, facing the same way. Left behind, they lie all over the
        // plane's area and let a later plane tilt through them.
        let tail = |i: usize| {
            plane.distance(&points[i]).abs() <= 3.0 * distance
                && cloud.normal[i].is_none_or(|(m, _)| m.dot(&plane.normal).abs() >= cos_max)
        };
        left.retain(|&i| !taken[i] && !tail(i));
        // What a plane leaves of its own noise (the tails beyond the inlier distance)
        // fits a parallel plane a noise width off: that is no plane of its own.
        let centroid = inliers.iter().map(|&i| points[i]).sum::<Vector3<f64>>() / inliers.len() as f64;
        let echo = planes.iter().any(|(p, _)| {
            p.normal.dot(&plane.normal).abs() >= cos_max && p.distance(&centroid).abs() <= 3.0 * s.ransac_distance
        });
        if !echo {
            planes.push((plane, inliers));
        }
    }
    planes
}

/// RANSAC over a region's points (MSAC scores, an adaptive stop), local refits on the
/// best plane's largest connected piece, and the oriented least-squares plane of its
/// inliers.
pub(super) fn best_plane(
    cloud: &Cloud<'_>,
    region: &[usize],
    distance: f64,
    s: &SegmentSettings,
    rng: &mut impl Rng,
    scratch: &mut [u8],
) -> Option<(Plane, Vec<usize>)> {
    let Cloud { points, normal, .. } = *cloud;
    let cos_max = s.max_normal_angle.cos();
    // An inlier lies near the plane and, where it has a normal, agrees with it: points of
    // a neighbouring face near the corner stay out (after Schnabel et al.).
    let fits = |n: &Vector3<f64>, d: f64, i: usize| {
        (n.dot(&points[i]) + d).abs() <= distance && normal[i].is_none_or(|(m, _)| m.dot(n).abs() >= cos_max)
    };
    // Hypotheses are scored on at most this many of the region's points, drawn once.
    const SCORED: usize = 2000;
    let scored: Vec<usize> = if region.len() <= SCORED {
        region.to_vec()
    } else {
        (0..SCORED).map(|_| region[rng.random_range(0..region.len())]).collect()
    };
    // MSAC (Torr and Zisserman): each point costs its squared distance, capped at the
    // inlier distance's square where it is no inlier. Counting inliers alone cannot tell
    // a tread from a plane tilted through it that picks up the foot of one riser and the
    // top of the next (under a neighbourhood radius, a low riser's points have normals
    // near vertical); the tread's points lie far closer to the level plane.
    let cap = distance * distance;
    let mut best: Option<(f64, Vector3<f64>, f64)> = None;
    // Hypotheses stop once one all-inlier draw was likely among them (99.9 %) for the
    // best inlier share seen, the local optimisation below doing the rest.
    let mut needed = s.ransac_iterations;
    for iteration in 0..s.ransac_iterations {
        if iteration >= needed.max(MIN_HYPOTHESES) {
            break;
        }
        let [a, b, c] = [0; 3].map(|_| points[region[rng.random_range(0..region.len())]]);
        let n = (b - a).cross(&(c - a));
        if n.norm() < 1e-9 {
            continue;
        }
        let n = n.normalize();
        let d = -n.dot(&a);
        let (mut cost, mut count) = (0.0, 0usize);
        for &i in &scored {
            if fits(&n, d, i) {
                cost += (n.dot(&points[i]) + d).powi(2);
                count += 1;
            } else {
                cost += cap;
            }
        }
        if best.is_none_or(|(k, _, _)| cost < k) {
            best = Some((cost, n, d));
            let share = count as f64 / scored.len() as f64;
            let miss = 1.0 - share.powi(3);
            if miss <= 0.0 {
                needed = 0;
            } else if miss < 1.0 {
                needed = (0.001f64.ln() / miss.ln()).ceil().min(s.ransac_iterations as f64) as usize;
            }
        }
    }
    let (_, mut n, mut d) = best?;
    // Local optimisation (after Chum et al.'s LO-RANSAC), on one connected piece
    // (Schnabel et al.): a plane's points are one surface. A plane tilted through a
    // tread and the far floor's noise tails has its inliers in separate pieces; the
    // largest piece, refitted, is the tread.
    for _ in 0..LOCAL_STEPS {
        let near: Vec<usize> = region.iter().copied().filter(|&i| fits(&n, d, i)).collect();
        let piece = cloud.largest_component(&near, scratch);
        if piece.len() < s.min_plane_points {
            break;
        }
        let refit = fit(points, cloud.weights, piece.iter().copied())?;
        (n, d) = (refit.normal, -refit.normal.dot(&refit.centroid));
    }
    let inliers: Vec<usize> = region.iter().copied().filter(|&i| fits(&n, d, i)).collect();
    if inliers.len() < s.min_plane_points {
        return None;
    }
    Some((plane_of(cloud, &inliers, s)?, inliers))
}

/// The least-squares plane of `inliers`, oriented; its hull is left for the end. The fit
/// leaves out points of high curvature: near a corner, points of the other face lie
/// within the inlier distance, and would tilt a narrow face such as a 16 cm riser.
pub(super) fn plane_of(cloud: &Cloud<'_>, inliers: &[usize], s: &SegmentSettings) -> Option<Plane> {
    let Cloud { points, weights, normal, .. } = *cloud;
    let flat = inliers.iter().copied().filter(|&i| normal[i].is_some_and(|(_, c)| c <= s.max_curvature));
    let Fit { centroid, mut normal, .. } = fit(points, weights, flat)?;
    // Orientation: up for floors and ceilings, towards the viewpoint for walls.
    let flip = if normal.z.abs() >= 0.5 { normal.z < 0.0 } else { normal.dot(&(s.viewpoint - centroid)) < 0.0 };
    if flip {
        normal = -normal;
    }
    let offset = -normal.dot(&centroid);
    Some(Plane { normal, offset, polygon: Vec::new(), inliers: inliers.len() })
}
