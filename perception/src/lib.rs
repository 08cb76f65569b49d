//! Terrain perception (Tachyon 3 paper, section III-A): what the filter sees of the world
//! when it is not handed the ground truth.
//!
//! * [`scanner`] — a simulated spinning LiDAR, ray-cast against terrain boxes, with
//!   range noise, dropouts and the robot's own body in the way;
//! * [`planes`] — normals from each point's neighbourhood, region growing on normal
//!   angle and curvature, a RANSAC refit per region and each plane's convex hull;
//! * [`edges`] — an edge cuboid along each level plane's hull edge where the terrain
//!   drops beyond it (a step's nosing), and the floor height under a point;
//! * [`map`] — the accumulated map, one centroid per voxel;
//! * [`worker`] — all of the above on its own thread, beside a control loop that never
//!   waits for it;
//! * [`figure`] — side and top views of what was found over the truth (`cbfgen perceive`).
//!
//! Generic: nothing here knows a robot. Degenerate input (no points, points on a line,
//! a million points in one spot) gives no planes; non-finite input is a typed error.
//!
//! ```
//! use cbfgen_perception::{edges, planes, scanner::Lidar};
//! use cbfgen::OrientedBox;
//! use nalgebra::Vector3;
//! use rand::SeedableRng;
//!
//! // A floor and one 16.5 cm step 1 m ahead, scanned from 0.6 m up at three points of
//! // the approach, the scans accumulated into one map.
//! let terrain = [
//!     OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, -0.5), Vector3::new(4.0, 2.0, 0.5))?,
//!     OrientedBox::axis_aligned(Vector3::new(2.0, 0.0, 0.0825), Vector3::new(1.0, 1.0, 0.0825))?,
//! ];
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
//! let mut points = Vec::new();
//! for x in [0.0, 0.3, 0.6] {
//!     points.extend(Lidar::default().scan(&Vector3::new(x, 0.0, 0.6), 0.0, &terrain, &[], &mut rng)?);
//! }
//! let settings = planes::SegmentSettings { viewpoint: Vector3::new(0.0, 0.0, 0.6), ..Default::default() };
//! let found = planes::segment(&points, &settings)?;
//! let nosings = edges::edge_cuboids(&found, &points, &edges::EdgeSettings::default())?;
//! assert!(nosings.iter().any(|c| (c.center().x - 1.025).abs() < 0.03));
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

#![warn(missing_docs)]

pub mod edges;
pub mod figure;
pub mod map;
pub mod planes;
pub mod scanner;
pub mod worker;
