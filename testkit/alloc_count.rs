//! Counting allocators for the no-allocation tests: Rust's global allocator, and the C
//! `malloc` family that OSQP (compiled C, statically linked) calls. A test binary
//! includes this file by path (`#[path = ".../testkit/alloc_count.rs"] mod alloc_count;`),
//! not through the testkit library: its global allocator and `malloc` hooks must be in the
//! counting binaries only. The
//! counters are process-wide, so such a binary runs without libtest (`harness = false`):
//! its `main` is the only thread.
//!
//! The two counters are disjoint. Rust's `System` allocator is itself built on `malloc`,
//! so every Rust allocation also reaches the hooks below; the Rust allocator marks its
//! thread while it is inside `System`, and the hooks do not count such calls. The C
//! counter therefore sees only `malloc` calls made from outside the Rust allocator: in
//! these binaries, OSQP's own (it allocates with `malloc`, `calloc` and `realloc` only).
//! [`assert_counters_work`] checks both halves of that claim before a count is trusted.
#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

pub static COUNTING: AtomicBool = AtomicBool::new(false);
pub static RUST_ALLOCS: AtomicUsize = AtomicUsize::new(0);
pub static C_ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Set while this thread is inside the Rust allocator's call into `System`. Per
    /// thread, so a C allocation on another thread is still counted. `const` and without
    /// a destructor: reading it never allocates and never fails, even inside `malloc`.
    static IN_RUST_ALLOCATOR: Cell<bool> = const { Cell::new(false) };
}

/// Run `f` (a call into `System`) with this thread marked as inside the Rust allocator.
fn as_rust_allocation<R>(f: impl FnOnce() -> R) -> R {
    let outer = IN_RUST_ALLOCATOR.replace(true);
    let out = f();
    IN_RUST_ALLOCATOR.set(outer);
    out
}

struct CountingAllocator;

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            RUST_ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        as_rust_allocation(|| unsafe { System.alloc(layout) })
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            RUST_ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        as_rust_allocation(|| unsafe { System.realloc(ptr, layout, new_size) })
    }
    // `alloc_zeroed` keeps its default (`alloc`, then zeroing), so it is counted above.
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
    // `COUNTING` first: outside a count the thread-local is not touched at all (this
    // runs for every `malloc` of the process, some before `main`).
    if COUNTING.load(Ordering::Relaxed) && !IN_RUST_ALLOCATOR.get() {
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

/// Run `f` with both counters on; returns its result and the (Rust, C) allocation counts.
pub fn counting<R>(f: impl FnOnce() -> R) -> (R, usize, usize) {
    RUST_ALLOCS.store(0, Ordering::SeqCst);
    C_ALLOCS.store(0, Ordering::SeqCst);
    COUNTING.store(true, Ordering::SeqCst);
    let out = f();
    COUNTING.store(false, Ordering::SeqCst);
    (out, RUST_ALLOCS.swap(0, Ordering::SeqCst), C_ALLOCS.swap(0, Ordering::SeqCst))
}

/// A zero count proves nothing unless each counter sees what it claims to and nothing
/// else. Negative control: a plain `Vec`, allocated and then grown, must be counted as
/// Rust allocations (both `alloc` and `realloc`) and not at all by the C counter, though
/// it reached `malloc` and `realloc` through `System`. Positive control: `sets_up_osqp`
/// (e.g. building a filter) must be seen by the C counter: OSQP's own `malloc` calls.
pub fn assert_counters_work<R>(sets_up_osqp: impl FnOnce() -> R) {
    let (grown, rust, c) = counting(|| {
        let mut v: Vec<u64> = Vec::with_capacity(4);
        v.extend(0..1000);
        std::hint::black_box(v)
    });
    drop(grown);
    assert!(rust >= 2, "a Vec's alloc and realloc must be counted as Rust allocations, counted {rust}");
    assert_eq!(c, 0, "the C counter counted a Rust Vec's allocations: it cannot tell OSQP's mallocs from Rust's");

    let (built, _, c) = counting(sets_up_osqp);
    drop(built);
    assert!(c > 0, "setting up OSQP made no C malloc call the counter saw: the malloc hooks are not counting");
}
