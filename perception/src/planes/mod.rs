//! Planes from a point cloud: normals from each point's neighbourhood, region growing on
//! normal angle and curvature (after Rabbani et al.), a RANSAC refit per region (after
//! Schnabel et al.), and the convex hull of each plane's inliers.

//!
//! Each job in its own file: `grid` the spatial hash and voxel centroids, `plane_fit` the plane
//! fits, `ransac` the refits, `convex_hull` the convex hulls; this file holds the settings, the
//! planes and the region growing that ties them together.

mod convex_hull;
pub(crate) mod grid;
mod parallel;
mod plane_fit;
mod ransac;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use cbfgen::error::{within, CbfError};

use convex_hull::{hull, shrunk_edges};
use grid::{voxel_centroids, Candidates, Grid};
use parallel::{parallel_map, MAX_THREADS, PARALLEL_FROM, PARTS_PER_THREAD};
use plane_fit::{fit, Fit};
use ransac::{inlier_distance, plane_of, refine};

pub(crate) use grid::{cell_of, Cell};

/// Most points one segmentation accepts.
pub const MAX_POINTS: usize = 10_000_000;

/// Segmentation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentSettings {
    /// Side of the voxels the map is thinned to first (one centroid each) \[m\].
    pub voxel: f64,
    /// Neighbourhood radius for normals and growth \[m\].
    pub neighbor_radius: f64,
    /// Fewest neighbours a point needs for a normal.
    pub min_neighbors: usize,
    /// Most neighbours a normal is fitted to (the nearest cells' first ones): bounds the
    /// work where points pile up.
    pub max_neighbors: usize,
    /// Largest angle between neighbouring normals inside one region \[rad\].
    pub max_normal_angle: f64,
    /// Largest curvature (smallest eigenvalue over the sum) of a point that grows a region.
    pub max_curvature: f64,
    /// Fewest points a plane needs.
    pub min_plane_points: usize,
    /// Largest inlier distance of the RANSAC fits, set for raw returns \[m\]. Each region
    /// uses three times its points' median scatter about their local planes, if that is
    /// less (not under a quarter of this): averaged map voxels scatter far less.
    pub ransac_distance: f64,
    /// RANSAC hypotheses per region.
    pub ransac_iterations: usize,
    /// Seed of the RANSAC draws (segmentation is deterministic).
    pub seed: u64,
    /// Vertical planes' normals point towards this point (the sensor); others point up.
    pub viewpoint: Vector3<f64>,
    /// Threads the voxels, the normals, the regions' RANSAC, the refits and the hulls
    /// run on, for clouds of 20 000 points or more; 0: one per core. At most 8. The result is the
    /// same for any number.
    pub threads: usize,
}

impl Default for SegmentSettings {
    fn default() -> Self {
        Self {
            voxel: 0.02,
            neighbor_radius: 0.08,
            min_neighbors: 8,
            max_neighbors: 40,
            max_normal_angle: 15f64.to_radians(),
            max_curvature: 0.05,
            min_plane_points: 150,
            ransac_distance: 0.012,
            ransac_iterations: 200,
            seed: 7,
            viewpoint: Vector3::zeros(),
            threads: 0,
        }
    }
}

impl SegmentSettings {
    /// `Ok` when every setting is usable.
    ///
    /// # Errors
    /// A setting outside its domain, named.
    pub fn validate(&self) -> Result<(), CbfError> {
        within("neighbor radius [m]", self.neighbor_radius, 1e-4, 10.0, "[1e-4, 10]")?;
        within("voxel [m]", self.voxel, 1e-5, self.neighbor_radius, "[1e-5, neighbor radius]")?;
        within("max normal angle [rad]", self.max_normal_angle, 0.0, std::f64::consts::FRAC_PI_2, "[0, pi/2]")?;
        within("max curvature", self.max_curvature, 0.0, 1.0 / 3.0, "[0, 1/3]")?;
        within("ransac distance [m]", self.ransac_distance, 1e-6, 10.0, "[1e-6, 10]")?;
        for &c in self.viewpoint.iter() {
            within("viewpoint", c, -1e5, 1e5, "[-1e5, 1e5]")?;
        }
        for (what, n, lo, hi) in [
            ("min neighbors", self.min_neighbors, 3, 1000),
            ("max neighbors", self.max_neighbors, self.min_neighbors.max(3), 1000),
            ("min plane points", self.min_plane_points, 3, MAX_POINTS),
            ("ransac iterations", self.ransac_iterations, 1, 100_000),
            ("threads", self.threads, 0, MAX_THREADS),
        ] {
            if n < lo || n > hi {
                return Err(CbfError::OutOfRange { what, value: n as f64, range: "its documented bounds" });
            }
        }
        Ok(())
    }
}

