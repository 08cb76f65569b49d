//! Every command that draws figures writes each one as a non-empty SVG and a PNG beside
//! it (the command-line tool, run as a user runs it).

use std::path::Path;
use std::process::Command;

fn run(args: &[&str], out: &Path) {
    let status = Command::new(env!("CARGO_BIN_EXE_cbfgen"))
        .args(args)
        .arg("--out")
        .arg(out)
        .stdout(std::process::Stdio::null())
        .status()
        .expect("cbfgen runs");
    assert!(status.success(), "cbfgen {args:?} failed");
}

/// The figures in `dir`, by stem: each must have a non-empty SVG holding an `<svg`
/// element and a PNG with the PNG signature.
fn figures(dir: &Path) -> Vec<String> {
    let mut stems: Vec<String> = std::fs::read_dir(dir)
        .expect("output folder")
        .filter_map(|e| {
            let path = e.ok()?.path();
            let ext = path.extension()?.to_str()?;
            (ext == "svg" || ext == "png").then(|| path.file_stem()?.to_str().map(String::from)).flatten()
        })
        .collect();
    stems.sort();
    stems.dedup();
    for stem in &stems {
        let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap_or_default();
        assert!(svg.contains("<svg") && svg.len() > 1000, "{stem}.svg missing or empty");
        let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap_or_default();
        assert!(png.len() > 5000 && &png[1..4] == b"PNG", "{stem}.png missing or empty");
    }
    stems
}

#[test]
fn every_figure_command_writes_svg_and_png() {
    let root = std::env::temp_dir().join(format!("cbfgen_figures_{}", std::process::id()));
    let cases: [(&str, &[&str], usize); 6] = [
        ("simulate", &["simulate", "--scenario", "step", "--no-osqp-reference"], 4),
        ("campaign", &["campaign", "--episodes", "2", "--steps", "1,1"], 5),
        ("lip", &["lip", "--steps", "20"], 3),
        ("multilayer", &["multilayer"], 2),
        ("arm", &["arm"], 4),
        ("perceive", &["perceive"], 2),
    ];
    for (name, args, expected) in cases {
        let out = root.join(name);
        run(args, &out);
        let stems = figures(&out);
        assert_eq!(stems.len(), expected, "{name}: {stems:?}");
    }
    std::fs::remove_dir_all(&root).ok();
}
