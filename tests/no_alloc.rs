//! The control path allocates nothing: thousands of filter updates along the drive into
//! the stairs, counted two ways — Rust's global allocator, and the C `malloc` family
//! that OSQP (compiled C, linked into this binary) would call.
//!
//! This file holds one test on purpose: the counters are process-wide.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use cbfgen::approach::Approach;
use cbfgen::catalog::Capacity;
use cbfgen::filter::{EcbfFilter, FilterSettings, InputSource};
use cbfgen::terrain::Stairs;

static COUNTING: AtomicBool = AtomicBool::new(false);
static RUST_ALLOCS: AtomicUsize = AtomicUsize::new(0);
static C_ALLOCS: AtomicUsize = AtomicUsize::new(0);

struct CountingAllocator;

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            RUST_ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            RUST_ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

// glibc documents replacing malloc by defining these in the program; the statically
// linked OSQP objects resolve to them. They count and forward to glibc's own.
unsafe extern "C" {
    fn __libc_malloc(size: usize) -> *mut u8;
    fn __libc_calloc(n: usize, size: usize) -> *mut u8;
    fn __libc_realloc(ptr: *mut u8, size: usize) -> *mut u8;
    fn __libc_free(ptr: *mut u8);
}

fn count_c() {
    if COUNTING.load(Ordering::Relaxed) {
        C_ALLOCS.fetch_add(1, Ordering::Relaxed);
    }
}

#[unsafe(no_mangle)]
unsafe extern "C" fn malloc(size: usize) -> *mut u8 {
    count_c();
    unsafe { __libc_malloc(size) }
}

#[unsafe(no_mangle)]
unsafe extern "C" fn calloc(n: usize, size: usize) -> *mut u8 {
    count_c();
    unsafe { __libc_calloc(n, size) }
}

#[unsafe(no_mangle)]
unsafe extern "C" fn realloc(ptr: *mut u8, size: usize) -> *mut u8 {
    count_c();
    unsafe { __libc_realloc(ptr, size) }
}

#[unsafe(no_mangle)]
unsafe extern "C" fn free(ptr: *mut u8) {
    unsafe { __libc_free(ptr) }
}

#[test]
fn thousands_of_filter_updates_allocate_nothing() {
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut filter = EcbfFilter::new(capacity, FilterSettings::default()).expect("filter");
    let mut drive = Approach::new(capacity, Stairs::HARDWARE, 0.3, 0.4).expect("drive");
    let mut broken = drive.x;
    broken[7] = f64::NAN;

    // The counters must see allocations at all, or a zero below would prove nothing.
    COUNTING.store(true, Ordering::SeqCst);
    let probe = EcbfFilter::new(Capacity { edges: 1, foothold_edges: [1; 6] }, FilterSettings::default());
    COUNTING.store(false, Ordering::SeqCst);
    drop(probe);
    assert!(RUST_ALLOCS.swap(0, Ordering::SeqCst) > 0, "Rust allocations are not being counted");
    assert!(C_ALLOCS.swap(0, Ordering::SeqCst) > 0, "OSQP's malloc calls are not being counted");

    let (mut sources, mut solved) = ([0usize; 4], 0);
    COUNTING.store(true, Ordering::SeqCst);
    for cycle in 0..3000 {
        let u_ref = drive.nominal_input();
        // Every 500th cycle a bad state: the error path must not allocate either.
        if cycle % 500 == 250 {
            let _ = filter.update(&broken, &u_ref, &drive.env);
        }
        let out = match filter.update(&drive.x, &u_ref, &drive.env) {
            Ok(out) => *out,
            Err(_) => break,
        };
        sources[out.source as usize] += 1;
        solved += usize::from(out.polished);
        drive.advance(&out.u, 1e-3);
    }
    COUNTING.store(false, Ordering::SeqCst);
    let (rust, c) = (RUST_ALLOCS.load(Ordering::SeqCst), C_ALLOCS.load(Ordering::SeqCst));
    assert_eq!((rust, c), (0, 0), "allocations during 3000 updates: Rust {rust}, C {c}");
    assert_eq!(sources.iter().sum::<usize>(), 3000, "an update failed");
    assert!(sources[InputSource::Qp as usize] > 2900 && solved > 2900, "the loop must really solve: {sources:?}");
    assert!(drive.x[0] > 0.1, "the robot must have moved");
}
