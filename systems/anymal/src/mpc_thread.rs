//! The MPC in its own thread, as seed 004 runs it beside its 400 Hz controller: the
//! controller [`post`](MpcThread::post)s every measured state; the thread, whenever it is
//! free, solves on the newest one and publishes the plan; the controller
//! [`take`](MpcThread::take)s a plan when a newer one is there. The controller never waits
//! for a solve: it only holds a lock to copy a state in or a plan out. Neither side
//! allocates after [`spawn`](MpcThread::spawn).
//!
//! A state posted while the thread solves replaces any older one waiting: the next solve
//! starts from the newest measurement, and none is queued behind a slow iteration. How
//! fresh a plan is then depends on the machine; [`crate::walk::LayeredController`]'s
//! synchronous mode is the deterministic one.

use std::sync::{Arc, Barrier, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;

use cbfgen::error::CbfError;

use crate::gait::Trot;
use crate::mpc::{KinodynamicMpc, MpcReport, Plan};
use crate::mpc_generated::NX;
use crate::terrain::Footholds;

/// The newest posted state.
struct Request {
    t: f64,
    x: [f64; NX],
    fresh: bool,
    stop: bool,
}

/// The newest plan and how the solves went.
struct Published {
    plan: Plan,
    /// Plans published so far.
    version: u64,
    /// The report of the solve that made `plan`.
    report: Option<MpcReport>,
    /// The last solve's error, if it failed (a state outside the MPC's domain).
    error: Option<CbfError>,
    /// Solves run, and of them those that found no plan.
    solves: (u64, u64),
}

struct Shared {
    request: Mutex<Request>,
    wake: Condvar,
    published: Mutex<Published>,
}

/// A lock that a panic elsewhere does not poison for us: the data are plain numbers,
/// each write complete before the lock is released.
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The MPC running in a thread of its own (module docs). Dropping it stops the thread.
pub struct MpcThread {
    shared: Arc<Shared>,
    handle: Option<JoinHandle<()>>,
    taken: u64,
}

impl std::fmt::Debug for MpcThread {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MpcThread").field("taken", &self.taken).finish_non_exhaustive()
    }
}

impl MpcThread {
    /// Start `mpc`'s thread on the gait `trot`, each foot's region from `footholds`.
    ///
    /// # Errors
    /// The thread could not be started.
    pub fn spawn(mut mpc: KinodynamicMpc, trot: Trot, footholds: Footholds) -> Result<Self, CbfError> {
        let horizon = mpc.settings().horizon;
        let shared = Arc::new(Shared {
            request: Mutex::new(Request { t: 0.0, x: [0.0; NX], fresh: false, stop: false }),
            wake: Condvar::new(),
            published: Mutex::new(Published {
                plan: Plan::new(horizon, mpc.settings().dt),
                version: 0,
                report: None,
                error: None,
                solves: (0, 0),
            }),
        });
        let worker = Arc::clone(&shared);
        // The thread's start-up allocates (its name, its thread-locals); the caller waits
        // until it is done, so that none of it falls into the control loop that follows.
        let ready = Arc::new(Barrier::new(2));
        let started = Arc::clone(&ready);
        let handle = std::thread::Builder::new()
            .name("cbfgen-anymal MPC".into())
            .spawn(move || {
                started.wait();
                drop(started);
                loop {
                    let (t, x) = {
                        let mut request = lock(&worker.request);
                        while !request.fresh && !request.stop {
                            request = worker.wake.wait(request).unwrap_or_else(PoisonError::into_inner);
                        }
                        if request.stop {
                            return;
                        }
                        request.fresh = false;
                        (request.t, request.x)
                    };
                    let region = |foot: usize, time: f64| footholds.region(&trot, foot, time);
                    let result = mpc.solve(t, &x, &trot, &region);
                    let mut published = lock(&worker.published);
                    published.solves.0 += 1;
                    published.solves.1 += u64::from(!matches!(result, Ok(MpcReport { updated: true, .. })));
                    match result {
                        Ok(report) => {
                            // A solve that found no plan leaves the last one (and its report).
                            if report.updated {
                                published.plan.copy_from(mpc.latest());
                                published.version += 1;
                                published.report = Some(report);
                            }
                            published.error = None;
                        }
                        Err(error) => published.error = Some(error),
                    }
                }
            })
            .map_err(|e| CbfError::Thread { what: "MPC", reason: e.to_string() })?;
        ready.wait();
        Ok(Self { shared, handle: Some(handle), taken: 0 })
    }

    /// Post the measured state `x` (the MPC's layout) at time `t`: the thread's next solve
    /// starts from it, unless a newer one is posted first.
    pub fn post(&self, t: f64, x: &[f64; NX]) {
        let mut request = lock(&self.shared.request);
        (request.t, request.x, request.fresh) = (t, *x, true);
        drop(request);
        self.shared.wake.notify_one();
    }

    /// Copy the newest plan into `plan` if one newer than the last taken is there, and
    /// return the report of the solve that made it.
    ///
    /// # Panics
    /// A `plan` of another horizon than the MPC's.
    pub fn take(&mut self, plan: &mut Plan) -> Option<MpcReport> {
        let published = lock(&self.shared.published);
        if published.version == self.taken {
            return None;
        }
        plan.copy_from(&published.plan);
        self.taken = published.version;
        published.report
    }

    /// Plans published so far.
    pub fn published(&self) -> u64 {
        lock(&self.shared.published).version
    }

    /// Solves run so far, and of them those that found no plan (their states are
    /// skipped: the controller keeps tracking the last plan).
    pub fn solves(&self) -> (u64, u64) {
        lock(&self.shared.published).solves
    }

    /// The last solve's error, if the last solve failed.
    pub fn last_error(&self) -> Option<CbfError> {
        lock(&self.shared.published).error.clone()
    }
}

impl Drop for MpcThread {
    fn drop(&mut self) {
        lock(&self.shared.request).stop = true;
        self.shared.wake.notify_one();
        if let Some(handle) = self.handle.take() {
            // A panicked worker has nothing left to clean up.
            let _ = handle.join();
        }
    }
}
