//! What a simulation leaves behind: a CSV time series, the paper's Figs. 7–10 as SVG,
//! and a printed summary.
//!
//! CSV columns, one row per recorded cycle:
//!
//! | column | meaning |
//! |---|---|
//! | `t` | time \[s\] |
//! | `px` … `rr_vz` | the 36 states, `model::STATE_NAMES` order (origin-relative body and toes) |
//! | `body_z_world`, `body_raise` | body centre height, and its excess over the gait's nominal \[m\] |
//! | `min_h_<family>` | minimum `h` over that family's applicable rows (empty if none) |
//! | `active_rows`, `iterations`, `source` | rows in the QP, ADMM iterations, where `u` came from (`InputSource::name`: qp, unconverged, last_safe, nominal_clipped) |
//! | `computed_rows`, `culled_rows` | rows computed this cycle (filled instances, empty capacity slots excluded), and those of them culled by their lower bound (never applied) |
//! | `eval_us`, `solve_us`, `update_us` | row evaluation, QP, whole filter update: wall time \[µs\] |
//! | `cpu_us` | the thread's CPU time over the whole filter update \[µs\] (0 without a thread clock); far below `update_us` = the thread waited, not worked |
//! | `body_clearance`, `body_nearest` | exact signed distance of the body to the solid terrain (floor and steps as blocks) \[m\], negative = depth into a solid; and where (`body step 2 riser`: the solid and, by the SAT's axis, tread or riser) |
//! | `toe_clearance`, `toe_nearest` | the same for the nearest wheel (toe sphere): about 0 for a wheel on its tread; where (`RR floor tread`) |
//! | `toe_riser_clearance`, `toe_riser_nearest` | the nearest wheel to a riser (contact normal over 30° from vertical) \[m\], and where |
//! | `swinging` | tripod in swing: 0 = (LR, RR, MF), 1 = (MR, LF, RF), -1 = none |

use std::fmt::{self, Write as _};
use std::io;
use std::path::{Path, PathBuf};

use super::{Approach, Plant, Sample, SimResult, Summary};
use crate::catalog::Family;
use crate::generated as gen;
use crate::model::{BODY_Z, STATE_NAMES};
use cbfgen_chart::{Chart, Series};

/// The CSV text of `samples`, every `every`-th cycle.
pub fn csv(samples: &[Sample], every: usize) -> String {
    let mut out = String::from("t");
    for name in STATE_NAMES {
        out.push(',');
        out.push_str(name);
    }
    out.push_str(",body_z_world,body_raise");
    for f in Family::ALL {
        let _ = write!(out, ",min_h_{}", f.name());
    }
    out.push_str(
        ",active_rows,iterations,source,computed_rows,culled_rows,eval_us,solve_us,update_us,cpu_us,body_clearance,body_nearest,toe_clearance,toe_nearest,toe_riser_clearance,toe_riser_nearest,swinging\n",
    );
    for s in samples.iter().step_by(every.max(1)) {
        let _ = write!(out, "{:.3}", s.t);
        for v in s.x {
            let _ = write!(out, ",{v:.6}");
        }
        let _ = write!(out, ",{:.6},{:.6}", s.x[2] + s.x[BODY_Z], s.body_raise);
        for h in s.min_h {
            if h.is_finite() {
                let _ = write!(out, ",{h:.6}");
            } else {
                out.push(',');
            }
        }
        let c = &s.clearance;
        let riser = c.wheel_riser.map_or((String::new(), String::new()), |r| (format!("{:.6}", r.distance), r.place()));
        let _ = writeln!(
            out,
            ",{},{},{},{},{},{:.1},{:.1},{:.1},{:.1},{:.6},{},{:.6},{},{},{},{}",
            s.active_rows,
            s.iterations,
            s.source.name(),
            s.computed_rows,
            s.culled_rows,
            s.eval_us,
            s.solve_us,
            s.update_us,
            s.cpu_us,
            c.body.distance,
            c.body.place(),
            c.wheel.distance,
            c.wheel.place(),
            riser.0,
            riser.1,
            s.swinging
        );
    }
    out
}

