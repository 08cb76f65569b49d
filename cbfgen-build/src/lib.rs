//! # cbfgen-build — generate a system's safety-filter code from `build.rs`
//!
//! A crate that keeps a cbfgen system spec (a Python file, see the cbfgen README's "Your
//! own robot") beside its sources calls this from its build script, the way prost-build
//! is called for `.proto` files:
//!
//! ```no_run
//! // in build.rs's `fn main`
//! cbfgen_build::Generator::new().spec("spec/planar_robot.py").build();
//! ```
//!
//! and includes the result where it wants the module:
//!
//! ```ignore
//! pub mod planar_robot {
//!     cbfgen::include_system!("planar_robot");
//! }
//! ```
//!
//! # Two modes
//! * **`OUT_DIR` (the default).** The generator runs whenever the spec changes and writes
//!   only into Cargo's `OUT_DIR`. Every build machine needs Python 3 with SymEngine.
//!   Use this while the spec changes often, and wherever Python is at hand.
//! * **Checked in ([`Generator::checked_in`]).** The generated file lives in a folder of
//!   your crate that you commit. With Python and SymEngine present the file is
//!   regenerated (byte-identical when current); without them, the committed file is used
//!   as it is, with a cargo warning. Use this when builds must work without Python
//!   (cross-compiling, an embedded target's CI), and regenerate on a machine with Python
//!   before committing a spec change.
//!
//! Nothing is written outside `OUT_DIR` unless [`Generator::checked_in`] asks for it.
//!
//! # Finding Python
//! The interpreter is `CBFGEN_PYTHON` if set, else `python3`. When it is missing or lacks
//! SymEngine, the build stops with one line naming the fix.
//! The generator itself (the `symbolic` package) is taken from the cbfgen source tree this
//! crate was built from, or from `CBFGEN_SYMBOLIC` (the folder that contains `symbolic/`).

use std::fmt;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The `symbolic` package's parent folder in the source tree this crate comes from.
const SOURCE_TREE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

/// The SymEngine version the generator is pinned to (symbolic/requirements.txt).
const SYMENGINE_PIN: &str = "symengine==0.15.0";

/// Why generation failed. Its `Display` is one line that names the fix.
#[derive(Debug)]
pub enum Error {
    /// No Python interpreter could be started.
    NoPython {
        /// The interpreter tried.
        python: PathBuf,
    },
    /// Python runs but cannot import SymEngine.
    NoSymEngine {
        /// The interpreter tried.
        python: PathBuf,
    },
    /// The `symbolic` package was not found.
    NoGenerator {
        /// Where it was looked for.
        looked_in: PathBuf,
    },
    /// A spec file that does not exist.
    NoSpec {
        /// The path given.
        spec: PathBuf,
    },
    /// The generator ran and refused the spec (its last line of output).
    Generator {
        /// The spec being generated.
        spec: PathBuf,
        /// What the generator said.
        message: String,
    },
    /// `OUT_DIR` is not set: the helper was called outside a build script.
    NoOutDir,
    /// Checked-in mode without Python, and the committed file is missing.
    MissingCheckedIn {
        /// The file expected.
        file: PathBuf,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NoPython { python } => write!(
                f,
                "cbfgen-build: cannot start Python `{}`; install Python 3 and `pip install {SYMENGINE_PIN}`, \
                 or set CBFGEN_PYTHON to an interpreter that has SymEngine",
                python.display()
            ),
            Error::NoSymEngine { python } => write!(
                f,
                "cbfgen-build: `{}` has no SymEngine; run `{} -m pip install {SYMENGINE_PIN}`, \
                 or set CBFGEN_PYTHON to an interpreter that has it",
                python.display(),
                python.display()
            ),
            Error::NoGenerator { looked_in } => write!(
                f,
                "cbfgen-build: the cbfgen generator (symbolic/) is not in {}; set CBFGEN_SYMBOLIC to the folder \
                 that contains symbolic/",
                looked_in.display()
            ),
            Error::NoSpec { spec } => {
                write!(f, "cbfgen-build: spec file {} not found (paths are relative to the crate root)", spec.display())
            }
            Error::Generator { spec, message } => {
                write!(f, "cbfgen-build: generating {} failed: {message}", spec.display())
            }
            Error::NoOutDir => write!(f, "cbfgen-build: OUT_DIR is not set; call the generator from build.rs"),
            Error::MissingCheckedIn { file } => write!(
                f,
                "cbfgen-build: {} is missing and cannot be generated without Python; generate it on a machine with \
                 Python and SymEngine and commit it",
                file.display()
            ),
        }
    }
}

impl std::error::Error for Error {}

/// Generates one module per spec. See the [crate docs](crate).
#[derive(Debug, Clone, Default)]
pub struct Generator {
    specs: Vec<PathBuf>,
    checked_in: Option<PathBuf>,
    runtime_crate: Option<String>,
}

impl Generator {
    /// No specs yet; output into `OUT_DIR`.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add a spec file (relative to the crate root, as build scripts run there). Its
    /// module is named after the system, `<system>.rs`.
    pub fn spec(mut self, path: impl Into<PathBuf>) -> Self {
        self.specs.push(path.into());
        self
    }

