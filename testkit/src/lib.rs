//! Test helpers shared by the cbfgen crates' tests and benches: random and hand-built box
//! pairs ([`boxes`]), Clarabel on a dense QP ([`clarabel_qp`]), a second solver's answer
//! to the lexicographic QP ([`lexicographic_reference`]), Table I's LP box–box query
//! ([`lp_boxes`]), the SSAT's 2-D collision boundary of Fig. 6 ([`ssat_boundary`]) and
//! per-outcome tallies ([`tally`]), and whether a bench was started to measure or to be
//! checked ([`bench_run`]).
//!
//! The allocation counter is not a module of this library: it installs a global allocator
//! and `malloc` hooks, which must be in the allocation-counting test binaries only. Those
//! include `testkit/alloc_count.rs` by path.

pub mod bench_run;
pub mod boxes;
pub mod clarabel_qp;
pub mod lexicographic_reference;
pub mod lp_boxes;
pub mod ssat_boundary;
pub mod tally;
