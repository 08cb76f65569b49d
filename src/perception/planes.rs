//! Planes from a point cloud: normals from each point's neighbourhood, region growing on
//! normal angle and curvature (after Rabbani et al.), a RANSAC refit per region (after
//! Schnabel et al.), and the convex hull of each plane's inliers.

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{within, CbfError};

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
    /// Inlier distance of the RANSAC refit \[m\].
    pub ransac_distance: f64,
    /// RANSAC hypotheses per region.
    pub ransac_iterations: usize,
    /// Seed of the RANSAC draws (segmentation is deterministic).
    pub seed: u64,
    /// Vertical planes' normals point towards this point (the sensor); others point up.
    pub viewpoint: Vector3<f64>,
    /// Threads the neighbourhoods are gathered on, for clouds of 20 000 points or more;
    /// 0: one per core. At most 8. The result is the same for any number.
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

/// Integer coordinates of a cubic cell.
pub(crate) type Cell = (i64, i64, i64);

/// The cell of side `size` holding `p`.
pub(crate) fn cell_of(p: &Vector3<f64>, size: f64) -> Cell {
    ((p.x / size).floor() as i64, (p.y / size).floor() as i64, (p.z / size).floor() as i64)
}

/// A multiply-rotate hash for cell keys: the grid is queried 27 times per point per pass,
/// and SipHash (the standard map's default, resistant to chosen keys, which cell indices
/// of a point cloud are not) was most of a segmentation's time.
#[derive(Default)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// Points binned into cubes of the neighbourhood radius, cell by cell in one array: a
/// dense index over the cloud's bounding box where that box is a few cells per point (a
/// lookup is arithmetic), a hash of the occupied cells otherwise.
struct Grid<'a> {
    points: &'a [Vector3<f64>],
    size: f64,
    /// Point indices, grouped by cell.
    order: Vec<u32>,
    /// The points in `order`'s order: a cell's points lie side by side in memory.
    grouped: Vec<Vector3<f64>>,
    cells: Cells,
}

enum Cells {
    /// `starts[c]..starts[c + 1]` of `order` for the linear index `c` of a cell in the box
    /// from `lo` with `dims` cells along each axis.
    Dense {
        lo: Cell,
        dims: (i64, i64, i64),
        starts: Vec<u32>,
    },
    Sparse(HashMap<Cell, (u32, u32), std::hash::BuildHasherDefault<CellHasher>>),
}

impl<'a> Grid<'a> {
    fn new(points: &'a [Vector3<f64>], size: f64) -> Self {
        let keys: Vec<Cell> = points.iter().map(|p| Self::cell(p, size)).collect();
        let lo = keys.iter().fold((i64::MAX, i64::MAX, i64::MAX), |a, k| (a.0.min(k.0), a.1.min(k.1), a.2.min(k.2)));
        let hi = keys.iter().fold((i64::MIN, i64::MIN, i64::MIN), |a, k| (a.0.max(k.0), a.1.max(k.1), a.2.max(k.2)));
        let dims = (hi.0 - lo.0 + 1, hi.1 - lo.1 + 1, hi.2 - lo.2 + 1);
        let volume = (dims.0 as f64) * (dims.1 as f64) * (dims.2 as f64);
        if !keys.is_empty() && volume <= (8 * points.len() + 4096) as f64 {
            let index = |k: &Cell| (((k.0 - lo.0) * dims.1 + (k.1 - lo.1)) * dims.2 + (k.2 - lo.2)) as usize;
            let mut starts = vec![0u32; volume as usize + 1];
            for k in &keys {
                starts[index(k) + 1] += 1;
            }
            for c in 1..starts.len() {
                starts[c] += starts[c - 1];
            }
            let mut fill = starts.clone();
            let mut order = vec![0u32; points.len()];
            for (i, k) in keys.iter().enumerate() {
                let c = index(k);
                order[fill[c] as usize] = i as u32;
                fill[c] += 1;
            }
            let grouped = order.iter().map(|&i| points[i as usize]).collect();
            return Self { points, size, order, grouped, cells: Cells::Dense { lo, dims, starts } };
        }
        let mut grouped: HashMap<Cell, Vec<u32>, std::hash::BuildHasherDefault<CellHasher>> = HashMap::default();
        for (i, k) in keys.iter().enumerate() {
            grouped.entry(*k).or_default().push(i as u32);
        }
        let mut order = Vec::with_capacity(points.len());
        let mut ranges = HashMap::default();
        for (k, members) in grouped {
            ranges.insert(k, (order.len() as u32, (order.len() + members.len()) as u32));
            order.extend(members);
        }
        let grouped = order.iter().map(|&i| points[i as usize]).collect();
        Self { points, size, order, grouped, cells: Cells::Sparse(ranges) }
    }

