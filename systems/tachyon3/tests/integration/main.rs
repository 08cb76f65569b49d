//! tachyon3's integration tests, one module per file, in one test binary: each binary
//! links the crate and its dependencies whole, so one per crate instead of one per file
//! is most of what `cargo test` spends linking. The no-allocation tests stay binaries of
//! their own (each installs a counting global allocator and runs without the harness).
//! Run one file's tests with `cargo test --release --test integration <module>::`.

mod animation;
mod between_samples;
mod campaign;
mod campaign_shards;
mod constraints;
mod culling;
mod dynamic;
mod filter;
mod filter_properties;
mod foothold;
mod origin_jump;
mod param_domains;
mod perception_loop;
mod robustness;
mod sim;
mod stairs_qps;
mod terrain;
mod toe_certificate;
mod turn;

// Helpers several test modules share (also the no-allocation binary's), once each.
use cbfgen_testkit::lexicographic_reference;
#[path = "../common/kkt.rs"]
mod kkt;
#[path = "../common/replay.rs"]
mod replay;
#[path = "../common/singular.rs"]
mod singular;
#[path = "../common/tachyon3_state.rs"]
mod tachyon3_state;
#[path = "../common/terrain_contact.rs"]
mod terrain_contact;
