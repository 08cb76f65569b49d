//! Tachyon 3 on perceived terrain: a LiDAR on the body scans the true terrain at 10 Hz,
//! a [`Worker`] thread turns the accumulated map into planes and edge cuboids at 1 Hz,
//! and the [`Course`]'s gait and filter see only that (paper section III-A).
//!
//! * [`ground_from_planes`] — the ground along the path from the level planes: at each x
//!   the highest plane whose hull the path crosses;
//! * [`Perceiver`] — the loop: scan, hand over, request, apply the result a fixed latency
//!   after its request.
//!
//! The control update never waits for perception. A simulation is not real time, so
//! [`Perceiver::step`] waits for each result at its due time (request + `latency` of
//! simulated time); that makes a run reproducible, and models a perception that takes
//! `latency` to answer.

use std::time::Duration;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::catalog::EdgeCuboid;
use crate::generated as gen;
use crate::model::{self, State, TOE_RADIUS};
use crate::sim::gait::FOOTHOLD_INSET;
use crate::sim::Course;
use crate::terrain::{Level, Profile, Terrain};
use cbfgen::error::{within, CbfError};
use cbfgen::geometry::OrientedBox;
use cbfgen::sphere_box;
use cbfgen_perception::planes::Plane;
use cbfgen_perception::scanner::Lidar;
use cbfgen_perception::worker::{Perceived, Worker, WorkerSettings};

/// Planes closer than this in height along the path merge into one level \[m\].
const SAME_LEVEL: f64 = 0.01;
/// A level shorter than this between two others is a sliver of hull noise, and joins the
/// level before it \[m\].
const SLIVER: f64 = 0.03;

/// Narrowest half width of a level the gait may stand on \[m\]: room for a foothold strip,
/// whose toe centres keep [`FOOTHOLD_INSET`] from its sides, and 3 cm more.
pub const MIN_HALF_WIDTH: f64 = FOOTHOLD_INSET + 0.03;

/// What the robot perceives with, and how often.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerceptionSettings {
    /// The sensor.
    pub lidar: Lidar,
    /// Where it sits in the body frame (x forward, z up from the body centre) \[m\]; it
    /// turns with the body.
    pub mount: [f64; 3],
    /// Time between scans \[s\].
    pub scan_period: f64,
    /// Time between perception updates \[s\].
    pub update_period: f64,
    /// Time from an update's request to its result reaching the gait and filter \[s\].
    pub latency: f64,
    /// The map and the segmentation.
    pub worker: WorkerSettings,
    /// Each perceived edge cuboid is widened this much beyond its edge, off the step
    /// (not over the tread, where the wheels stand) \[m\]: an edge is found up to about
    /// 3 cm short of where it is (a far rim seen at grazing angles).
    pub edge_margin: f64,
    /// ... and raised this much above the perceived tread \[m\]: a tread's height is
    /// found a few millimetres off, and a wheel rolling over the nosing follows the
    /// cuboid's top.
    pub edge_lift: f64,
    /// Every perceived level is raised this much for the gait and the floors under the
    /// wheels \[m\]: a tread's plane is found up to a few millimetres low (2.1 mm at
    /// worst in 20 episodes of rises 17.5–20 cm, seed 777), and a floor read low lets
    /// the foot-height rows hold a wheel that far into the true tread. On a physical
    /// robot the tread itself stops a wheel, and a level read high leaves the wheels
    /// landing on it unloaded: there a lift of zero or below (down to −5 cm) is the safer
    /// side.
    pub floor_lift: f64,
    /// Seed of the scans' noise and dropouts.
    pub seed: u64,
}

