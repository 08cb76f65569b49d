//! No code. This crate exists for its manifest: see `Cargo.toml`.