    fn cell(p: &Vector3<f64>, size: f64) -> Cell {
        cell_of(p, size)
    }

    /// Where the points of cell `k` lie in `order` and `grouped`.
    fn members(&self, k: Cell) -> std::ops::Range<usize> {
        let (a, b) = match &self.cells {
            Cells::Dense { lo, dims, starts } => {
                let (x, y, z) = (k.0 - lo.0, k.1 - lo.1, k.2 - lo.2);
                if x < 0 || y < 0 || z < 0 || x >= dims.0 || y >= dims.1 || z >= dims.2 {
                    return 0..0;
                }
                let c = ((x * dims.1 + y) * dims.2 + z) as usize;
                (starts[c], starts[c + 1])
            }
            Cells::Sparse(ranges) => ranges.get(&k).copied().unwrap_or((0, 0)),
        };
        a as usize..b as usize
    }

    /// Up to `cap` points within the radius of point `i` (itself included), scanning at
    /// most `cap` points of each of the 27 cells around it.
    fn neighbors(&self, i: usize, cap: usize, out: &mut Vec<u32>) {
        out.clear();
        let p = self.points[i];
        let (cx, cy, cz) = Self::cell(&p, self.size);
        let r2 = self.size * self.size;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let range = self.members((cx + dx, cy + dy, cz + dz));
                    let take = range.len().min(cap);
                    let (ids, at) = (&self.order[range.clone()], &self.grouped[range]);
                    for (&j, q) in ids.iter().zip(at).take(take) {
                        if (q - p).norm_squared() <= r2 {
                            out.push(j);
                            if out.len() >= cap {
                                return;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The centroid of the points in each occupied voxel of side `size`, in first-seen order.
fn voxel_centroids(points: &[Vector3<f64>], size: f64) -> Vec<Vector3<f64>> {
    let mut slot: HashMap<Cell, usize, std::hash::BuildHasherDefault<CellHasher>> = HashMap::default();
    let mut sums: Vec<(Vector3<f64>, f64)> = Vec::new();
    for p in points {
        let k = *slot.entry(Grid::cell(p, size)).or_insert_with(|| {
            sums.push((Vector3::zeros(), 0.0));
            sums.len() - 1
        });
        sums[k].0 += p;
        sums[k].1 += 1.0;
    }
    sums.into_iter().map(|(sum, n)| sum / n).collect()
}

/// Least-squares plane through `points[idx]`: (centroid, unit normal, curvature), or
/// `None` when they span no plane (fewer than three, or all on one point).
fn fit(points: &[Vector3<f64>], idx: impl Iterator<Item = usize> + Clone) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
    let n = idx.clone().count();
    if n < 3 {
        return None;
    }
    let centroid = idx.clone().map(|i| points[i]).sum::<Vector3<f64>>() / n as f64;
    let mut cov = Matrix3::zeros();
    for i in idx {
        let d = points[i] - centroid;
        cov += d * d.transpose();
    }
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
    Some((centroid, normal, smallest.max(0.0) / total))
}

/// Eigenvalues of a symmetric 3×3 matrix, ascending, in closed form (the trigonometric
/// solution of the characteristic cubic): an iterative decomposition per point was most
/// of the normals' cost.
fn symmetric_eigenvalues(a: &Matrix3<f64>) -> [f64; 3] {
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
fn null_direction(m: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let rows = [m.row(0).transpose(), m.row(1).transpose(), m.row(2).transpose()];
    let best = [rows[0].cross(&rows[1]), rows[0].cross(&rows[2]), rows[1].cross(&rows[2])]
        .into_iter()
        .max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))?;
    let norm = best.norm();
    (norm > 0.0 && norm.is_finite()).then(|| best / norm)
}

/// Clouds at least this large have their neighbourhoods gathered on several threads.
const PARALLEL_FROM: usize = 20_000;
/// Most threads one segmentation uses.
const MAX_THREADS: usize = 8;

/// The neighbour lists and normals of a run of points.
struct NeighborPart {
    /// Where each point's list starts in `flat` (relative to this part).
    starts: Vec<usize>,
    flat: Vec<u32>,
    normal: Vec<Option<(Vector3<f64>, f64)>>,
}

fn neighbor_part(
    grid: &Grid<'_>,
    points: &[Vector3<f64>],
    range: std::ops::Range<usize>,
    s: &SegmentSettings,
) -> NeighborPart {
    let mut nb = Vec::with_capacity(s.max_neighbors);
    let mut part = NeighborPart {
        starts: Vec::with_capacity(range.len()),
        flat: Vec::with_capacity(range.len() * s.max_neighbors / 2),
        normal: Vec::with_capacity(range.len()),
    };
    for i in range {
        grid.neighbors(i, s.max_neighbors, &mut nb);
        part.starts.push(part.flat.len());
        part.flat.extend_from_slice(&nb);
        part.normal.push(if nb.len() >= s.min_neighbors {
            fit(points, nb.iter().map(|&j| j as usize)).map(|(_, n, c)| (n, c))
        } else {
            None
        });
    }
    part
}

/// Planes in `points`, largest first.
///
/// # Errors
/// A non-finite point ([`CbfError::NonFinite`]), more than [`MAX_POINTS`] points, or
/// invalid settings. Points that support no plane (too few, on a line, all in one spot)
/// give no plane, not an error.
pub fn segment(points: &[Vector3<f64>], settings: &SegmentSettings) -> Result<Vec<Plane>, CbfError> {
    settings.validate()?;
    if points.len() > MAX_POINTS {
        return Err(CbfError::TooLarge { what: "points", value: points.len(), max: MAX_POINTS });
    }
    for p in points {
        for &c in p.iter() {
            within("point coordinate [m]", c, -1e5, 1e5, "[-1e5, 1e5]")?;
        }
    }
    let s = settings;
    // One point per voxel (the centroid of those in it): the map's density no longer sets
    // the cost, and a pile of points in one spot is one point.
    let cloud = voxel_centroids(points, s.voxel);
    let points = &cloud[..];
    let grid = Grid::new(points, s.neighbor_radius);
    // Neighbour lists, once: normals, growth and the hulls' rims all walk them. The
    // points are split between the cores; each part's lists are joined in order, so the
    // result does not depend on how many there are.
    let threads = match s.threads {
        _ if points.len() < PARALLEL_FROM => 1,
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()).min(MAX_THREADS),
        n => n,
    };
    let chunk = points.len().div_ceil(threads).max(1);
    let parts: Vec<NeighborPart> = std::thread::scope(|scope| {
        let grid = &grid;
        let handles: Vec<_> = (0..points.len())
            .step_by(chunk)
            .map(|from| scope.spawn(move || neighbor_part(grid, points, from..(from + chunk).min(points.len()), s)))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))).collect()
    });
    let mut starts = Vec::with_capacity(points.len() + 1);
    let mut flat: Vec<u32> = Vec::with_capacity(parts.iter().map(|p| p.flat.len()).sum());
    let mut normal = Vec::with_capacity(points.len());
    for part in parts {
        starts.extend(part.starts.iter().map(|&k| k + flat.len()));
        flat.extend(part.flat);
        normal.extend(part.normal);
    }
    starts.push(flat.len());
    let neighbors = |i: usize| &flat[starts[i]..starts[i + 1]];
    // Region growing from the flattest points.
    let mut order: Vec<usize> = (0..points.len()).filter(|&i| normal[i].is_some()).collect();
    order.sort_by(|&a, &b| {
        normal[a].map(|n| n.1).partial_cmp(&normal[b].map(|n| n.1)).unwrap_or(std::cmp::Ordering::Equal)
    });
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
            for &j in neighbors(i) {
                let j = j as usize;
                let Some((nj, cj)) = normal[j] else { continue };
                if region[j] == u32::MAX && ni.dot(&nj).abs() >= cos_max {
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
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
    let mut found: Vec<(Plane, Vec<usize>)> = regions
        .iter()
        .filter(|r| r.len() >= s.min_plane_points)
        .flat_map(|r| refine(points, &normal, r, s, &mut rng))
        .collect();
    found.sort_by_key(|f| std::cmp::Reverse(f.0.inliers));
    let mut merged = merge_coplanar(points, &normal, found, s);
    // Refit each plane on every point of the cloud near it, not only its region's (noise
    // splits a narrow face into regions, and one region's points can lean), leaving out
    // the points that also lie on a crossing plane: at a corner those sit on one side of
    // the edge only (a tread's points end at the riser) and tilt a narrow face.
    let snapshot: Vec<Plane> = merged.iter().map(|(p, _)| p.clone()).collect();
    for (k, (plane, inliers)) in merged.iter_mut().enumerate() {
        let crossing: Vec<&Plane> = snapshot
            .iter()
            .enumerate()
            .filter(|&(j, q)| j != k && q.normal.dot(&plane.normal).abs() < 0.5)
            .map(|(_, q)| q)
            .collect();
        let margin = Vector3::repeat(2.0 * s.neighbor_radius);
        let (lo, hi) = inliers
            .iter()
            .fold((Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY)), |(lo, hi), &i| {
                (lo.inf(&points[i]), hi.sup(&points[i]))
            });
        let (lo, hi) = (lo - margin, hi + margin);
        // A band of 2.5 RANSAC distances: about 3 sigma of the range noise the RANSAC
        // distance is set for, so the band does not clip the noise and keep a tilt.
        let band = 2.5 * s.ransac_distance;
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
        // Least squares, then again without the points beyond 2.5 robust sigmas (the
        // median absolute residual): what lies in the band but off the face goes.
        for _ in 0..3 {
            let Some((centroid, n, _)) = fit(points, clear.iter().copied()) else { break };
            let n = if n.dot(&plane.normal) < 0.0 { -n } else { n };
            plane.normal = n;
            plane.offset = -n.dot(&centroid);
            let mut residuals: Vec<f64> = clear.iter().map(|&i| plane.distance(&points[i]).abs()).collect();
            residuals.sort_by(f64::total_cmp);
            let sigma = 1.4826 * residuals[residuals.len() / 2];
            clear.retain(|&i| plane.distance(&points[i]).abs() <= 2.5 * sigma);
        }
    }
    // The hull takes in the points next to the inliers that lie on the plane too: at a
    // nosing those have mixed normals and stay out of the fit, but they are where the
    // tread ends.
    let mut on_plane = vec![false; points.len()];
    let planes = merged
        .into_iter()
        .map(|(mut plane, inliers)| {
            let mut rim = inliers.clone();
            for &i in &inliers {
                on_plane[i] = true;
            }
            for &i in &inliers {
                for &j in neighbors(i) {
                    let j = j as usize;
                    if !on_plane[j] && plane.distance(&points[j]).abs() <= s.ransac_distance {
                        on_plane[j] = true;
                        rim.push(j);
                    }
                }
            }
            for &i in &rim {
                on_plane[i] = false;
            }
            plane.polygon = hull(points, &rim, &plane.normal, &(plane.normal * -plane.offset));
            plane
        })
        .collect();
    Ok(planes)
}