impl Default for PerceptionSettings {
    /// The default [`Lidar`] on a mast 0.35 m ahead of the body centre and 0.4 m above it
    /// (0.6 m above flat ground in the standard posture; assumed, the paper does not give
    /// the mounting), 10 Hz scans, 1 Hz updates answered 0.5 s after their request, edge
    /// cuboids widened by 3 cm and raised by 5 mm, levels raised by 4 mm.
    fn default() -> Self {
        Self {
            lidar: Lidar::default(),
            mount: [0.35, 0.0, 0.4],
            scan_period: 0.1,
            update_period: 1.0,
            latency: 0.5,
            worker: WorkerSettings::default(),
            edge_margin: 0.03,
            edge_lift: 0.005,
            floor_lift: 0.004,
            seed: 1,
        }
    }
}

impl PerceptionSettings {
    /// # Errors
    /// A setting outside its domain, named: the mount beyond 2 m of the body centre, a
    /// scan period outside \[1 ms, 10 s\], an update period shorter than the scan period
    /// or above 60 s, a latency longer than the update period.
    pub fn validate(&self) -> Result<(), CbfError> {
        self.lidar.validate()?;
        for &c in &self.mount {
            within("lidar mount [m]", c, -2.0, 2.0, "[-2, 2]")?;
        }
        within("scan period [s]", self.scan_period, 1e-3, 10.0, "[0.001, 10]")?;
        within("update period [s]", self.update_period, self.scan_period, 60.0, "[scan period, 60]")?;
        within("perception latency [s]", self.latency, 0.0, self.update_period, "[0, update period]")?;
        within("edge margin [m]", self.edge_margin, 0.0, 0.5, "[0, 0.5]")?;
        within("edge lift [m]", self.edge_lift, 0.0, 0.5, "[0, 0.5]")?;
        within("floor lift [m]", self.floor_lift, -0.05, 0.5, "[-0.05, 0.5]")?;
        self.worker.validate()
    }
}

/// Where a convex polygon (x, y of its vertices) crosses the line where coordinate
/// `axis` (0: x, 1: y) equals `at`: the interval of the other coordinate, if any.
fn chord(polygon: &[Vector3<f64>], axis: usize, at: f64) -> Option<(f64, f64)> {
    let other = 1 - axis;
    let n = polygon.len();
    let mut range: Option<(f64, f64)> = None;
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
        let (da, db) = (a[axis] - at, b[axis] - at);
        if da * db > 0.0 || (da == 0.0 && db == 0.0) {
            continue;
        }
        let v = if da == db { a[other] } else { a[other] + (b[other] - a[other]) * da / (da - db) };
        range = Some(range.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))));
    }
    range
}

/// The ground along the path (y = 0) from perceived planes: at each x, the highest plane
/// within `max_tilt` of level whose hull the path crosses there (a floor's hull can
/// reach under the steps; the tread above is what a toe meets). Stretches no plane
/// covers take the level before them, or the first level seen if they lie before it.
/// Levels within 1 cm of each other in height merge, slivers under 3 cm join the level
/// before, and each level's half width is the hull's, measured across the path at the
/// stretch's middle; a level narrower than [`MIN_HALF_WIDTH`] is not one to stand
/// on, and is left out. `None` when no plane is left.
pub fn ground_from_planes(planes: &[Plane], max_tilt: f64) -> Option<Profile> {
    struct Stretch {
        lo: f64,
        hi: f64,
        height: f64,
        half_width: f64,
    }
    let stretches: Vec<Stretch> = planes
        .iter()
        .filter(|p| p.normal.z >= max_tilt.cos() && p.polygon.len() >= 3)
        .filter_map(|p| {
            let (lo, hi) = chord(&p.polygon, 1, 0.0)?;
            let mid = 0.5 * (lo + hi);
            let (y_lo, y_hi) = chord(&p.polygon, 0, mid)?;
            let half_width = (-y_lo).min(y_hi);
            (hi > lo && half_width > MIN_HALF_WIDTH).then(|| Stretch {
                lo,
                hi,
                height: p.height_at(mid, 0.0),
                half_width,
            })
        })
        .collect();
    let mut xs: Vec<f64> = stretches.iter().flat_map(|s| [s.lo, s.hi]).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    // Elementary pieces between consecutive ends: the highest stretch over each; a gap
    // before a piece belongs to the level before it.
    let mut pieces: Vec<Level> = Vec::new();
    for w in xs.windows(2) {
        let mid = 0.5 * (w[0] + w[1]);
        let covering = stretches.iter().filter(|s| s.lo <= mid && mid <= s.hi);
        let Some(top) = covering.max_by(|a, b| a.height.total_cmp(&b.height)) else { continue };
        if let Some(last) = pieces.last_mut() {
            last.end = w[0];
        }
        pieces.push(Level { begin: w[0], end: w[1], height: top.height, half_width: top.half_width });
    }
    // Interior slivers join the level before them; then equal heights merge.
    let count = pieces.len();
    let mut levels: Vec<Level> = Vec::with_capacity(count);
    for (k, piece) in pieces.into_iter().enumerate() {
        match levels.last_mut() {
            Some(last)
                if (last.height - piece.height).abs() < SAME_LEVEL
                    || (piece.end - piece.begin < SLIVER && k + 1 < count) =>
            {
                last.end = piece.end;
                if (last.height - piece.height).abs() < SAME_LEVEL {
                    last.half_width = last.half_width.min(piece.half_width);
                }
            }
            _ => levels.push(piece),
        }
    }
    let first = levels.first_mut()?;
    first.begin = f64::NEG_INFINITY;
    levels.last_mut()?.end = f64::INFINITY;
    Profile::new(levels).ok()
}

