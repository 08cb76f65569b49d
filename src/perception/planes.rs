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

/// Integer coordinates of a cubic cell.
pub(crate) type Cell = (i64, i64, i64);

/// The cell of side `size` holding `p`.
pub(crate) fn cell_of(p: &Vector3<f64>, size: f64) -> Cell {
    (floor(p.x / size), floor(p.y / size), floor(p.z / size))
}

/// `v.floor() as i64`, without the call into the C library that `floor` compiles to on
/// the baseline x86-64 target (no rounding instruction), which cost more than the
/// voxels' hashing. Exact wherever `v as i64` is, and saturating as that is.
fn floor(v: f64) -> i64 {
    let truncated = v as i64;
    truncated.saturating_sub(i64::from((truncated as f64) > v))
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
        // The last multiply mixes only upwards: its low bits, which pick the table's
        // bucket, depend on the low bits of the last coordinate alone, so neighbouring
        // cells can crowd a few buckets; the well-mixed high bits are rotated down.
        self.0.rotate_left(26)
    }
}

/// Points binned into cubes of the neighbourhood radius, cell by cell in one array: a
/// dense index over the cloud's bounding box where that box is a few cells per point (a
/// lookup is arithmetic), a hash of the occupied cells otherwise.
struct Grid {
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

impl Grid {
    fn new(points: &[Vector3<f64>], size: f64) -> Self {
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
            return Self { size, order, grouped, cells: Cells::Dense { lo, dims, starts } };
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
        Self { size, order, grouped, cells: Cells::Sparse(ranges) }
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

    /// The points of cell `k`'s 27-cell block that a neighbourhood search from a point of
    /// `k` scans, in the order it scans them: at most `cap` of each cell.
    fn block(&self, k: Cell, cap: usize, weights: &[f64], out: &mut Candidates) {
        out.clear();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let range = self.members((k.0 + dx, k.1 + dy, k.2 + dz));
                    let take = range.start..range.end.min(range.start + cap);
                    out.ids.extend_from_slice(&self.order[take.clone()]);
                    out.weights.extend(self.order[take.clone()].iter().map(|&i| weights[i as usize]));
                    out.points.extend_from_slice(&self.grouped[take]);
                }
            }
        }
    }
}

/// The candidates of a neighbourhood search shared by the points of one cell: found
/// once per cell rather than per point (27 cell look-ups each), and side by side in
/// memory for the distance tests and the fit.
#[derive(Default)]
struct Candidates {
    ids: Vec<u32>,
    points: Vec<Vector3<f64>>,
    weights: Vec<f64>,
    /// The neighbours of the current point, as positions in `ids` and `points`.
    chosen: Vec<usize>,
}

impl Candidates {
    fn clear(&mut self) {
        self.ids.clear();
        self.points.clear();
        self.weights.clear();
    }

    /// The first `cap` candidates within `radius` of `p` (`p` itself included), into
    /// `chosen`.
    fn choose(&mut self, p: &Vector3<f64>, radius: f64, cap: usize) {
        // Without a branch on the distance: a third of a block's points are within the
        // radius, in no pattern a branch predictor learns, and the mispredictions were
        // most of the search. Each candidate is written, and kept by counting it.
        self.chosen.clear();
        self.chosen.resize(self.points.len(), 0);
        let r2 = radius * radius;
        let mut kept = 0;
        for (k, q) in self.points.iter().enumerate() {
            self.chosen[kept] = k;
            kept += usize::from((q - p).norm_squared() <= r2);
            if kept >= cap {
                break;
            }
        }
        self.chosen.truncate(kept);
    }
}

/// A voxel is a surface's noise tail when a face neighbour holds more than this many
/// times its weight and the neighbour on the opposite side is empty.
pub const TAIL_RATIO: f64 = 4.0;

