//! Keeps `generated/` in step with the symbolic stage.
//!
//! Every generated file records the SHA-256 of the generator's inputs. This script
//! recomputes that hash (same rule as `symbolic/inputs_hash.py`); when it differs, it
//! runs `python -m symbolic.generate` with the interpreter `cbfgen-build` finds
//! (`CBFGEN_PYTHON`, the active virtual environment, the project's `.venv`, `python3`).
//! A fresh clone has current files and needs no Python at all.

use cbfgen_build::inputs_hash::{package_files, package_hash};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const HASH_PREFIX: &str = "// inputs-sha256: ";

fn main() {
    check_cmake();
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets this"));
    println!("cargo:rerun-if-env-changed=CBFGEN_PYTHON");
    println!("cargo:rerun-if-env-changed=VIRTUAL_ENV");
    let symbolic = root.join("symbolic");
    if !symbolic.is_dir() {
        return; // a packaged crate: generated/ is all there is
    }
    // The rule of symbolic/inputs_hash.py, shared with cbfgen-build (which checks a user
    // crate's checked-in files the same way).
    for file in package_files(&root) {
        println!("cargo:rerun-if-changed={}", file.display());
    }
    let digest = match package_hash(&root) {
        Ok(digest) => digest,
        Err(e) => {
            println!("cargo::error=cannot read the generator's sources in symbolic/: {e}");
            return;
        }
    };
    let generated = root.join("generated");
    let stale = stale_files(&generated, &digest);
    for file in generated_files(&generated) {
        println!("cargo:rerun-if-changed={}", file.display());
    }
    if stale.is_empty() {
        return;
    }
    if let Err(why) = regenerate(&root) {
        println!(
            "cargo::error=generated/ is stale ({} differs from symbolic/) and regeneration failed: {why}. \
             Fix: run `scripts/cbf setup` (creates .venv with symbolic/requirements.txt) or set CBFGEN_PYTHON to a python with symengine.",
            stale[0]
        );
        return;
    }
    let still = stale_files(&generated, &digest);
    if !still.is_empty() {
        println!("cargo::error=regenerated generated/ but {} still records another inputs hash", still[0]);
    }
}

/// OSQP's C sources build with CMake (the `osqp-sys` build script runs it), whose absence
/// there ends in a question ("is `cmake` not installed?"). Said here first, with the fix.
fn check_cmake() {
    println!("cargo:rerun-if-env-changed=CMAKE");
    println!("cargo:rerun-if-env-changed=CMAKE_POLICY_VERSION_MINIMUM");
    let cmake = std::env::var_os("CMAKE").map_or_else(|| PathBuf::from("cmake"), PathBuf::from);
    let fix = "`pip install cmake==3.31.10` (what `scripts/cbf setup` puts in the cbfgen repository's \
               .venv/bin: put that folder on PATH), or your system's cmake 3.x";
    let version = Command::new(&cmake).arg("--version").output().ok().filter(|o| o.status.success());
    let Some(version) = version else {
        println!(
            "cargo::error=cbfgen needs CMake to build OSQP's C sources and `{}` does not run: {fix}",
            cmake.display()
        );
        return;
    };
    // CMake 4 refuses the minimum version OSQP 0.6's CMakeLists asks for, unless told to.
    let text = String::from_utf8_lossy(&version.stdout);
    let major = text.split_whitespace().nth(2).and_then(|v| v.split('.').next()?.parse::<u32>().ok());
    if major.is_some_and(|m| m >= 4) && std::env::var_os("CMAKE_POLICY_VERSION_MINIMUM").is_none() {
        println!(
            "cargo::error=CMake {} cannot build OSQP 0.6's C sources as they are: set CMAKE_POLICY_VERSION_MINIMUM=3.5, or use {fix}",
            text.split_whitespace().nth(2).unwrap_or("4")
        );
    }
}

/// mod.rs plus every module it declares.
fn generated_files(generated: &Path) -> Vec<PathBuf> {
    let mod_rs = generated.join("mod.rs");
    let mut files = vec![mod_rs.clone()];
    if let Ok(text) = fs::read_to_string(&mod_rs) {
        for line in text.lines() {
            if let Some(name) = line.strip_prefix("pub mod ").and_then(|l| l.strip_suffix(';')) {
                files.push(generated.join(format!("{name}.rs")));
            }
        }
    }
    files
}

fn stale_files(generated: &Path, digest: &str) -> Vec<String> {
    let want = format!("{HASH_PREFIX}{digest}");
    generated_files(generated)
        .into_iter()
        .filter(|f| fs::read_to_string(f).map_or(true, |text| !text.lines().take(3).any(|l| l == want)))
        .map(|f| f.display().to_string())
        .collect()
}

fn regenerate(root: &Path) -> Result<(), String> {
    let py = cbfgen_build::python_interpreter(&[root]);
    let out = Command::new(&py)
        .args(["-m", "symbolic.generate"])
        .current_dir(root)
        .output()
        .map_err(|e| format!("cannot start {}: {e}", py.display()))?;
    if out.status.success() {
        return Ok(());
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no output");
    Err(format!("`{} -m symbolic.generate` said: {last}", py.display()))
}