/// One perception update of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct PerceptionUpdate {
    /// Simulated time of the request \[s\].
    pub requested_at: f64,
    /// Simulated time the result reached the gait and filter \[s\].
    pub applied_at: f64,
    /// Map points (voxel centroids) segmented.
    pub map_points: usize,
    /// Planes found.
    pub planes: usize,
    /// Levels of the perceived ground along the path (0: none seen, the last kept).
    pub levels: usize,
    /// Wall time of the update on the worker thread.
    pub elapsed: Duration,
    /// Every edge found, as the box handed to the filter: the edge cuboid reaching down
    /// to the level below its drop (over the riser), widened and raised as
    /// [`PerceptionSettings`] say, nearest the body first (the filter takes the nearest,
    /// up to its capacity).
    pub edges: Vec<OrientedBox>,
    /// The ground the gait stood on from then on.
    pub ground: Profile,
}

/// Scans, requests and applies perception updates for one run.
#[derive(Debug)]
pub struct Perceiver {
    settings: PerceptionSettings,
    world: Vec<OrientedBox>,
    worker: Worker,
    rng: ChaCha8Rng,
    next_scan: f64,
    next_request: f64,
    /// (request time, due time) of the update in flight.
    in_flight: Option<(f64, f64)>,
    updates: Vec<PerceptionUpdate>,
    last: Option<Perceived>,
}

impl Perceiver {
    /// Perception of `terrain` (its solid boxes are what the scanner sees).
    ///
    /// # Errors
    /// Invalid settings, or a worker thread that would not start.
    pub fn new(settings: PerceptionSettings, terrain: &Terrain) -> Result<Self, CbfError> {
        settings.validate()?;
        Ok(Self {
            settings,
            world: terrain.solid_boxes()?,
            worker: Worker::spawn(settings.worker)?,
            rng: ChaCha8Rng::seed_from_u64(settings.seed),
            next_scan: 0.0,
            next_request: 0.0,
            in_flight: None,
            updates: Vec::new(),
            last: None,
        })
    }

    /// Look before moving: one scan, and its update applied to `course` at once (the
    /// robot stands still for it). Before any plane is seen, the ground is taken flat at
    /// the wheels' mean height, which the legs know without looking.
    ///
    /// # Errors
    /// A state outside the model's domain; a failed update.
    pub fn start(&mut self, x: &State, course: &mut Course) -> Result<(), CbfError> {
        self.start_estimated(x, x, course)
    }