/// A plane `normal · p + offset = 0` and the convex hull of its inliers.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// Unit normal: up for planes that face up or down, towards the viewpoint otherwise.
    pub normal: Vector3<f64>,
    /// Offset: `normal · p + offset = 0` on the plane \[m\].
    pub offset: f64,
    /// Convex hull of the inliers, projected onto the plane, counter-clockwise seen
    /// against the normal, world frame.
    pub polygon: Vec<Vector3<f64>>,
    /// Points that support it.
    pub inliers: usize,
}

impl Plane {
    /// Signed distance of `p` from the plane, along the normal \[m\].
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(p) + self.offset
    }

    /// Whether the vertical line through `p` crosses the hull (for planes that face up).
    pub fn covers_xy(&self, p: &Vector3<f64>) -> bool {
        let n = self.polygon.len();
        n >= 3
            && (0..n).all(|i| {
                let (a, b) = (self.polygon[i], self.polygon[(i + 1) % n]);
                (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x) >= -1e-9
            })
    }

    /// Height of the plane above `(x, y)` (planes that face up).
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        -(self.offset + self.normal.x * x + self.normal.y * y) / self.normal.z
    }
}

/// The neighbour lists and normals of a run of the grid's positions (points in cell
/// order, so that the points of a cell share one search block).
struct NeighborPart {
    /// Where each position's list starts in `flat`, and where the last one ends.
    starts: Vec<usize>,
    flat: Vec<u32>,
    normal: Vec<Option<(Vector3<f64>, f64)>>,
    /// RMS distance of the neighbours from their plane (infinite without a normal).
    scatter: Vec<f64>,
}

fn neighbor_part(grid: &Grid, weights: &[f64], positions: std::ops::Range<usize>, s: &SegmentSettings) -> NeighborPart {
    let mut part = NeighborPart {
        starts: Vec::with_capacity(positions.len() + 1),
        flat: Vec::with_capacity(positions.len() * s.max_neighbors / 2),
        normal: Vec::with_capacity(positions.len()),
        scatter: Vec::with_capacity(positions.len()),
    };
    let mut candidates = Candidates::default();
    let mut block_of = None;
    for pos in positions {
        let p = grid.grouped[pos];
        let cell = cell_of(&p, grid.size);
        if block_of != Some(cell) {
            grid.block(cell, s.max_neighbors, weights, &mut candidates);
            block_of = Some(cell);
        }
        candidates.choose(&p, grid.size, s.max_neighbors);
        let Candidates { ids, points, weights, chosen } = &candidates;
        part.starts.push(part.flat.len());
        part.flat.extend(chosen.iter().map(|&k| ids[k]));
        let local = (chosen.len() >= s.min_neighbors).then(|| fit(points, weights, chosen.iter().copied())).flatten();
        part.normal.push(local.as_ref().map(|f| (f.normal, f.curvature)));
        part.scatter.push(local.map_or(f64::INFINITY, |f| f.variance.sqrt()));
    }
    part.starts.push(part.flat.len());
    part
}

/// Planes in `points`, largest first.
///
/// # Errors
/// A non-finite point ([`CbfError::NonFinite`]), more than [`MAX_POINTS`] points, or
/// invalid settings. Points that support no plane (too few, on a line, all in one spot)
/// give no plane, not an error.
pub fn segment(points: &[Vector3<f64>], settings: &SegmentSettings) -> Result<Vec<Plane>, CbfError> {
    if points.len() > MAX_POINTS {
        return Err(CbfError::TooLarge { what: "points", value: points.len(), max: MAX_POINTS });
    }
    segment_weighted(points, &vec![1.0; points.len()], settings)
}

