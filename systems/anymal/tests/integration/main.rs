//! anymal's integration tests, one module per file, in one test binary: each binary
//! links the crate and its dependencies whole, so one per crate instead of one per file
//! is most of what `cargo test` spends linking. The no-allocation tests stay binaries of
//! their own (each installs a counting global allocator and runs without the harness).
//! Run one file's tests with `cargo test --release --test integration <module>::`.

mod mpc;
mod mpc_model;
mod mpc_thread;
mod mpc_wbc;
mod stones;
mod terrain;
mod wbc;