    /// [`Perceiver::start`] for a robot at `truth` that believes it is at `estimate` (see
    /// [`Perceiver::step_estimated`]).
    ///
    /// # Errors
    /// Either state outside the model's domain; a failed update.
    pub fn start_estimated(&mut self, truth: &State, estimate: &State, course: &mut Course) -> Result<(), CbfError> {
        let x = estimate;
        self.scan_from(truth, estimate)?;
        self.request(0.0, x)?;
        let (_, _, toes) = gen::world_kinematics(x);
        let height = toes.iter().map(|t| t[2] - TOE_RADIUS).sum::<f64>() / 6.0;
        let flat = Level { begin: f64::NEG_INFINITY, end: f64::INFINITY, height, half_width: 1.0 };
        course.set_perceived(Profile::new(vec![flat])?, &[])?;
        self.apply(0.0, x, course)?;
        self.next_scan = self.settings.scan_period;
        self.next_request = self.settings.update_period;
        Ok(())
    }

    /// Before the control cycle at time `t`: scan if a scan is due, request an update if
    /// one is due, and apply the update in flight if its latency has passed.
    ///
    /// # Errors
    /// A state outside the model's domain; a failed update.
    pub fn step(&mut self, t: f64, x: &State, course: &mut Course) -> Result<(), CbfError> {
        self.step_estimated(t, x, x, course)
    }

    /// [`Perceiver::step`] for a robot that is at `truth` but believes it is at
    /// `estimate` (its state estimate, with drift and noise): the LiDAR's rays leave from
    /// the true sensor pose and meet the true terrain, and each return is placed in the
    /// map from the estimated pose, as a robot registering scans by its odometry does.
    /// Requests and the gait's new ground and edges use the estimate.
    ///
    /// # Errors
    /// Either state outside the model's domain; a failed update.
    pub fn step_estimated(
        &mut self,
        t: f64,
        truth: &State,
        estimate: &State,
        course: &mut Course,
    ) -> Result<(), CbfError> {
        let x = estimate;
        // Half a cycle of slack: `t` is k · DT, which rounds.
        let slack = 0.5 * super::DT;
        if t + slack >= self.next_scan {
            self.scan_from(truth, estimate)?;
            self.next_scan += self.settings.scan_period;
        }
        if self.in_flight.is_none() && t + slack >= self.next_request {
            self.request(t, x)?;
            self.next_request += self.settings.update_period;
        }
        if let Some((_, due)) = self.in_flight {
            if t + slack >= due {
                self.apply(t, x, course)?;
            }
        }
        Ok(())
    }

    /// Updates applied so far.
    pub fn updates(&self) -> usize {
        self.updates.len()
    }

    /// Hand the map and what was found in it over: (updates, last result).
    pub fn finish(self) -> (Vec<PerceptionUpdate>, Option<Perceived>) {
        (self.updates, self.last)
    }

    /// The sensor's world position on `body` (it turns with the body).
    fn sensor_at(&self, body: &OrientedBox) -> Vector3<f64> {
        body.center() + body.rotation() * Vector3::from(self.settings.mount)
    }

    /// One scan cast from `x`'s sensor pose, registered at `estimate`'s.
    fn scan_from(&mut self, x: &State, estimate: &State) -> Result<(), CbfError> {
        model::validate_state(x)?;
        model::validate_state(estimate)?;
        let body = model::body_box(x)?;
        let origin = self.sensor_at(&body);
        let orientation = *body.rotation();
        let believed = model::body_box(estimate)?;
        let (believed_origin, believed_orientation) = (self.sensor_at(&believed), *believed.rotation());
        // The robot's own body and wheels hide what is behind them.
        let (_, _, toes) = gen::world_kinematics(x);
        let mut own = vec![body];
        for toe in toes {
            own.push(OrientedBox::axis_aligned(Vector3::from(toe), Vector3::repeat(TOE_RADIUS))?);
        }
        let mut points = self.settings.lidar.scan_oriented(&origin, &orientation, &self.world, &own, &mut self.rng)?;
        if x != estimate {
            // Sensor frame from the true pose, world frame again from the believed one.
            let register = believed_orientation * orientation.inverse();
            for p in &mut points {
                *p = believed_origin + register * (*p - origin);
            }
        }
        self.worker.add_scan(points)
    }

