//! The spatial hash every neighbourhood query runs on (points binned into cubic cells),
//! and the voxel centroids that thin a cloud before segmentation.

use super::parallel::{parallel_map, PARTS_PER_THREAD};
use std::collections::HashMap;

use nalgebra::Vector3;

/// Integer coordinates of a cubic cell.
pub(crate) type Cell = (i64, i64, i64);

/// The cell of side `size` holding `p`.
pub(crate) fn cell_of(p: &Vector3<f64>, size: f64) -> Cell {
    (floor(p.x / size), floor(p.y / size), floor(p.z / size))
}

/// `v.floor() as i64`, without the call into the C library that `floor` compiles to on
/// the baseline x86-64 target (no rounding instruction), which cost more than the
/// voxels' hashing. Exact wherever `v as i64` is, and saturating as that is.
pub(super) fn floor(v: f64) -> i64 {
    let truncated = v as i64;
    truncated.saturating_sub(i64::from((truncated as f64) > v))
}

/// A multiply-rotate hash for cell keys: the grid is queried 27 times per point per pass,
/// and SipHash (the standard map's default, resistant to chosen keys, which cell indices
/// of a point cloud are not) was most of a segmentation's time.
#[derive(Default)]
pub(super) struct CellHasher(u64);

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
pub(super) struct Grid {
    pub(super) size: f64,
    /// Point indices, grouped by cell.
    pub(super) order: Vec<u32>,
    /// The points in `order`'s order: a cell's points lie side by side in memory.
    pub(super) grouped: Vec<Vector3<f64>>,
    pub(super) cells: Cells,
}

pub(super) enum Cells {
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
    pub(super) fn new(points: &[Vector3<f64>], size: f64) -> Self {
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

    pub(super) fn cell(p: &Vector3<f64>, size: f64) -> Cell {
        cell_of(p, size)
    }

    /// Where the points of cell `k` lie in `order` and `grouped`.
    pub(super) fn members(&self, k: Cell) -> std::ops::Range<usize> {
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
    pub(super) fn block(&self, k: Cell, cap: usize, weights: &[f64], out: &mut Candidates) {
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
pub(super) struct Candidates {
    pub(super) ids: Vec<u32>,
    pub(super) points: Vec<Vector3<f64>>,
    pub(super) weights: Vec<f64>,
    /// The neighbours of the current point, as positions in `ids` and `points`.
    pub(super) chosen: Vec<usize>,
}

impl Candidates {
    pub(super) fn clear(&mut self) {
        self.ids.clear();
        self.points.clear();
        self.weights.clear();
    }

    /// The first `cap` candidates within `radius` of `p` (`p` itself included), into
    /// `chosen`.
    pub(super) fn choose(&mut self, p: &Vector3<f64>, radius: f64, cap: usize) {
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
pub(super) fn voxel_centroids(
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
pub(super) struct VoxelShare {
    pub(super) slot: HashMap<Cell, usize, std::hash::BuildHasherDefault<CellHasher>>,
    pub(super) cells: Vec<Cell>,
    pub(super) sums: Vec<(Vector3<f64>, f64)>,
    /// The first point in each.
    pub(super) first: Vec<usize>,
}