/// Write `<scenario>.csv` (and `<scenario>_no_body_cbf.csv` for the comparison run) and
/// the four figures into `dir`; `osqp_reference`, the same course with the OSQP backend,
/// adds its QP time to Fig. 10. A run on perceived terrain adds its perception record
/// (updates, last map, what was extracted, side and top views). Returns the paths written.
///
/// # Errors
/// Any I/O error.
pub fn write_all(
    dir: &Path,
    main: &SimResult,
    comparison: Option<&SimResult>,
    osqp_reference: Option<&SimResult>,
    every: usize,
) -> io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for run in std::iter::once(main).chain(comparison) {
        files.push((format!("{}.csv", file_stem(&run.summary)), csv(&run.samples, every)));
    }
    // Every run of the course on one page, one clock.
    let terrain = main.summary.scenario.terrain().map_err(io::Error::other)?;
    let mut runs = vec![(if main.summary.body_cbf { "with the body CBF" } else { "without the body CBF" }, main)];
    runs.extend(comparison.map(|run| ("without the body CBF", run)));
    let page = super::animation::animation(&runs, &terrain).map_err(io::Error::other)?;
    files.push((format!("{}_animation.html", main.summary.scenario.name()), page.html));
    let mut charts: Vec<(String, Chart)> = figures(main, comparison, osqp_reference)
        .into_iter()
        .map(|(name, chart)| (format!("{}_{name}", main.summary.scenario.name()), chart))
        .collect();
    let route = main.summary.scenario.route().map_err(io::Error::other)?;
    if route.flights().len() > 1 {
        let top = top_view(&route, main).map_err(io::Error::other)?;
        charts.push((format!("{}_top_view", main.summary.scenario.name()), top));
    }
    if let Some(perception) = &main.perception {
        let (more_files, more_charts) = perception_files(&file_stem(&main.summary), main.summary.scenario, perception)?;
        files.extend(more_files);
        charts.extend(more_charts);
    }
    let mut written = cbfgen_chart::write_files(dir, files)?;
    written.extend(cbfgen_chart::write_charts(dir, &charts)?);
    Ok(written)
}

/// A perceived run's record: every update (`<stem>_perception.csv`), the last map
/// (`<stem>_map.csv`: x, y, z and the returns each voxel averages), what the last update extracted (`<stem>_perceived.txt`:
/// planes, cuboids) and its side and top views over the true edge cuboids.
/// Text files `(name, contents)` and charts `(stem, chart)` to write.
type NamedFiles = (Vec<(String, String)>, Vec<(String, Chart)>);

fn perception_files(
    stem: &str,
    scenario: super::Scenario,
    perception: &super::PerceptionRun,
) -> io::Result<NamedFiles> {
    use std::fmt::Write as _;
    let mut updates = String::from("requested_at,applied_at,map_points,planes,cuboids,levels,elapsed_ms\n");
    for u in &perception.updates {
        let _ = writeln!(
            updates,
            "{},{},{},{},{},{},{:.3}",
            u.requested_at,
            u.applied_at,
            u.map_points,
            u.planes,
            u.edges.len(),
            u.levels,
            u.elapsed.as_secs_f64() * 1e3
        );
    }
    let mut files = vec![(format!("{stem}_perception.csv"), updates)];
    let Some(last) = &perception.last else { return Ok((files, Vec::new())) };
    let mut map = String::from("x,y,z,returns\n");
    for (p, n) in last.points.iter().zip(&last.weights) {
        let _ = writeln!(map, "{:.4},{:.4},{:.4},{n}", p.x, p.y, p.z);
    }
    let mut found = String::new();
    for (k, p) in last.planes.iter().enumerate() {
        let _ = writeln!(
            found,
            "plane {k}: normal ({:+.4}, {:+.4}, {:+.4}), offset {:+.4} m, {} inliers, hull of {} vertices",
            p.normal.x,
            p.normal.y,
            p.normal.z,
            p.offset,
            p.inliers,
            p.polygon.len()
        );
    }
    for (k, c) in last.cuboids.iter().enumerate() {
        let axis = c.rotation().matrix().column(0);
        let _ = writeln!(
            found,
            "cuboid {k}: centre ({:.4}, {:.4}, {:.4}) m, axis ({:+.4}, {:+.4}, {:+.4}), {:.3} m long",
            c.center().x,
            c.center().y,
            c.center().z,
            axis[0],
            axis[1],
            axis[2],
            2.0 * c.half_extents().x
        );
    }
    files.push((format!("{stem}_map.csv"), map));
    files.push((format!("{stem}_perceived.txt"), found));
    let truth = scenario.terrain().and_then(|t| t.edge_boxes()).map_err(io::Error::other)?;
    let charts = cbfgen_perception::figure::side_and_top(&last.points, &last.planes, &last.cuboids, &truth)
        .into_iter()
        .map(|(name, chart)| (format!("{stem}_perception_{name}"), chart))
        .collect();
    Ok((files, charts))
}

fn file_stem(s: &Summary) -> String {
    if s.body_cbf {
        s.scenario.name().to_string()
    } else {
        format!("{}_no_body_cbf", s.scenario.name())
    }
}