/// [`segment`] of points that each stand for `weights[i]` returns, such as the centroids
/// of an accumulated map's voxels weighted by how many returns each averages: the fits
/// then weigh each voxel by the evidence in it, as a fit to all the returns would.
///
/// # Errors
/// As [`segment`]; also weights that are not one per point, or not in (0, 1e9].
pub fn segment_weighted(
    points: &[Vector3<f64>],
    weights: &[f64],
    settings: &SegmentSettings,
) -> Result<Vec<Plane>, CbfError> {
    settings.validate()?;
    if points.len() > MAX_POINTS {
        return Err(CbfError::TooLarge { what: "points", value: points.len(), max: MAX_POINTS });
    }
    if weights.len() != points.len() {
        return Err(CbfError::LengthMismatch { what: "point weights", expected: points.len(), got: weights.len() });
    }
    for p in points {
        for &c in p.iter() {
            within("point coordinate [m]", c, -1e5, 1e5, "[-1e5, 1e5]")?;
        }
    }
    for &w in weights {
        within("point weight", w, f64::MIN_POSITIVE, 1e9, "(0, 1e9]")?;
    }
    let s = settings;
    // One point per voxel (the centroid of those in it): the map's density no longer sets
    // the cost, and a pile of points in one spot is one point.
    let threads = match s.threads {
        _ if points.len() < PARALLEL_FROM => 1,
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()).min(MAX_THREADS),
        n => n,
    };
    let (points, weights) = voxel_centroids(points, weights, s.voxel, threads);
    let (points, weights) = (&points[..], &weights[..]);
    let grid = Grid::new(points, s.neighbor_radius);
    // Neighbour lists, once: normals, growth and the hulls' rims all walk them. The
    // points are split into runs of the grid's cell order, taken by the threads from a
    // queue; a list is found by its point's run, so the result does not depend on how
    // many threads there are.
    let chunk = points.len().div_ceil(threads * PARTS_PER_THREAD).max(1);
    let parts: Vec<NeighborPart> = parallel_map(points.len().div_ceil(chunk), threads, |c| {
        neighbor_part(&grid, weights, c * chunk..((c + 1) * chunk).min(points.len()), s)
    });
    // The neighbour lists stay in their parts (joining them was a copy of megabytes);
    // normals go back to point order.
    let mut normal = vec![None; points.len()];
    let mut scatter = vec![f64::INFINITY; points.len()];
    let mut position = vec![0u32; points.len()];
    for (pos, &i) in grid.order.iter().enumerate() {
        let part = &parts[pos / chunk];
        normal[i as usize] = part.normal[pos % chunk];
        scatter[i as usize] = part.scatter[pos % chunk];
        position[i as usize] = pos as u32;
    }
    let cloud =
        Cloud { points, weights, normal: &normal, scatter: &scatter, parts: &parts, position: &position, chunk };
    // Region growing from the flattest points.
    // Curvatures are not negative: their bit patterns sort as they do (`+ 0.0` makes a
    // negative zero positive).
    let mut by_curvature: Vec<(u64, usize)> =
        normal.iter().enumerate().filter_map(|(i, n)| n.map(|(_, c)| ((c + 0.0).to_bits(), i))).collect();
    by_curvature.sort_unstable();
    let order: Vec<usize> = by_curvature.into_iter().map(|(_, i)| i).collect();
    let cos_max = s.max_normal_angle.cos();
    let mut region = vec![u32::MAX; points.len()];
    let mut regions: Vec<Vec<usize>> = Vec::new();
    let mut queue = Vec::new();
    for &seed in &order {
        let Some((_, c)) = normal[seed] else { continue };
        if region[seed] != u32::MAX || c > s.max_curvature {
            continue;
        }
        let id = regions.len() as u32;
        let mut members = vec![seed];
        region[seed] = id;
        queue.clear();
        queue.push(seed);
        while let Some(i) = queue.pop() {
            let (ni, _) = normal[i].expect("only points with normals join");
            for &j in cloud.neighbors(i) {
                let j = j as usize;
                // Most neighbours have joined already: that is the cheap test.
                if region[j] != u32::MAX {
                    continue;
                }
                let Some((nj, cj)) = normal[j] else { continue };
                if ni.dot(&nj).abs() >= cos_max {
                    region[j] = id;
                    members.push(j);
                    if cj <= s.max_curvature {
                        queue.push(j);
                    }
                }
            }
        }
        regions.push(members);
    }
    // Each region draws from its own stream of the seed, so the draws do not depend on
    // which thread refines it.
    regions.retain(|r| r.len() >= s.min_plane_points);
    let mut found: Vec<(Plane, Vec<usize>)> = parallel_map(regions.len(), threads, |k| {
        let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
        rng.set_stream(k as u64);
        refine(&cloud, &regions[k], s, &mut rng)
    })
    .into_iter()
    .flatten()
    .collect();
    found.sort_by_key(|f| std::cmp::Reverse(f.0.inliers));
    let mut merged = merge_coplanar(&cloud, found, s);
    let snapshot: Vec<Plane> = merged.iter().map(|(p, _)| p.clone()).collect();
    let refitted = parallel_map(merged.len(), threads, |k| refit_on_face(&cloud, &snapshot, k, &merged[k].1, s));
    for ((plane, _), refit) in merged.iter_mut().zip(refitted) {
        *plane = refit;
    }
    // The hull takes in the points next to the inliers that lie on the plane too: at a
    // nosing those have mixed normals and stay out of the fit, but they are where the
    // tread ends.
    let planes = parallel_map(merged.len(), threads, |k| {
        let (plane, inliers) = &merged[k];
        let mut on_plane = vec![false; points.len()];
        let mut rim = inliers.clone();
        for &i in inliers {
            on_plane[i] = true;
        }
        for &i in inliers {
            for &j in cloud.neighbors(i) {
                let j = j as usize;
                if !on_plane[j] && plane.distance(&points[j]).abs() <= s.ransac_distance {
                    on_plane[j] = true;
                    rim.push(j);
                }
            }
        }
        Plane { polygon: hull(points, &rim, &plane.normal, &(plane.normal * -plane.offset)), ..plane.clone() }
    });
    Ok(planes)
}

