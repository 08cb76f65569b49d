//! The convex hull of a plane's inliers (Andrew's monotone chain, in the plane), and its
//! edges moved inward by a margin.

use nalgebra::{Vector2, Vector3};

/// The half-spaces `inward · p >= limit` of a convex polygon's edges (counter-clockwise
/// seen against `normal`), each moved in by its margin; edges of no margin are left out.
pub(super) fn shrunk_edges(
    polygon: &[Vector3<f64>],
    margins: &[f64],
    normal: &Vector3<f64>,
) -> Vec<(Vector3<f64>, f64)> {
    let n = polygon.len();
    (0..n)
        .filter(|&k| margins[k] > 0.0)
        .filter_map(|k| {
            let (a, b) = (polygon[k], polygon[(k + 1) % n]);
            let inward = normal.cross(&(b - a)).try_normalize(0.0)?;
            Some((inward, inward.dot(&a) + margins[k]))
        })
        .collect()
}

/// Convex hull (Andrew's monotone chain) of the inliers projected onto the plane,
/// counter-clockwise seen against the normal.
pub(super) fn hull(
    points: &[Vector3<f64>],
    inliers: &[usize],
    normal: &Vector3<f64>,
    centroid: &Vector3<f64>,
) -> Vec<Vector3<f64>> {
    let u = normal.cross(&(if normal.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() })).normalize();
    let v = normal.cross(&u);
    let mut flat: Vec<Vector2<f64>> =
        inliers.iter().map(|&i| points[i] - centroid).map(|d| Vector2::new(d.dot(&u), d.dot(&v))).collect();
    drop_interior(&mut flat);
    // (u, v, n) is right-handed, so counter-clockwise in (u, v) is counter-clockwise
    // seen against the normal.
    monotone_chain(flat).into_iter().map(|q| centroid + u * q.x + v * q.y).collect()
}

/// The convex hull's vertices, counter-clockwise from the lowest-x point, without
/// collinear ones (Andrew's monotone chain).
pub(super) fn monotone_chain(mut flat: Vec<Vector2<f64>>) -> Vec<Vector2<f64>> {
    flat.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    flat.dedup();
    let cross = |o: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>| (a - o).perp(&(b - o));
    let mut chain: Vec<Vector2<f64>> = Vec::with_capacity(2 * flat.len());
    for pass in [&flat[..], &flat.iter().rev().copied().collect::<Vec<_>>()[..]] {
        let start = chain.len();
        for p in pass {
            while chain.len() >= start + 2 && cross(&chain[chain.len() - 2], &chain[chain.len() - 1], p) <= 0.0 {
                chain.pop();
            }
            chain.push(*p);
        }
        chain.pop();
    }
    chain
}

/// Leaves out the points well inside the octagon of the extreme points in eight
/// directions (Akl and Toussaint), which are no hull vertices: most of a large face's
/// points, which the hull's sort then need not order.
pub(super) fn drop_interior(flat: &mut Vec<Vector2<f64>>) {
    if flat.len() < 64 {
        return;
    }
    let directions =
        [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (-1.0, 1.0), (-1.0, 0.0), (-1.0, -1.0), (0.0, -1.0), (1.0, -1.0)];
    let mut octagon: Vec<Vector2<f64>> = directions
        .iter()
        .map(|&(a, b)| {
            let score = |p: &Vector2<f64>| a * p.x + b * p.y;
            *flat.iter().max_by(|p, q| score(p).total_cmp(&score(q))).expect("points")
        })
        .collect();
    octagon.dedup();
    if octagon.len() > 1 && octagon.first() == octagon.last() {
        octagon.pop();
    }
    if octagon.len() < 3 {
        return;
    }
    // Counter-clockwise by construction (the directions turn that way); "well inside"
    // is by a margin of 1e-9 of the octagon's size, so rounding keeps every vertex.
    let size = octagon.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let margin = 1e-9 * size * size;
    let edges: Vec<(Vector2<f64>, Vector2<f64>)> =
        (0..octagon.len()).map(|k| (octagon[k], octagon[(k + 1) % octagon.len()] - octagon[k])).collect();
    flat.retain(|p| !edges.iter().all(|(a, along)| along.perp(&(p - a)) > margin));
}