/// The weighted centroid of the points in each occupied voxel of side `size` and the
/// voxel's total weight, in first-seen order, without the surfaces' noise tails.
///
/// Why the tails go: range noise spreads a surface's returns into the voxels on either
/// side of the one it lies in, and each of those holds the centroid of one tail of the
/// noise, near its boundary with the surface's voxel, 1–1.5 cm off the surface. A tread
/// halfway between voxel boundaries then shows as three layers, which a plane fit reads
/// as a tilt. A tail holds a few percent of the surface's weight and has nothing beyond
/// it. A surface near a boundary splits between two voxels in comparable shares, and
/// both stay; a surface's last voxel at its border goes only when it is less than a
/// quarter covered, which moves the border by under a quarter of a voxel.
fn voxel_centroids(
    points: &[Vector3<f64>],
    weights: &[f64],
    size: f64,
    threads: usize,
) -> (Vec<Vector3<f64>>, Vec<f64>) {
    // The voxels are shared out among the threads by their cell's hash; each sums its own
    // in the points' order, as one thread would.
    let hasher = std::hash::BuildHasherDefault::<CellHasher>::default();
    let share_of = |c: &Cell| ((std::hash::BuildHasher::hash_one(&hasher, c) >> 32) % threads as u64) as usize;
    let shares: Vec<VoxelShare> = parallel_map(threads, threads, |share| {
        let expected = points.len() / 2 / threads;
        let mut own = VoxelShare {
            slot: HashMap::with_capacity_and_hasher(expected, Default::default()),
            cells: Vec::with_capacity(expected),
            sums: Vec::with_capacity(expected),
            first: Vec::with_capacity(expected),
        };
        // A scan's consecutive returns often fall in one voxel: that one is looked up once.
        let mut last: Option<(Cell, usize)> = None;
        for (i, (p, &w)) in points.iter().zip(weights).enumerate() {
            let cell = Grid::cell(p, size);
            let k = match last {
                Some((c, k)) if c == cell => k,
                _ if threads > 1 && share_of(&cell) != share => continue,
                _ => *own.slot.entry(cell).or_insert_with(|| {
                    own.cells.push(cell);
                    own.sums.push((Vector3::zeros(), 0.0));
                    own.first.push(i);
                    own.sums.len() - 1
                }),
            };
            last = Some((cell, k));
            own.sums[k].0 += p * w;
            own.sums[k].1 += w;
        }
        own
    });
    // Back into first-seen order: each share's voxels are in it already.
    let mut order: Vec<(usize, usize)> = Vec::with_capacity(shares.iter().map(|v| v.cells.len()).sum());
    let mut next = vec![0; shares.len()];
    while let Some(share) =
        (0..shares.len()).filter(|&v| next[v] < shares[v].first.len()).min_by_key(|&v| shares[v].first[next[v]])
    {
        order.push((share, next[share]));
        next[share] += 1;
    }
    let weight_at = |c: Cell| {
        let share = &shares[if threads > 1 { share_of(&c) } else { 0 }];
        share.slot.get(&c).map_or(0.0, |&k| share.sums[k].1)
    };
    let is_tail = |(share, k): (usize, usize)| {
        let ((x, y, z), w) = (shares[share].cells[k], shares[share].sums[k].1);
        let tail = |a: Cell, b: Cell| weight_at(a) > TAIL_RATIO * w && weight_at(b) == 0.0;
        let sides = [((x, y, z - 1), (x, y, z + 1)), ((x - 1, y, z), (x + 1, y, z)), ((x, y - 1, z), (x, y + 1, z))];
        sides.iter().any(|&(a, b)| tail(a, b) || tail(b, a))
    };
    // Six look-ups per voxel, read-only: shared out in runs.
    let run = order.len().div_ceil(threads * PARTS_PER_THREAD).max(1);
    let tails: Vec<Vec<bool>> = parallel_map(order.len().div_ceil(run), threads, |r| {
        order[r * run..((r + 1) * run).min(order.len())].iter().map(|&v| is_tail(v)).collect()
    });
    order
        .iter()
        .zip(tails.iter().flatten())
        .filter(|(_, &tail)| !tail)
        .map(|(&(share, k), _)| {
            let (sum, w) = shares[share].sums[k];
            (sum / w, w)
        })
        .unzip()
}

/// The voxels one thread sums.
struct VoxelShare {
    slot: HashMap<Cell, usize, std::hash::BuildHasherDefault<CellHasher>>,
    cells: Vec<Cell>,
    sums: Vec<(Vector3<f64>, f64)>,
    /// The first point in each.
    first: Vec<usize>,
}

/// A least-squares plane: where it passes, which way it faces, how far the points bend
/// away from it, and how far they scatter about it.
struct Fit {
    centroid: Vector3<f64>,
    normal: Vector3<f64>,
    /// The smallest eigenvalue of the scatter over their sum.
    curvature: f64,
    /// Weighted mean square distance of the points from the plane \[m²\].
    variance: f64,
}