/// Plane `k` of `planes` refitted on every point of the cloud near it, not only its
/// region's (noise splits a narrow face into regions, and one region's points can lean),
/// leaving out the points that also lie on a crossing plane: at a corner those sit on one
/// side of the edge only (a tread's points end at the riser) and tilt a narrow face.
fn refit_on_face(cloud: &Cloud<'_>, planes: &[Plane], k: usize, inliers: &[usize], s: &SegmentSettings) -> Plane {
    let Cloud { points, weights, .. } = *cloud;
    let cos_max = s.max_normal_angle.cos();
    let mut plane = planes[k].clone();
    let crossing: Vec<&Plane> = planes
        .iter()
        .enumerate()
        .filter(|&(j, q)| j != k && q.normal.dot(&plane.normal).abs() < 0.5)
        .map(|(_, q)| q)
        .collect();
    let margin = Vector3::repeat(2.0 * s.neighbor_radius);
    let (lo, hi) =
        inliers.iter().fold((Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY)), |(lo, hi), &i| {
            (lo.inf(&points[i]), hi.sup(&points[i]))
        });
    let (lo, hi) = (lo - margin, hi + margin);
    // A band of 2.5 inlier distances: about 3 sigma of the noise, so the band does
    // not clip the noise and keep a tilt, and no wider: a low riser is no plane of its
    // own (too few points), and its points within the band tilt a tread.
    let band = 2.5 * inlier_distance(cloud, inliers, s);
    let mut clear: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let p = &points[i];
            // Geometry only: a per-point normal near an edge leans with the noise (a
            // point pushed off the face towards the neighbouring face gets a mixed
            // normal), so filtering on it would keep one side of the noise only.
            (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a])
                && plane.distance(p).abs() <= band
                && crossing.iter().all(|q| q.distance(p).abs() > band)
        })
        .collect();
    // A level face is fitted away from its border where no plane found crosses it
    // there: at such a border the band also holds the foot or the top of what rises
    // or drops beyond it, on one side of the face only, and that tilts the face. A
    // riser lower than the neighbourhood radius is no plane of its own, and its foot
    // and top would tilt the treads either side of it. Where a found plane crosses,
    // its points are out already; a vertical face's borders are the level faces
    // above and below it, which are large and found.
    if plane.normal.z >= cos_max {
        let centroid = plane.normal * -plane.offset;
        let outline = hull(points, inliers, &plane.normal, &centroid);
        let margins: Vec<f64> = (0..outline.len())
            .map(|e| {
                let (a, b) = (outline[e], outline[(e + 1) % outline.len()]);
                let crossed = crossing.iter().any(|q| q.distance(&a).abs() <= band && q.distance(&b).abs() <= band);
                if crossed {
                    0.0
                } else {
                    band
                }
            })
            .collect();
        let bounds = shrunk_edges(&outline, &margins, &plane.normal);
        clear.retain(|&i| bounds.iter().all(|(inward, limit)| inward.dot(&points[i]) >= *limit));
    }
    // Least squares, then again without the points beyond 2.5 robust sigmas (the
    // median absolute residual): what lies in the band but off the face goes.
    for _ in 0..3 {
        let Some(Fit { centroid, normal: n, .. }) = fit(points, weights, clear.iter().copied()) else { break };
        let n = if n.dot(&plane.normal) < 0.0 { -n } else { n };
        plane.normal = n;
        plane.offset = -n.dot(&centroid);
        let mut residuals: Vec<f64> = clear.iter().map(|&i| plane.distance(&points[i]).abs()).collect();
        let mid = residuals.len() / 2;
        let sigma = 1.4826 * *residuals.select_nth_unstable_by(mid, f64::total_cmp).1;
        clear.retain(|&i| plane.distance(&points[i]).abs() <= 2.5 * sigma);
    }
    plane
}

