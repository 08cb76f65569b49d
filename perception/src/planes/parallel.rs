//! How the per-point and per-voxel work is spread over threads: when, how many, in what
//! parts.

/// Clouds of at least this many points (before thinning) are segmented on several
/// threads.
pub(super) const PARALLEL_FROM: usize = 20_000;
/// Most threads one segmentation uses.
pub(super) const MAX_THREADS: usize = 8;
/// The neighbourhoods are gathered in this many runs of points per thread, from a work
/// queue: the runs' costs differ (where surfaces meet, more cells are full).
pub(super) const PARTS_PER_THREAD: usize = 8;

/// `f(0), …, f(count - 1)` on up to `threads` threads, in order. Each thread takes the
/// next index left, so one large item (the floor) does not hold back a share of the rest.
pub(super) fn parallel_map<R: Send>(count: usize, threads: usize, f: impl Fn(usize) -> R + Sync) -> Vec<R> {
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
