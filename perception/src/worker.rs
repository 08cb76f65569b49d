//! Perception on its own thread, beside a control loop that must never wait for it.
//!
//! The control side hands over scans ([`Worker::add_scan`]) and asks for an update
//! ([`Worker::request`]); both only send a message. The worker adds the scans to its
//! [`VoxelMap`], and for each request segments the map around the given point and
//! extracts the edge cuboids. The control side picks the result up when it is ready
//! ([`Worker::try_result`], which never blocks). Messages are handled in the order sent,
//! so a result covers exactly the scans added before its request, however the threads
//! were scheduled: a simulation that waits for each result at a fixed simulated time
//! ([`Worker::wait_result`]) is deterministic.

use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nalgebra::Vector3;

use super::edges::{found_edges, EdgeSettings};
use super::map::VoxelMap;
use super::planes::{segment_weighted, Plane, SegmentSettings};
use cbfgen::error::{within, CbfError};
use cbfgen::geometry::OrientedBox;

/// What the worker does with the map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkerSettings {
    /// Voxel of the accumulated map \[m\].
    pub map_voxel: f64,
    /// Each update segments the map within this horizontal distance of the requested
    /// point, and forgets what lies beyond twice it \[m\].
    pub map_radius: f64,
    /// Plane segmentation (its `viewpoint` is replaced by each request's).
    pub segment: SegmentSettings,
    /// Edge cuboid extraction (its `viewpoint` is replaced by each request's).
    pub edges: EdgeSettings,
}

impl Default for WorkerSettings {
    /// A 2 cm map, segmented within 3.5 m; default segmentation; default edges but for
    /// their support, 40 points per metre: a map of 2 cm voxels holds at most about 125
    /// per metre in the 5 cm band along an edge (the default's 100 is set for raw scans),
    /// and a low tread seen at grazing angles fills half of that.
    fn default() -> Self {
        Self {
            map_voxel: 0.02,
            map_radius: 3.5,
            segment: SegmentSettings::default(),
            edges: EdgeSettings { min_support: 40.0, ..EdgeSettings::default() },
        }
    }
}

impl WorkerSettings {
    /// # Errors
    /// A setting outside its domain, named.
    pub fn validate(&self) -> Result<(), CbfError> {
        VoxelMap::new(self.map_voxel)?;
        within("map radius [m]", self.map_radius, 0.1, 1e3, "[0.1, 1000]")?;
        self.segment.validate()?;
        self.edges.validate()
    }
}

/// One update's output.
#[derive(Debug, Clone, PartialEq)]
pub struct Perceived {
    /// Map points (voxel centroids) it was computed from.
    pub points: Vec<Vector3<f64>>,
    /// How many scanned points each map point averages.
    pub weights: Vec<f64>,
    /// The planes found.
    pub planes: Vec<Plane>,
    /// The edge cuboids found.
    pub cuboids: Vec<OrientedBox>,
    /// For each cuboid, the height of the level seen below its drop \[m\] (where the
    /// riser under the edge ends).
    pub lower_levels: Vec<f64>,
    /// Wall time of the segmentation and edge extraction on the worker thread.
    pub elapsed: Duration,
}

enum Job {
    Scan(Vec<Vector3<f64>>),
    Update { center: Vector3<f64>, viewpoint: Vector3<f64> },
}

/// The perception thread and the two channels to it.
#[derive(Debug)]
pub struct Worker {
    jobs: Option<Sender<Job>>,
    results: Receiver<Result<Perceived, CbfError>>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Start the thread.
    ///
    /// # Errors
    /// Invalid settings, or a thread the system would not start.
    pub fn spawn(settings: WorkerSettings) -> Result<Self, CbfError> {
        settings.validate()?;
        let mut map = VoxelMap::new(settings.map_voxel)?;
        let (jobs, inbox) = channel::<Job>();
        let (outbox, results) = channel();
        let thread = std::thread::Builder::new()
            .name("cbfgen-perception".into())
            .spawn(move || {
                // A refused scan fails the next update, so every request gets one result.
                let mut refused = None;
                for job in inbox {
                    let result = match job {
                        Job::Scan(points) => {
                            if let Err(e) = map.insert(&points) {
                                refused.get_or_insert(e);
                            }
                            continue;
                        }
                        Job::Update { center, viewpoint } => match refused.take() {
                            Some(e) => Err(e),
                            None => {
                                map.forget_beyond(&center, 2.0 * settings.map_radius);
                                update(&map, &settings, &center, &viewpoint)
                            }
                        },
                    };
                    if outbox.send(result).is_err() {
                        return;
                    }
                }
            })
            .map_err(|e| gone(format!("could not start: {e}")))?;
        Ok(Self { jobs: Some(jobs), results, thread: Some(thread) })
    }

    fn send(&self, job: Job) -> Result<(), CbfError> {
        self.jobs.as_ref().and_then(|j| j.send(job).ok()).ok_or_else(|| gone("not running".into()))
    }

    /// Hand a scan (world frame) to the map. Never blocks. A scan with a non-finite or
    /// out-of-range point is refused whole by the worker, and the next update's result is
    /// that refusal (the update after it runs normally).
    ///
    /// # Errors
    /// [`CbfError::Thread`] if the thread has stopped.
    pub fn add_scan(&mut self, points: Vec<Vector3<f64>>) -> Result<(), CbfError> {
        self.send(Job::Scan(points))
    }

    /// Ask for an update of the map around `center`, normals of vertical planes facing
    /// `viewpoint` (the sensor). Never blocks.
    ///
    /// # Errors
    /// [`CbfError::Thread`] if the thread has stopped; a non-finite point.
    pub fn request(&mut self, center: &Vector3<f64>, viewpoint: &Vector3<f64>) -> Result<(), CbfError> {
        for &c in center.iter().chain(viewpoint.iter()) {
            within("perception request point [m]", c, -1e5, 1e5, "[-1e5, 1e5]")?;
        }
        self.send(Job::Update { center: *center, viewpoint: *viewpoint })
    }

    /// The next result if it is ready. Never blocks.
    pub fn try_result(&mut self) -> Option<Result<Perceived, CbfError>> {
        match self.results.try_recv() {
            Ok(r) => Some(r),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err(gone("not running".into()))),
        }
    }

    /// The next result, waiting for it: for simulations, which hold the simulated clock
    /// still while the worker catches up. Never call it from a real-time loop.
    ///
    /// # Errors
    /// The update's own error, or [`CbfError::Thread`] if the thread has stopped.
    pub fn wait_result(&mut self) -> Result<Perceived, CbfError> {
        self.results.recv().map_err(|_| gone("not running".into()))?
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the job channel ends the thread's loop after the job in hand.
        self.jobs = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

fn update(
    map: &VoxelMap,
    settings: &WorkerSettings,
    center: &Vector3<f64>,
    viewpoint: &Vector3<f64>,
) -> Result<Perceived, CbfError> {
    let started = Instant::now();
    let (points, weights) = map.points_near(center, settings.map_radius);
    let planes = segment_weighted(&points, &weights, &SegmentSettings { viewpoint: *viewpoint, ..settings.segment })?;
    let found = found_edges(&planes, &points, &EdgeSettings { viewpoint: Some(*viewpoint), ..settings.edges })?;
    let (cuboids, lower_levels) = found.into_iter().map(|e| (e.cuboid, e.lower)).unzip();
    Ok(Perceived { points, weights, planes, cuboids, lower_levels, elapsed: started.elapsed() })
}

/// The worker's thread failed (`reason`): started or stopped, it is not there to answer.
fn gone(reason: String) -> CbfError {
    CbfError::Thread { what: "perception worker", reason }
}