/// Planes split by noise into regions come back together: two planes within the
/// growth angle of each other and within the RANSAC distance at each other's centroid
/// are one, refitted on both sets of inliers.
fn merge_coplanar(
    points: &[Vector3<f64>],
    normal: &[Option<(Vector3<f64>, f64)>],
    mut found: Vec<(Plane, Vec<usize>)>,
    s: &SegmentSettings,
) -> Vec<(Plane, Vec<usize>)> {
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
                if let Some(refit) = plane_of(points, normal, set, s) {
                    *m = refit;
                }
            }
            None => merged.push((plane, inliers)),
        }
    }
    merged.sort_by_key(|m| std::cmp::Reverse(m.0.inliers));
    merged
}

/// Most planes one region is split into.
const MAX_PLANES_PER_REGION: usize = 8;

/// The planes of a region: RANSAC, then again on what the plane left, while enough is
/// left. A region can hold more than one plane: below a step lower than the neighbour
/// radius, the normals turn from floor to riser to tread in small steps, and growth runs
/// over the edge.
fn refine(
    points: &[Vector3<f64>],
    normal: &[Option<(Vector3<f64>, f64)>],
    region: &[usize],
    s: &SegmentSettings,
    rng: &mut impl Rng,
) -> Vec<(Plane, Vec<usize>)> {
    let cos_max = s.max_normal_angle.cos();
    let mut planes: Vec<(Plane, Vec<usize>)> = Vec::new();
    let mut left = region.to_vec();
    let mut taken = vec![false; points.len()];
    for _ in 0..MAX_PLANES_PER_REGION {
        if left.len() < s.min_plane_points {
            break;
        }
        let Some((plane, inliers)) = best_plane(points, normal, &left, s, rng) else { break };
        for &i in &inliers {
            taken[i] = true;
        }
        left.retain(|&i| !taken[i]);
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

/// RANSAC over a region's points, a least-squares refit on the best inliers, and their hull.
fn best_plane(
    points: &[Vector3<f64>],
    normal: &[Option<(Vector3<f64>, f64)>],
    region: &[usize],
    s: &SegmentSettings,
    rng: &mut impl Rng,
) -> Option<(Plane, Vec<usize>)> {
    let cos_max = s.max_normal_angle.cos();
    // An inlier lies near the plane and, where it has a normal, agrees with it: points of
    // a neighbouring face near the corner stay out (after Schnabel et al.).
    let fits = |n: &Vector3<f64>, d: f64, i: usize| {
        (n.dot(&points[i]) + d).abs() <= s.ransac_distance && normal[i].is_none_or(|(m, _)| m.dot(n).abs() >= cos_max)
    };
    // Hypotheses are scored on at most this many of the region's points, drawn once.
    const SCORED: usize = 2000;
    let scored: Vec<usize> = if region.len() <= SCORED {
        region.to_vec()
    } else {
        (0..SCORED).map(|_| region[rng.random_range(0..region.len())]).collect()
    };
    let mut best: Option<(usize, Vector3<f64>, f64)> = None;
    for _ in 0..s.ransac_iterations {
        let [a, b, c] = [0; 3].map(|_| points[region[rng.random_range(0..region.len())]]);
        let n = (b - a).cross(&(c - a));
        if n.norm() < 1e-9 {
            continue;
        }
        let n = n.normalize();
        let d = -n.dot(&a);
        let count = scored.iter().filter(|&&i| fits(&n, d, i)).count();
        if best.is_none_or(|(k, _, _)| count > k) {
            best = Some((count, n, d));
        }
    }
    let (_, n, d) = best?;
    let inliers: Vec<usize> = region.iter().copied().filter(|&i| fits(&n, d, i)).collect();
    if inliers.len() < s.min_plane_points {
        return None;
    }
    Some((plane_of(points, normal, &inliers, s)?, inliers))
}

/// The least-squares plane of `inliers`, oriented, with the hull of all of them. The fit
/// leaves out points of high curvature: near a corner, points of the other face lie
/// within the inlier distance, and would tilt a narrow face such as a 16 cm riser.
fn plane_of(
    points: &[Vector3<f64>],
    normal: &[Option<(Vector3<f64>, f64)>],
    inliers: &[usize],
    s: &SegmentSettings,
) -> Option<Plane> {
    let flat = inliers.iter().copied().filter(|&i| normal[i].is_some_and(|(_, c)| c <= s.max_curvature));
    let (centroid, mut normal, _) = fit(points, flat)?;
    // Orientation: up for floors and ceilings, towards the viewpoint for walls.
    let flip = if normal.z.abs() >= 0.5 { normal.z < 0.0 } else { normal.dot(&(s.viewpoint - centroid)) < 0.0 };
    if flip {
        normal = -normal;
    }
    let offset = -normal.dot(&centroid);
    let polygon = hull(points, inliers, &normal, &centroid);
    Some(Plane { normal, offset, polygon, inliers: inliers.len() })
}

/// Convex hull (Andrew's monotone chain) of the inliers projected onto the plane,
/// counter-clockwise seen against the normal.
fn hull(
    points: &[Vector3<f64>],
    inliers: &[usize],
    normal: &Vector3<f64>,
    centroid: &Vector3<f64>,
) -> Vec<Vector3<f64>> {
    let u = normal.cross(&(if normal.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() })).normalize();
    let v = normal.cross(&u);
    let mut flat: Vec<Vector2<f64>> =
        inliers.iter().map(|&i| points[i] - centroid).map(|d| Vector2::new(d.dot(&u), d.dot(&v))).collect();
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
    // (u, v, n) is right-handed, so counter-clockwise in (u, v) is counter-clockwise
    // seen against the normal.
    chain.into_iter().map(|q| centroid + u * q.x + v * q.y).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
