//! The accumulated point map: scans added as they come, thinned to one centroid per
//! voxel (so a map that has seen the same ground a hundred times holds it once, and the
//! noise averages out), cut to the neighbourhood of the robot before each perception
//! update.

use std::collections::BTreeMap;

use nalgebra::Vector3;

use super::planes::{cell_of, Cell, MAX_POINTS};
use cbfgen::error::{within, CbfError};

/// Largest coordinate a mapped point may have \[m\].
pub const MAX_COORDINATE: f64 = 1e5;

/// Voxels of one size, each holding the sum and count of the points that fell in it.
/// Ordered by cell, so the same scans give the same map, point for point.
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelMap {
    voxel: f64,
    cells: BTreeMap<Cell, (Vector3<f64>, u32)>,
}

impl VoxelMap {
    /// An empty map of cubic voxels of side `voxel` \[m\].
    ///
    /// # Errors
    /// A voxel outside \[1e-4, 10\] m.
    pub fn new(voxel: f64) -> Result<Self, CbfError> {
        within("map voxel [m]", voxel, 1e-4, 10.0, "[1e-4, 10]")?;
        Ok(Self { voxel, cells: BTreeMap::new() })
    }

    /// Add the points of one scan (world frame).
    ///
    /// # Errors
    /// A coordinate that is not finite or beyond ±[`MAX_COORDINATE`], or a map that would
    /// grow past [`MAX_POINTS`] voxels; the map is then left as it was.
    pub fn insert(&mut self, points: &[Vector3<f64>]) -> Result<(), CbfError> {
        for p in points {
            for &c in p.iter() {
                within("map point coordinate [m]", c, -MAX_COORDINATE, MAX_COORDINATE, "[-1e5, 1e5]")?;
            }
        }
        if self.cells.len().saturating_add(points.len()) > MAX_POINTS {
            return Err(CbfError::TooLarge {
                what: "map voxels",
                value: self.cells.len().saturating_add(points.len()),
                max: MAX_POINTS,
            });
        }
        for p in points {
            let slot = self.cells.entry(cell_of(p, self.voxel)).or_insert((Vector3::zeros(), 0));
            slot.0 += p;
            slot.1 = slot.1.saturating_add(1);
        }
        Ok(())
    }

    /// Voxels held.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether no point was added (or all were forgotten).
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The centroid of every voxel within horizontal distance `radius` of `center`, in
    /// cell order, and how many points each averages (the weights
    /// [`segment_weighted`](super::planes::segment_weighted) takes).
    pub fn points_near(&self, center: &Vector3<f64>, radius: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
        self.cells
            .values()
            .map(|(sum, n)| (sum / f64::from(*n), f64::from(*n)))
            .filter(|(p, _)| (p.xy() - center.xy()).norm() <= radius)
            .unzip()
    }

    /// Drop the voxels farther than `radius` (horizontally) from `center`: bounds the
    /// memory of a long run.
    pub fn forget_beyond(&mut self, center: &Vector3<f64>, radius: f64) {
        let voxel = self.voxel;
        self.cells.retain(|k, _| {
            let mid = Vector3::new(k.0 as f64 + 0.5, k.1 as f64 + 0.5, k.2 as f64 + 0.5) * voxel;
            (mid.xy() - center.xy()).norm() <= radius + voxel
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_points_average_into_one_voxel_and_far_ones_are_forgotten() {
        let mut map = VoxelMap::new(0.02).unwrap();
        map.insert(&[Vector3::new(0.001, 0.001, 0.001), Vector3::new(0.003, 0.005, 0.007)]).unwrap();
        map.insert(&[Vector3::new(5.0, 0.0, 0.0)]).unwrap();
        assert_eq!(map.len(), 2);
        let (near, counts) = map.points_near(&Vector3::zeros(), 1.0);
        assert_eq!((near.len(), counts), (1, vec![2.0]));
        assert!((near[0] - Vector3::new(0.002, 0.003, 0.004)).norm() < 1e-15);
        map.forget_beyond(&Vector3::zeros(), 1.0);
        assert_eq!(map.len(), 1);
        assert!(map.insert(&[Vector3::new(f64::NAN, 0.0, 0.0)]).is_err());
        assert!(map.insert(&[Vector3::new(1e300, 0.0, 0.0)]).is_err());
        assert_eq!(map.len(), 1);
        assert!(VoxelMap::new(0.0).is_err() && VoxelMap::new(f64::INFINITY).is_err());
    }
}