    fn request(&mut self, t: f64, x: &State) -> Result<(), CbfError> {
        let body = model::body_box(x)?;
        self.worker.request(body.center(), &self.sensor_at(&body))?;
        self.in_flight = Some((t, t + self.settings.latency));
        Ok(())
    }

    fn apply(&mut self, t: f64, x: &State, course: &mut Course) -> Result<(), CbfError> {
        let Some((requested_at, _)) = self.in_flight.take() else { return Ok(()) };
        let perceived = self.worker.wait_result()?;
        let ground = ground_from_planes(&perceived.planes, self.settings.worker.edges.max_tilt)
            .map(|g| g.lifted(self.settings.floor_lift))
            .transpose()?;
        let body = model::body_box(x)?;
        let mut nearest = perceived
            .cuboids
            .iter()
            .zip(&perceived.lower_levels)
            .map(|(c, &lower)| {
                let grown = riser_box(c, lower, self.settings.edge_margin, self.settings.edge_lift)?;
                Ok((sphere_box::exact_distance(body.center(), 0.0, c), grown))
            })
            .collect::<Result<Vec<(f64, OrientedBox)>, CbfError>>()?;
        nearest.sort_by(|a, b| a.0.total_cmp(&b.0));
        let edge_boxes: Vec<OrientedBox> = nearest.into_iter().map(|(_, b)| b).collect();
        let edges: Vec<EdgeCuboid> = edge_boxes.iter().map(EdgeCuboid::from_box).collect();
        let levels = ground.as_ref().map_or(0, |g| g.levels().len());
        let ground = ground.unwrap_or_else(|| course.ground().clone());
        course.set_perceived(ground.clone(), &edges)?;
        self.updates.push(PerceptionUpdate {
            requested_at,
            applied_at: t,
            map_points: perceived.points.len(),
            planes: perceived.planes.len(),
            levels,
            elapsed: perceived.elapsed,
            edges: edge_boxes,
            ground,
        });
        self.last = Some(perceived);
        Ok(())
    }
}

