//! The generated file's inputs hash, recomputed without Python. [`package_files`] and
//! [`package_hash`] are public for cbfgen's own build script, which keeps its
//! `generated/` current by the same rule.
//!
//! Mirrors `symbolic/inputs_hash.py` (`inputs_hash` and `spec_inputs_hash`); the package
//! part is the rule cbfgen's own build.rs mirrors too. Keep the three in step.

use sha2::{Digest, Sha256};
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

/// The hash line of a generated file.
pub(crate) const HASH_PREFIX: &str = "// inputs-sha256: ";
/// One line per dependency file, its path relative to the spec's folder.
pub(crate) const DEPENDS_PREFIX: &str = "// depends: ";
/// The line naming the spec the file was generated from.
const SPEC_PREFIX: &str = "// Spec: ";

const HASHED_SUFFIXES: [&str; 3] = [".py", ".toml", ".txt"];
const SKIPPED_DIRS: [&str; 2] = ["tests", "__pycache__"];

/// Every file of the generator (`<root>/symbolic/`) the package hash reads: names ending
/// in .py, .toml or .txt, outside folders named `tests`, `__pycache__` or starting with a
/// dot, in byte order of their '/'-separated path relative to `root`.
pub fn package_files(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = fs::read_dir(dir) else { return };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if path.is_dir() {
                if !(SKIPPED_DIRS.contains(&name.as_str()) || name.starts_with('.')) {
                    walk(&path, out);
                }
            } else if path.is_file() && HASHED_SUFFIXES.iter().any(|s| name.ends_with(s)) {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&root.join("symbolic"), &mut files);
    files.sort_by_key(|p| slash_path(p.strip_prefix(root).unwrap_or(p)).into_bytes());
    files
}

/// `path`'s components joined by '/'.
pub(crate) fn slash_path(path: &Path) -> String {
    path.components().map(|c| c.as_os_str().to_string_lossy()).collect::<Vec<_>>().join("/")
}

fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 over each package file's relative path, NUL, bytes, NUL (Python's `inputs_hash`).
///
/// # Errors
/// A package file that cannot be read.
pub fn package_hash(root: &Path) -> io::Result<String> {
    let mut hasher = Sha256::new();
    for file in package_files(root) {
        hasher.update(slash_path(file.strip_prefix(root).unwrap_or(&file)).as_bytes());
        hasher.update([0u8]);
        hasher.update(fs::read(&file)?);
        hasher.update([0u8]);
    }
    Ok(hex(&hasher.finalize()))
}

/// SHA-256 over `cbfgen-spec` NUL, the package hash (hex) NUL, the spec's bytes NUL,
/// `runtime_crate` NUL, then for each dependency in byte order of its path: the path
/// relative to the spec's folder ('/'-separated) NUL, its bytes NUL (Python's
/// `spec_inputs_hash`).
pub(crate) fn spec_inputs_hash(
    package_hash: &str,
    spec: &[u8],
    runtime_crate: &str,
    dependencies: &[(String, Vec<u8>)],
) -> String {
    let mut hasher = Sha256::new();
    for part in [b"cbfgen-spec".as_slice(), package_hash.as_bytes(), spec, runtime_crate.as_bytes()] {
        hasher.update(part);
        hasher.update([0u8]);
    }
    let mut sorted: Vec<&(String, Vec<u8>)> = dependencies.iter().collect();
    sorted.sort_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
    for (rel, bytes) in sorted {
        hasher.update(rel.as_bytes());
        hasher.update([0u8]);
        hasher.update(bytes);
        hasher.update([0u8]);
    }
    hex(&hasher.finalize())
}

/// What the comment lines heading a generated file record.
#[derive(Debug, Default, PartialEq, Eq)]
pub(crate) struct Header {
    /// The `inputs-sha256` value, when it is 64 lowercase hex digits.
    pub hash: Option<String>,
    /// The spec as the `Spec:` line names it (relative to the cbfgen tree, or a file name).
    pub spec_label: Option<String>,
    /// The `depends:` paths, relative to the spec's folder.
    pub depends: Vec<String>,
}

impl Header {
    /// The header of `text`: its leading `//` lines.
    pub(crate) fn parse(text: &str) -> Header {
        let mut header = Header::default();
        for line in text.lines().take_while(|l| l.starts_with("//")) {
            if let Some(hash) = line.strip_prefix(HASH_PREFIX) {
                let valid = hash.len() == 64 && hash.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
                header.hash = valid.then(|| hash.to_string());
            } else if let Some(rest) = line.strip_prefix(SPEC_PREFIX) {
                header.spec_label = rest.rsplit_once(" (system `").map(|(label, _)| label.to_string());
            } else if let Some(rel) = line.strip_prefix(DEPENDS_PREFIX) {
                header.depends.push(rel.to_string());
            }
        }
        header
    }
}