    /// Write into `dir` (a folder of your crate, committed) instead of `OUT_DIR`; without
    /// Python the committed files are used as they are. Include them with
    /// `include!("<dir>/<system>.rs")` or as a module file.
    pub fn checked_in(mut self, dir: impl Into<PathBuf>) -> Self {
        self.checked_in = Some(dir.into());
        self
    }

    /// The path generated code uses for the runtime (default `cbfgen`; a crate that
    /// renames its dependency says so here).
    pub fn runtime_crate(mut self, path: impl Into<String>) -> Self {
        self.runtime_crate = Some(path.into());
        self
    }

    /// Generate every spec; returns the files written (or, checked in without Python,
    /// used). Tells Cargo to rerun when a spec, the generator or `CBFGEN_PYTHON` changes.
    ///
    /// # Errors
    /// See [`Error`]; each names its fix.
    pub fn generate(&self) -> Result<Vec<PathBuf>, Error> {
        println!("cargo:rerun-if-env-changed=CBFGEN_PYTHON");
        println!("cargo:rerun-if-env-changed=CBFGEN_SYMBOLIC");
        let out = match &self.checked_in {
            Some(dir) => dir.clone(),
            None => PathBuf::from(std::env::var_os("OUT_DIR").ok_or(Error::NoOutDir)?),
        };
        for spec in &self.specs {
            if !spec.is_file() {
                return Err(Error::NoSpec { spec: spec.clone() });
            }
            println!("cargo:rerun-if-changed={}", spec.display());
        }
        let generator = generator_root()?;
        watch(&generator.join("symbolic"));
        let python = python();
        match check_python(&python) {
            Ok(()) => {}
            Err(e) if self.checked_in.is_some() => return self.use_checked_in(&out, e),
            Err(e) => return Err(e),
        }
        std::fs::create_dir_all(&out).map_err(|e| Error::Generator {
            spec: out.clone(),
            message: format!("cannot create {}: {e}", out.display()),
        })?;
        let runtime = self.runtime_crate.as_deref().unwrap_or("cbfgen");
        let mut written = Vec::new();
        for spec in &self.specs {
            let done = Command::new(&python)
                .args(["-m", "symbolic", "generate"])
                .arg(spec)
                .arg("--out")
                .arg(&out)
                .args(["--runtime-crate", runtime])
                .env("PYTHONPATH", &generator)
                .output()
                .map_err(|_| Error::NoPython { python: python.clone() })?;
            if !done.status.success() {
                return Err(Error::Generator { spec: spec.clone(), message: last_line(&done.stderr) });
            }
            // The generator's last line is `generated <file>`.
            let line = last_line(&done.stdout);
            written.push(PathBuf::from(line.strip_prefix("generated ").unwrap_or(&line)));
        }
        Ok(written)
    }

    /// [`Generator::generate`], reporting a failure to Cargo as one `cargo::error` line
    /// (the build then fails with that line and nothing else).
    pub fn build(&self) {
        if let Err(e) = self.generate() {
            println!("cargo::error={e}");
        }
    }

    fn use_checked_in(&self, dir: &Path, why: Error) -> Result<Vec<PathBuf>, Error> {
        let files: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|entries| {
                entries.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "rs")).collect()
            })
            .unwrap_or_default();
        if files.is_empty() {
            return Err(Error::MissingCheckedIn { file: dir.join("<system>.rs") });
        }
        println!("cargo:warning=using the checked-in files in {} without regenerating them ({why})", dir.display());
        Ok(files)
    }
}

/// The folder that contains `symbolic/`.
fn generator_root() -> Result<PathBuf, Error> {
    let root = std::env::var_os("CBFGEN_SYMBOLIC").map_or_else(|| PathBuf::from(SOURCE_TREE), PathBuf::from);
    if root.join("symbolic").join("__main__.py").is_file() {
        Ok(root)
    } else {
        Err(Error::NoGenerator { looked_in: root })
    }
}

fn python() -> PathBuf {
    std::env::var_os("CBFGEN_PYTHON").map_or_else(|| PathBuf::from("python3"), PathBuf::from)
}

fn check_python(python: &Path) -> Result<(), Error> {
    let probe = Command::new(python)
        .args(["-c", "import symengine"])
        .output()
        .map_err(|_| Error::NoPython { python: python.to_path_buf() })?;
    if probe.status.success() {
        Ok(())
    } else {
        Err(Error::NoSymEngine { python: python.to_path_buf() })
    }
}

/// Rerun when any generator source changes (a cbfgen upgrade regenerates).
fn watch(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        if path.is_dir() {
            if name != "tests" && name != "__pycache__" {
                watch(&path);
            }
        } else if path.extension().is_some_and(|x| x == "py" || x == "toml" || x == "txt") {
            println!("cargo:rerun-if-changed={}", path.display());
        }
    }
}

fn last_line(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no output").trim().to_string()
}