/// The thinned cloud the planes are found in: voxel centroids, their weights and normals.
#[derive(Clone, Copy)]
struct Cloud<'a> {
    points: &'a [Vector3<f64>],
    weights: &'a [f64],
    normal: &'a [Option<(Vector3<f64>, f64)>],
    /// Each point's neighbourhood's RMS distance from its own plane.
    scatter: &'a [f64],
    /// Point `i`'s neighbour list is in part `position[i] / chunk`, at
    /// `position[i] % chunk` there.
    parts: &'a [NeighborPart],
    position: &'a [u32],
    chunk: usize,
}

impl Cloud<'_> {
    fn neighbors(&self, i: usize) -> &[u32] {
        let pos = self.position[i] as usize;
        let part = &self.parts[pos / self.chunk];
        let k = pos % self.chunk;
        &part.flat[part.starts[k]..part.starts[k + 1]]
    }

    /// The largest set of `members` joined through neighbourhoods (most weight).
    /// `state` is one zero per point, and is left so: it is scratch, kept by the caller
    /// across calls (a buffer per call was an allocation the size of the cloud each time).
    fn largest_component(&self, members: &[usize], state: &mut [u8]) -> Vec<usize> {
        // 0: not a member; 1: a member not yet reached; 2: reached.
        for &i in members {
            state[i] = 1;
        }
        let (mut best, mut best_weight) = (Vec::new(), 0.0);
        let mut queue = Vec::new();
        for &seed in members {
            if state[seed] != 1 {
                continue;
            }
            state[seed] = 2;
            queue.clear();
            queue.push(seed);
            let mut component = Vec::new();
            let mut weight = 0.0;
            while let Some(i) = queue.pop() {
                component.push(i);
                weight += self.weights[i];
                for &j in self.neighbors(i) {
                    let j = j as usize;
                    if state[j] == 1 {
                        state[j] = 2;
                        queue.push(j);
                    }
                }
            }
            if weight > best_weight {
                (best, best_weight) = (component, weight);
            }
        }
        for &i in members {
            state[i] = 0;
        }
        best.sort_unstable();
        best
    }
}

/// Planes split by noise into regions come back together: two planes within the
/// growth angle of each other and within the RANSAC distance at each other's centroid
/// are one, refitted on both sets of inliers.
fn merge_coplanar(
    cloud: &Cloud<'_>,
    mut found: Vec<(Plane, Vec<usize>)>,
    s: &SegmentSettings,
) -> Vec<(Plane, Vec<usize>)> {
    let points = cloud.points;
    let cos_max = s.max_normal_angle.cos();
    let mut merged: Vec<(Plane, Vec<usize>)> = Vec::new();
    for (plane, inliers) in found.drain(..) {
        let centroid = inliers.iter().map(|&i| points[i]).sum::<Vector3<f64>>() / inliers.len() as f64;
        let into = merged
            .iter_mut()
            .find(|(m, _)| m.normal.dot(&plane.normal) >= cos_max && m.distance(&centroid).abs() <= s.ransac_distance);
        match into {
            Some((m, set)) => {
                set.extend(inliers);
                if let Some(refit) = plane_of(cloud, set, s) {
                    *m = refit;
                }
            }
            None => merged.push((plane, inliers)),
        }
    }
    merged.sort_by_key(|m| std::cmp::Reverse(m.0.inliers));
    merged
}

