//! What a crate outside this repository compiles when it depends on the core alone
//! (`examples/your_robot`, whose Cargo.toml is exactly such a crate's): the core's own short
//! list and nothing that draws, renders fonts, decodes images, draws random numbers, runs
//! thread pools or parses command lines. Read from `cargo tree`, the dependency graph Cargo
//! builds from.

use std::collections::BTreeSet;
use std::process::Command;

/// Crates that belong to figures, the campaign, perception, the CLI or Python, never to
/// the core.
const FORBIDDEN: &[&str] =
    &["plotters", "dejavu", "ab_glyph", "image", "png", "font", "rand", "rayon", "clap", "indicatif", "pyo3", "numpy"];

fn crates(edges: &str) -> BTreeSet<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let done = Command::new(cargo)
        .args(["tree", "--offline", "-p", "your_robot", "-e", edges, "--prefix", "none"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree starts");
    assert!(done.status.success(), "cargo tree failed: {}", String::from_utf8_lossy(&done.stderr));
    String::from_utf8_lossy(&done.stdout)
        .lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

#[test]
fn an_outside_crate_on_the_core_compiles_twenty_crates_or_fewer_and_nothing_of_the_systems() {
    let normal = crates("normal");
    assert!(normal.contains("cbfgen") && normal.contains("nalgebra") && normal.contains("osqp"), "{normal:?}");
    assert!(normal.len() <= 20, "{} crates, the crate itself included: {normal:?}", normal.len());
    let all = crates("normal,build");
    for name in &all {
        assert!(
            !FORBIDDEN.iter().any(|f| name.starts_with(f)) && !name.starts_with("cbfgen-") || name == "cbfgen-build",
            "{name} is compiled for a crate that uses only the core: {all:?}"
        );
    }
}
