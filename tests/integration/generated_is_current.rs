//! Regeneration is reproducible: the generator's fresh output is byte-identical to every
//! committed generated file (the core's generated/ and each built-in system crate's).
//!
//! Skips (with a message) when no Python with symengine is found, unless
//! CBFGEN_REQUIRE_SYMENGINE is set, as `scripts/cbf test` does, which makes that a failure.

use std::path::Path;
use std::process::Command;

#[test]
fn generator_reproduces_committed_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // The interpreter every build uses (CBFGEN_PYTHON, a virtual environment, python3).
    let py = cbfgen_build::python_interpreter(&[root]);
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
    let done = Command::new(&py)
        .args(["-m", "symbolic.generate", "--check"])
        .current_dir(root)
        .output()
        .expect("generator starts");
    assert!(
        done.status.success(),
        "generated code differs from a fresh generation:\n{}",
        String::from_utf8_lossy(&done.stderr)
    );
}