/// A course with turns from above: each solid's top face, the riser boxes the filter
/// avoids, the body centre's path and the six toes' (the side view of the animation shows
/// only the first flight's profile).
///
/// # Errors
/// As [`Route::solid_boxes`](crate::terrain::route::Route::solid_boxes).
pub fn top_view(route: &crate::terrain::route::Route, run: &SimResult) -> Result<Chart, cbfgen::CbfError> {
    let outline = |b: &cbfgen::OrientedBox| -> Vec<(f64, f64)> {
        let (c, r, h) = (b.center(), b.rotation(), b.half_extents());
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .iter()
            .map(|&(u, v)| {
                let p = c + r * nalgebra::Vector3::new(u * h.x, v * h.y, h.z);
                (p.x, p.y)
            })
            .collect()
    };
    let mut chart = Chart::new(
        &format!("{} from above: solids, riser boxes, body and toe paths", run.summary.scenario.name()),
        "world x [m]",
        "world y [m]",
    )
    .equal_axes();
    // The floor slab would set the scale: leave it out.
    for (k, solid) in route.solid_boxes()?.iter().enumerate().skip(1) {
        chart = chart.with(Series::new(if k == 1 { "solid blocks (top faces)" } else { "" }, "#999", outline(solid)));
    }
    for (k, riser) in route.riser_boxes()?.iter().enumerate() {
        chart = chart.with(Series::new(if k == 0 { "riser boxes (filter)" } else { "" }, "#d62728", outline(riser)));
    }
    let toes = |leg: usize| {
        run.samples
            .iter()
            .step_by(20)
            .map(|s| {
                let (_, _, toes) = gen::world_kinematics(&s.x);
                (toes[leg][0], toes[leg][1])
            })
            .collect()
    };
    for leg in 0..6 {
        chart = chart.with(Series::new(if leg == 0 { "toe paths" } else { "" }, "#2ca02c", toes(leg)));
    }
    let body = run
        .samples
        .iter()
        .step_by(20)
        .map(|s| {
            let (c, _, _) = gen::world_kinematics(&s.x);
            (c[0], c[1])
        })
        .collect();
    Ok(chart.with(Series::new("body centre", "#1f77b4", body)))
}

fn series(samples: &[Sample], f: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    samples.iter().map(|s| (s.t, f(s))).collect()
}

