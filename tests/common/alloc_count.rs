//! Counting allocators for the no-allocation tests: Rust's global allocator, and the C
//! `malloc` family that OSQP (compiled C, statically linked) calls. A test binary
//! includes this file with `#[path = "common/alloc_count.rs"] mod alloc_count;`. The
//! counters are process-wide, so such a binary runs without libtest (`harness = false`):
//! its `main` is the only thread.
#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

pub static COUNTING: AtomicBool = AtomicBool::new(false);
pub static RUST_ALLOCS: AtomicUsize = AtomicUsize::new(0);
pub static C_ALLOCS: AtomicUsize = AtomicUsize::new(0);

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

/// Run `f` with both counters on; returns its result and the (Rust, C) allocation counts.
pub fn counting<R>(f: impl FnOnce() -> R) -> (R, usize, usize) {
    RUST_ALLOCS.store(0, Ordering::SeqCst);
    C_ALLOCS.store(0, Ordering::SeqCst);
    COUNTING.store(true, Ordering::SeqCst);
    let out = f();
    COUNTING.store(false, Ordering::SeqCst);
    (out, RUST_ALLOCS.swap(0, Ordering::SeqCst), C_ALLOCS.swap(0, Ordering::SeqCst))
}

/// Both counters must see the allocations of `allocating` (e.g. building an OSQP
/// problem), or a zero count would prove nothing.
pub fn assert_counters_work<R>(allocating: impl FnOnce() -> R) {
    let (out, rust, c) = counting(allocating);
    drop(out);
    assert!(rust > 0, "Rust allocations are not being counted");
    assert!(c > 0, "C (OSQP) malloc calls are not being counted");
}
