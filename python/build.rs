//! Embeds the core's sources in the extension (`cbfgen._native.core_sources()`), so that
//! `cbfgen.load` builds a user's spec against exactly the core this module was built from,
//! also from an installed wheel with no clone of cbfgen left anywhere.
//!
//! What is embedded is what a plugin build reads: the core's manifest, lock file, build
//! script and rustfmt settings, `src/`, `generated/`, the `cbfgen-build` crate and the
//! generator's files (the set the generated files' inputs hash covers,
//! `cbfgen_build::inputs_hash::package_files`). `cbfgen.plugins` hashes the same set.
//! Beside them, the C interface's headers and CMake package (`capi/include`, `capi/cmake`),
//! which `cbfgen.embed` installs with a spec's libraries.

use cbfgen_build::inputs_hash::package_files;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

fn main() {
    let crate_dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets this"));
    let root = crate_dir.parent().expect("python/ sits in the repository").to_path_buf();
    // The lock too: a plugin resolves to the very versions this module was built with.
    let top = [
        "Cargo.toml",
        "Cargo.lock",
        "build.rs",
        "rustfmt.toml",
        "cbfgen-build/Cargo.toml",
        "capi/include/cbfgen/abi.h",
        "capi/include/cbfgen/cbfgen.h",
        "capi/include/cbfgen/cbfgen.hpp",
        "capi/cmake/cbfgenConfig.cmake",
        "capi/cmake/cbfgenConfigVersion.cmake",
    ];
    let mut files: Vec<PathBuf> = top.iter().map(|f| root.join(f)).collect();
    for folder in ["src", "generated", "cbfgen-build/src"] {
        rust_files(&root.join(folder), &mut files);
        // A directory is scanned whole for changes: a new module is seen too.
        println!("cargo:rerun-if-changed={}", root.join(folder).display());
    }
    let generator = package_files(&root);
    for file in &generator {
        // File by file: the folder also holds __pycache__, which changes on every run.
        println!("cargo:rerun-if-changed={}", file.display());
    }
    files.extend(generator);
    for file in top {
        println!("cargo:rerun-if-changed={}", root.join(file).display());
    }

    let mut table = String::from("/// `(path relative to the repository, contents)` of every embedded core file.\n");
    table.push_str("pub static CORE_SOURCES: &[(&str, &[u8])] = &[\n");
    for file in &files {
        let relative = file.strip_prefix(&root).expect("under the repository");
        let relative: Vec<_> = relative.components().map(|c| c.as_os_str().to_string_lossy()).collect();
        writeln!(table, "    ({:?}, include_bytes!({:?})),", relative.join("/"), file.display().to_string())
            .expect("writing to a String");
    }
    table.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets this")).join("core_sources.rs");
    fs::write(out, table).expect("OUT_DIR is writable");
}

/// Every `.rs` file under `dir`, recursively, in a stable order.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir).expect("a core source folder").flatten().map(|e| e.path()).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}
