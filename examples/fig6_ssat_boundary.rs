//! The Tachyon 3 paper's Fig. 6 from the generated SSAT: where box B's centre must be for
//! the smooth SAT value to read 0, with log-sum-exp (left panel) and the Boltzmann
//! operator (right panel) at three α, beside the exact SAT boundary. The scene and why
//! the 3-D kernels give the 2-D case are in `cbfgen_testkit::ssat_boundary`.
//!
//! `cargo run --release --example fig6_ssat_boundary [-- OUT_DIR]` writes
//! `fig6_ssat_boundary_lse.{svg,png}` and `fig6_ssat_boundary_boltzmann.{svg,png}` into
//! OUT_DIR (default `out/`) and prints each curve's convexity and its exact SAT
//! separation (how far it lies outside (+) or inside (−) the exact boundary).

use cbfgen::ssat::{self, SmoothAbs, SmoothMax, SmoothParams};
use cbfgen::{sat, OrientedBox};
use cbfgen_chart::{Chart, Series};
use cbfgen_testkit::ssat_boundary::{boundary, box_a, box_b, turns, HALF_A, HALF_B, YAW_B_DEG};
use std::path::PathBuf;

/// The three smoothing sharpnesses [1/m]: smoothing lengths of 20, 10 and 5 cm against
/// boxes of 0.4–1.2 m.
const ALPHAS: [f64; 3] = [5.0, 10.0, 20.0];
const COLORS: [&str; 3] = ["red", "green", "blue"];
const RAYS: usize = 720;

fn closed(mut p: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    p.push(p[0]);
    p
}

fn main() -> std::io::Result<()> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".into()));
    let exact = boundary(sat::separation, RAYS);
    let sep = |(x, y): (f64, f64)| sat::separation(&box_a(), &box_b(x, y));
    let title = |what: &str| {
        format!(
            "Fig. 6, {what}: B ({}×{} m, yaw {YAW_B_DEG}°) around A ({}×{} m)",
            2.0 * HALF_B.0,
            2.0 * HALF_B.1,
            2.0 * HALF_A.0,
            2.0 * HALF_A.1
        )
    };
    let mut charts = Vec::new();
    for (max, what, stem) in [
        (SmoothMax::Lse, "log-sum-exp", "fig6_ssat_boundary_lse"),
        (SmoothMax::Boltzmann, "Boltzmann", "fig6_ssat_boundary_boltzmann"),
    ] {
        let mut chart = Chart::new(&title(what), "B's centre x [m]", "B's centre y [m]").equal_axes();
        for (alpha, color) in ALPHAS.into_iter().zip(COLORS) {
            // α_rot stays at its default 200: the rotation entries (0, ±sin 10°, cos 10°)
            // are then smoothed to within 1e-15, and α alone shapes the curve.
            let p = SmoothParams::new(alpha, 200.0).expect("α in its domain").with_variant(max, SmoothAbs::XTanh);
            let curve = boundary(|a: &OrientedBox, b: &OrientedBox| ssat::ssat(a, b, &p), RAYS);
            let t = turns(&curve);
            let (tmin, tmax) = t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            let (smin, smax) = curve
                .iter()
                .map(|&q| sep(q))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
            println!(
                "{what:<11} α = {alpha:>4}: turns in [{tmin:.3e}, {tmax:.3e}] ({} negative of {RAYS}); exact separation on the curve {smin:+.4} … {smax:+.4} m",
                t.iter().filter(|&&v| v < 0.0).count()
            );
            chart = chart.with(Series::new(&format!("h = 0, α = {alpha} 1/m"), color, closed(curve)));
            if max == SmoothMax::Lse {
                let certified = boundary(|a: &OrientedBox, b: &OrientedBox| ssat::certified_clearance(a, b, &p), RAYS);
                let smin = certified.iter().map(|&q| sep(q)).fold(f64::INFINITY, f64::min);
                println!("{:<11} α = {alpha:>4}: certified curve h = m + guard, exact separation ≥ {smin:+.4} m", "");
                chart = chart
                    .with(Series::new(&format!("h = m (certified), α = {alpha}"), color, closed(certified)).dashed());
            }
        }
        chart = chart.with(Series::new("exact SAT", "black", closed(exact.clone())));
        charts.push((stem.to_string(), chart));
    }
    for path in cbfgen_chart::write_charts(&dir, &charts)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}