/// The box the filter keeps the robot out of for a perceived edge: `cuboid` reaching
/// down to `lower`, the level seen below its drop (so that it covers the riser as well as
/// the nosing, as [`Terrain::riser_boxes`] does on the true terrain), grown by `margin`
/// on its outer side, off the step, and by `lift` on its top. The cuboid's local y points
/// into the plane above the edge and its local z up, level
/// ([`edge_cuboids`](cbfgen_perception::edges::edge_cuboids)). A `lower` above the
/// cuboid's own bottom (a drop under its section) leaves the bottom where it is.
///
/// # Errors
/// None for a cuboid [`edge_cuboids`](cbfgen_perception::edges::edge_cuboids) found (the
/// box is checked again).
fn riser_box(cuboid: &OrientedBox, lower: f64, margin: f64, lift: f64) -> Result<OrientedBox, CbfError> {
    let r = cuboid.rotation();
    let (c, half) = (cuboid.center(), cuboid.half_extents());
    // The cuboid is level, so its local z is the world's: its top and bottom are heights.
    let top = c.z + half.z + lift;
    let bottom = (c.z - half.z).min(lower);
    let center = Vector3::new(c.x, c.y, 0.5 * (top + bottom)) - r * Vector3::new(0.0, 0.5 * margin, 0.0);
    OrientedBox::new(center, *r, Vector3::new(half.x, half.y + 0.5 * margin, 0.5 * (top - bottom)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level_plane(height: f64, x: [f64; 2], y: [f64; 2]) -> Plane {
        Plane {
            normal: Vector3::z(),
            offset: -height,
            polygon: vec![
                Vector3::new(x[0], y[0], height),
                Vector3::new(x[1], y[0], height),
                Vector3::new(x[1], y[1], height),
                Vector3::new(x[0], y[1], height),
            ],
            inliers: 1000,
        }
    }

    /// A nosing cuboid along y at x = 1 m, top at 0.2 m, its local y into the step (+x):
    /// the box reaches down to the floor seen at 0.02 m, 3 cm off the step, 5 mm up.
    #[test]
    fn a_perceived_edge_becomes_a_box_over_its_riser() {
        let into_step = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
            -Vector3::y(),
            Vector3::x(),
            Vector3::z(),
        ]));
        let nosing = OrientedBox::new(Vector3::new(1.025, 0.0, 0.175), into_step, Vector3::new(0.8, 0.025, 0.025))
            .expect("nosing");
        let b = riser_box(&nosing, 0.02, 0.03, 0.005).expect("box");
        // x from 1.0 − 0.03 to 1.05, z from 0.02 to 0.205, y ±0.8.
        let worked = [(1.0 - 0.03 + 1.05) / 2.0, 0.0, (0.02 + 0.205) / 2.0];
        assert!((b.center() - Vector3::from(worked)).norm() < 1e-12, "{b:?}");
        assert!((b.half_extents() - Vector3::new(0.8, (1.05 - 0.97) / 2.0, (0.205 - 0.02) / 2.0)).norm() < 1e-12);
        assert_eq!(b.rotation(), &into_step);
        // A drop under the cuboid's own section leaves its bottom (0.15 m) where it is.
        let shallow = riser_box(&nosing, 0.17, 0.0, 0.0).expect("box");
        assert!((shallow.center().z - 0.175).abs() < 1e-12 && (shallow.half_extents().z - 0.025).abs() < 1e-12);
    }

    #[test]
    fn the_highest_plane_over_each_stretch_of_the_path_is_its_level() {
        // A floor reaching under two treads, a gap before the second, a sliver of the
        // first tread's hull poking past the second riser, and a plane off the path.
        let planes = [
            level_plane(0.0, [-3.0, 3.0], [-4.0, 4.0]),
            level_plane(0.165, [1.0, 1.72], [-1.0, 1.0]),
            level_plane(0.33, [1.35, 1.7], [-1.0, 0.9]),
            level_plane(0.5, [0.0, 1.0], [2.0, 3.0]),
            level_plane(0.001, [5.0, 6.0], [-1.0, 1.0]),
        ];
        let ground = ground_from_planes(&planes, 0.1).expect("ground");
        let levels = ground.levels();
        let worked: [(f64, f64, f64); 3] = [(f64::NEG_INFINITY, 1.0, 0.0), (1.0, 1.35, 0.165), (1.35, 1.72, 0.33)];
        for (level, (begin, end, height)) in levels.iter().zip(worked) {
            assert_eq!((level.begin, level.end, level.height), (begin, end, height), "{levels:?}");
        }
        // Past the second tread (and the first tread's 2 cm sliver beyond it) the floor's
        // level again, into which the far floor 1 mm higher merges.
        assert_eq!(levels.len(), 4, "{levels:?}");
        assert_eq!((levels[3].begin, levels[3].end, levels[3].height), (1.72, f64::INFINITY, 0.0));
        assert_eq!(levels[2].half_width, 0.9);
        assert!(ground_from_planes(&[], 0.1).is_none());
        // A plane crossing the path only at its edge, or too narrow to stand on, is none.
        assert!(ground_from_planes(&[level_plane(0.0, [0.0, 1.0], [0.0, 2.0])], 0.1).is_none());
        assert!(ground_from_planes(&[level_plane(0.0, [0.0, 1.0], [-0.05, 0.05])], 0.1).is_none());
    }
}