/// Weighted least-squares plane through `points[idx]`, or `None` when they span no plane
/// (fewer than three, or all on one point or one line). One pass: the sums are taken
/// about the first point, which keeps them as well conditioned as about the centroid for
/// a neighbourhood, and the scatter is their second moment less the mean's.
fn fit(points: &[Vector3<f64>], weights: &[f64], idx: impl Iterator<Item = usize>) -> Option<Fit> {
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

/// Clouds of at least this many points (before thinning) are segmented on several
/// threads.
const PARALLEL_FROM: usize = 20_000;
/// Most threads one segmentation uses.
const MAX_THREADS: usize = 8;
/// The neighbourhoods are gathered in this many runs of points per thread, from a work
/// queue: the runs' costs differ (where surfaces meet, more cells are full).
const PARTS_PER_THREAD: usize = 8;

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

/// `f(0), …, f(count - 1)` on up to `threads` threads, in order. Each thread takes the
/// next index left, so one large item (the floor) does not hold back a share of the rest.
fn parallel_map<R: Send>(count: usize, threads: usize, f: impl Fn(usize) -> R + Sync) -> Vec<R> {
    if threads <= 1 || count <= 1 {
        return (0..count).map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut done: Vec<(usize, R)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads.min(count))
            .map(|_| {
                scope.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if i >= count {
                            break mine;
                        }
                        mine.push((i, f(i)));
                    }
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))).collect()
    });
    done.sort_unstable_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, r)| r).collect()
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

/// The inlier distance of a plane through `members`: three times the median scatter of
/// their neighbourhoods about their local planes, within \[a quarter, all\] of the
/// setting. The setting is for raw returns; averaged map voxels scatter a millimetre or
/// two, and a centimetre would let a plane tilted through the treads of a shallow flight
/// (a ramp) gather as many inliers as one tread.
fn inlier_distance(cloud: &Cloud<'_>, members: &[usize], s: &SegmentSettings) -> f64 {
    let mut scatter: Vec<f64> = members.iter().map(|&i| cloud.scatter[i]).filter(|d| d.is_finite()).collect();
    if scatter.is_empty() {
        return s.ransac_distance;
    }
    let mid = scatter.len() / 2;
    let (_, median, _) = scatter.select_nth_unstable_by(mid, f64::total_cmp);
    (3.0 * *median).clamp(0.25 * s.ransac_distance, s.ransac_distance)
}

/// Fewest RANSAC hypotheses per plane.
const MIN_HYPOTHESES: usize = 20;

/// Refits of a RANSAC plane on its connected inliers.
const LOCAL_STEPS: usize = 2;

/// Most planes one region is split into.
const MAX_PLANES_PER_REGION: usize = 8;

/// The planes of a region: RANSAC, then again on what the plane left, while enough is
/// left. A region can hold more than one plane: below a step lower than the neighbour
/// radius, the normals turn from floor to riser to tread in small steps, and growth runs
/// over the edge.
fn refine(cloud: &Cloud<'_>, region: &[usize], s: &SegmentSettings, rng: &mut impl Rng) -> Vec<(Plane, Vec<usize>)> {
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
fn best_plane(
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
fn plane_of(cloud: &Cloud<'_>, inliers: &[usize], s: &SegmentSettings) -> Option<Plane> {
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

/// The half-spaces `inward · p >= limit` of a convex polygon's edges (counter-clockwise
/// seen against `normal`), each moved in by its margin; edges of no margin are left out.
fn shrunk_edges(polygon: &[Vector3<f64>], margins: &[f64], normal: &Vector3<f64>) -> Vec<(Vector3<f64>, f64)> {
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
    drop_interior(&mut flat);
    // (u, v, n) is right-handed, so counter-clockwise in (u, v) is counter-clockwise
    // seen against the normal.
    monotone_chain(flat).into_iter().map(|q| centroid + u * q.x + v * q.y).collect()
}

/// The convex hull's vertices, counter-clockwise from the lowest-x point, without
/// collinear ones (Andrew's monotone chain).
fn monotone_chain(mut flat: Vec<Vector2<f64>>) -> Vec<Vector2<f64>> {
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
fn drop_interior(flat: &mut Vec<Vector2<f64>>) {
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

#[cfg(test)]
mod tests {
    use super::*;

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