#[cfg(test)]
mod tests {
    use super::convex_hull::{drop_interior, monotone_chain};
    use super::grid::floor;
    use super::plane_fit::{null_direction, symmetric_eigenvalues};
    use super::*;
    use nalgebra::{Matrix3, Vector2};
    use rand::Rng;

    /// The inlined floor against the standard library's, at integers, just either side
    /// of them, at random values over the range cells use, and at the extremes.
    #[test]
    fn floor_matches_the_standard_floor() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut values = vec![0.0, -0.0, 1e10, -1e10, 1e300, -1e300, f64::MAX, f64::MIN, 9.2e18, -9.3e18];
        for k in -5..=5 {
            let k = f64::from(k);
            values.extend([k, k.next_up(), k.next_down(), k + 0.5, k - 0.5]);
        }
        values.extend((0..10_000).map(|_| (rng.random::<f64>() - 0.5) * 2e10));
        for v in values {
            assert_eq!(floor(v), v.floor() as i64, "{v:e}");
        }
    }

    /// Leaving out the interior points never changes the hull: random clouds, clouds on
    /// a grid (collinear runs on the hull's edges, ties among the extremes) and clouds
    /// with repeated points, against Andrew's chain over all of them. And it leaves most
    /// of a random cloud out.
    #[test]
    fn dropping_interior_points_keeps_the_hull() {
        let (mut random_points, mut random_kept) = (0, 0);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for case in 0..300 {
            let n = 64 + case * 7;
            let flat: Vec<Vector2<f64>> = (0..n)
                .map(|_| match case % 3 {
                    0 => Vector2::new(rng.random::<f64>() * 3.0 - 1.0, rng.random::<f64>() * 0.4 - 0.2),
                    1 => Vector2::new(f64::from(rng.random_range(-4..=4)), f64::from(rng.random_range(-2..=2))) * 0.02,
                    _ => Vector2::new(f64::from(rng.random_range(0..3)), rng.random::<f64>()),
                })
                .collect();
            let mut kept = flat.clone();
            drop_interior(&mut kept);
            if case % 3 == 0 {
                (random_points, random_kept) = (random_points + flat.len(), random_kept + kept.len());
            }
            assert_eq!(monotone_chain(kept), monotone_chain(flat), "case {case}");
        }
        assert!(random_kept * 5 < random_points, "kept {random_kept} of {random_points}");
    }

    /// The closed form against nalgebra's iterative decomposition (an independent
    /// solver): random symmetric matrices, and covariances of noisy planar patches, whose
    /// smallest eigenvalue is a thousandth of the others.
    #[test]
    fn closed_form_eigen_matches_the_iterative_decomposition() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for case in 0..2000 {
            let a = if case % 2 == 0 {
                let m = Matrix3::from_fn(|_, _| rng.random::<f64>() * 2.0 - 1.0);
                m + m.transpose()
            } else {
                let tilt = nalgebra::Rotation3::from_euler_angles(rng.random(), rng.random(), rng.random());
                let pts: Vec<Vector3<f64>> = (0..40)
                    .map(|_| {
                        tilt * Vector3::new(
                            rng.random::<f64>() * 0.08,
                            rng.random::<f64>() * 0.08,
                            rng.random::<f64>() * 0.002,
                        )
                    })
                    .collect();
                let c = pts.iter().sum::<Vector3<f64>>() / 40.0;
                pts.iter().map(|p| (p - c) * (p - c).transpose()).sum()
            };
            let truth = nalgebra::SymmetricEigen::new(a);
            let mut expected = [truth.eigenvalues[0], truth.eigenvalues[1], truth.eigenvalues[2]];
            expected.sort_by(f64::total_cmp);
            let got = symmetric_eigenvalues(&a);
            let scale = expected[2].abs().max(expected[0].abs());
            for (g, e) in got.iter().zip(expected) {
                assert!((g - e).abs() <= 1e-9 * scale, "case {case}: {got:?} vs {expected:?}");
            }
            let k = truth.eigenvalues.imin();
            let v = null_direction(&(a - Matrix3::identity() * got[0])).expect("a direction");
            let gap = (expected[1] - expected[0]) / scale;
            if gap > 1e-3 {
                let cos = v.dot(&truth.eigenvectors.column(k)).abs();
                assert!(cos > 1.0 - 1e-8, "case {case}: eigenvector off by {:.2e} rad", cos.acos());
            }
        }
        assert_eq!(symmetric_eigenvalues(&Matrix3::identity()), [1.0; 3]);
    }
}