/// Figs. 7–10 of the paper for one run (and the run without the body CBF, for Fig. 7; the
/// run with the OSQP backend, for Fig. 10).
pub fn figures(
    main: &SimResult,
    comparison: Option<&SimResult>,
    osqp_reference: Option<&SimResult>,
) -> Vec<(&'static str, Chart)> {
    let body_z = |s: &Sample| s.x[2] + s.x[BODY_Z];
    let label = |r: &SimResult| if r.summary.body_cbf { "with body SSAT CBF" } else { "without body SSAT CBF" };
    let mut fig7 = Chart::new("Body height (Fig. 7)", "time [s]", "body centre height [m]").with(Series::new(
        label(main),
        "#1f77b4",
        series(&main.samples, body_z),
    ));
    if let Some(other) = comparison {
        fig7 = fig7.with(Series::new(label(other), "#d62728", series(&other.samples, body_z)));
    }
    fig7 =
        fig7.with(Series::new("nominal (gait)", "#555", series(&main.samples, |s| body_z(s) - s.body_raise)).dashed());
    let min_h = |f: Family| move |s: &Sample| s.min_h[f.index()];
    let fig8 = Chart::new("Minimum h (Fig. 8)", "time [s]", "h")
        .with(Series::new("body–edge SSAT [m]", "#1f77b4", series(&main.samples, min_h(Family::BodyEdge))))
        .with(Series::new("joint limits [m, rad]", "#2ca02c", series(&main.samples, min_h(Family::JointLimits))))
        .with(Series::new("h = 0", "#555", series(&main.samples, |_| 0.0)).dashed());
    // The paper's "valid CBFs": what each cycle computed and what it applied. Empty
    // capacity slots (the catalog is laid out for the paper's 269 rows) are in neither;
    // the gap between the first two lines is the rows culled by their lower bound.
    let fig9 = Chart::new("CBF rows computed and applied (Fig. 9)", "time [s]", "rows")
        .with(Series::new("computed (filled instances)", "#1f77b4", series(&main.samples, |s| s.computed_rows as f64)))
        .with(
            Series::new(
                "evaluated in full (computed − culled by their lower bound)",
                "#2ca02c",
                series(&main.samples, |s| (s.computed_rows - s.culled_rows) as f64),
            )
            .dashed(),
        )
        .with(Series::new("applied (in the QP)", "#9467bd", series(&main.samples, |s| s.active_rows as f64)));
    let backend = main.summary.backend.name();
    let mut fig10 = Chart::new("Computation time per cycle (Fig. 10)", "time [s]", "µs")
        .with(Series::new(&format!("whole update ({backend})"), "#1f77b4", series(&main.samples, |s| s.update_us)))
        .with(Series::new("whole update, thread CPU time", "#d62728", series(&main.samples, |s| s.cpu_us)).dashed())
        .with(Series::new("row evaluation", "#2ca02c", series(&main.samples, |s| s.eval_us)))
        .with(Series::new(&format!("QP update + solve ({backend})"), "#ff7f0e", series(&main.samples, |s| s.solve_us)));
    if let Some(osqp) = osqp_reference {
        fig10 = fig10.with(Series::new(
            "QP update + solve (osqp, same course)",
            "#9467bd",
            series(&osqp.samples, |s| s.solve_us),
        ));
    }
    vec![("fig7_body_height", fig7), ("fig8_min_h", fig8), ("fig9_active_rows", fig9), ("fig10_cycle_time", fig10)]
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "scenario {}{} {} body SSAT CBF, QP backend {}: {} after {:.1} s",
            self.scenario.name(),
            if self.perception.is_some() { " (perceived terrain)" } else { "" },
            if self.body_cbf { "with" } else { "without" },
            self.backend.name(),
            if self.completed { "climbed" } else { "did NOT finish" },
            self.duration
        )?;
        let approach = |a: Option<Approach>| a.map_or_else(|| "-".into(), |a| format!("{} at {:.2} s", a.contact, a.t));
        match self.plant {
            Plant::Euler => writeln!(f, "  plant: one Euler step per 1 ms period, measured at the samples")?,
            Plant::Held { fine } => {
                writeln!(f, "  plant: input held, RK4 at 1 ms / {fine}, measured at every fine step")?;
            }
        }
        if let Some(certified) = self.certified_cycles {
            writeln!(f, "  updates certified between the samples: {certified} of {}", self.cycles)?;
        }
        writeln!(
            f,
            "  exact clearance to the solid terrain ({}):",
            if self.penetrated() { "PENETRATION beyond 1 mm" } else { "no penetration beyond 1 mm" }
        )?;
        writeln!(f, "    body, nearest: {}", approach(self.body_nearest))?;
        writeln!(f, "    wheels, nearest (0 on a tread): {}", approach(self.toe_nearest))?;
        writeln!(
            f,
            "    wheels to a riser, nearest: {}; cycles with a wheel on a riser: {}",
            approach(self.toe_riser_nearest),
            self.riser_contact_cycles
        )?;
        write!(f, "  minimum h:")?;
        for fam in Family::ALL {
            let h = self.min_h[fam.index()];
            if h.is_finite() {
                write!(f, " {} {:.4}", fam.name(), h)?;
            }
        }
        writeln!(f)?;
        writeln!(f, "  maximum body raise above nominal: {:.1} cm", self.max_body_raise * 100.0)?;
        writeln!(
            f,
            "  filter update, wall: median {:.1} µs, p99 {:.1} µs, max {:.1} µs; cycles over 1 ms: {}",
            self.median_update_us, self.p99_update_us, self.max_update_us, self.over_period_wall
        )?;
        writeln!(
            f,
            "  filter update, thread CPU: median {:.1} µs, p99 {:.1} µs, max {:.1} µs; cycles over 1 ms: {}",
            self.median_cpu_us, self.p99_cpu_us, self.max_cpu_us, self.over_period_cpu
        )?;
        let (w, most) = (&self.worst_case, &self.max_work);
        writeln!(
            f,
            "  filter update, work (most in a cycle / stated worst case): {} / {} QP solves, {} / {} dense-solver trips, {} / {} OSQP iterations; cycles beyond it: {} in counts, {} in CPU time",
            most.qp_solves,
            w.qp_solves,
            most.dense_trips,
            w.dense_trips,
            most.osqp_iterations,
            w.osqp_iterations,
            self.over_worst_case,
            self.over_time_bound
        )?;
        write!(f, "  cycles not solved to tolerance: {}", self.fallback_cycles)?;
        write!(f, "\n  cycles with rows relaxed (the filter's verdict), per family:")?;
        for family in Family::ALL {
            write!(f, " {} {}", family.name(), self.relaxed_cycles[family.index()])?;
        }
        if let Some(p) = &self.perception {
            write!(
                f,
                "\n  perception: {} updates on the worker thread, median {:.1} ms, max {:.1} ms; last map {} points, {} edge cuboids",
                p.updates, p.median_ms, p.max_ms, p.last_map_points, p.last_cuboids
            )?;
        }
        Ok(())
    }
}
