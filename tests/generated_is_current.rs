//! Regeneration is reproducible: the generator, run into a temporary directory, writes
//! files byte-identical to the committed generated/.
//!
//! Skips (with a message) when no Python with symengine is found, unless
//! CBFGEN_REQUIRE_SYMENGINE is set, as `scripts/cbf test` does, which makes that a failure.

use std::path::{Path, PathBuf};
use std::process::Command;

fn python(root: &Path) -> PathBuf {
    if let Ok(p) = std::env::var("CBFGEN_PYTHON") {
        return p.into();
    }
    let venv = root.join(".venv/bin/python");
    if venv.is_file() {
        venv
    } else {
        "python3".into()
    }
}

#[test]
fn generator_reproduces_committed_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let py = python(root);
    let has_symengine = Command::new(&py).args(["-c", "import symengine"]).status().is_ok_and(|s| s.success());
    if !has_symengine {
        assert!(
            std::env::var_os("CBFGEN_REQUIRE_SYMENGINE").is_none(),
            "{} has no symengine; run `scripts/cbf setup`",
            py.display()
        );
        eprintln!("SKIPPED: {} has no symengine (run `scripts/cbf setup`)", py.display());
        return;
    }
    let out = std::env::temp_dir().join(format!("cbfgen-regen-{}", std::process::id()));
    let status = Command::new(&py)
        .args(["-m", "symbolic.generate", "--out"])
        .arg(&out)
        .current_dir(root)
        .status()
        .expect("generator starts");
    assert!(status.success(), "generator failed");
    let mut compared = 0;
    for entry in std::fs::read_dir(&out).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap();
        let fresh = std::fs::read(&path).unwrap();
        let committed = std::fs::read(root.join("generated").join(name))
            .unwrap_or_else(|_| panic!("generated/{} is missing", name.to_string_lossy()));
        assert!(fresh == committed, "generated/{} differs from a fresh generation", name.to_string_lossy());
        compared += 1;
    }
    std::fs::remove_dir_all(&out).ok();
    assert!(compared >= 2);
}
