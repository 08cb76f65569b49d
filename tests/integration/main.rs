//! cbfgen's integration tests, one module per file, in one test binary: each binary
//! links the crate and its dependencies whole, so one per crate instead of one per file
//! is most of what `cargo test` spends linking. The no-allocation tests stay binaries of
//! their own (each installs a counting global allocator and runs without the harness).
//! Run one file's tests with `cargo test --release --test integration <module>::`.

mod between_samples;
mod dual_active_set;
mod ecbf_qp;
mod generated_is_current;
mod hierarchy;
mod lanes;
mod lexicographic;
mod lp_boxes;
mod ocp;
mod op_counts;
mod outside_crate;
mod sat_vs_parry;
mod ssat;
mod ssat_boundary;
mod ssat_domain;
