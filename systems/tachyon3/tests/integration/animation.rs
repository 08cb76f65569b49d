//! The run's animation page: as many frames as it says, every run's series that long,
//! one frame per 40 ms of the run, and a body that is the body box.

use cbfgen_tachyon3::model::BODY_HALF_EXTENTS;
use cbfgen_tachyon3::sim::animation::{animation, FRAME_PERIOD};
use cbfgen_tachyon3::sim::perceived::PerceptionSettings;
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};
use nalgebra::Vector3;

/// The JSON the page plays back.
fn page_data(html: &str) -> serde_json::Value {
    let tag = r#"<script type="application/json" id="data">"#;
    let start = html.find(tag).expect("data") + tag.len();
    let end = start + html[start..].find("</script>").expect("end of data");
    serde_json::from_str(&html[start..end]).expect("valid JSON")
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect()
}

#[test]
fn the_page_holds_as_many_frames_as_it_says_and_draws_the_body_box() {
    let mut short = SimConfig::new(Scenario::Step, true);
    short.max_time = 3.0;
    let with = sim::run(&short, |_| {}).expect("simulation");
    let mut shorter = SimConfig::new(Scenario::Step, false);
    shorter.max_time = 2.0;
    let without = sim::run(&shorter, |_| {}).expect("simulation");
    let terrain = Scenario::Step.terrain().unwrap();
    let page = animation(&[("with", &with), ("without", &without)], &terrain).unwrap();

    let data = page_data(&page.html);
    // 3 s at one frame per 40 ms: 75 frames (the run's samples, every 40th).
    assert_eq!(page.frames, with.samples.len().div_ceil(40));
    assert_eq!(page.frames, 75);
    assert_eq!(data["frames"].as_u64(), Some(page.frames as u64));
    let runs = data["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2);
    for (run, samples) in runs.iter().zip([&with.samples, &without.samples]) {
        let n = run["frames"].as_u64().unwrap() as usize;
        assert_eq!(n, samples.len().div_ceil(40));
        for key in ["t", "body", "hips", "toes", "h_body", "h_min", "clearance", "rows"] {
            assert_eq!(run[key].as_array().unwrap().len(), n, "{key}");
        }
        let t = numbers(&run["t"]);
        assert!(t.windows(2).all(|w| (w[1] - w[0] - FRAME_PERIOD).abs() < 1e-4));
        // The body's side view is the box's: adjacent corners 2 hz and 2 hx apart (to
        // the page's 0.1 mm).
        for body in run["body"].as_array().unwrap() {
            let c = numbers(body);
            let side = |i: usize, j: usize| (c[2 * i] - c[2 * j]).hypot(c[2 * i + 1] - c[2 * j + 1]);
            assert!((side(0, 1) - 2.0 * BODY_HALF_EXTENTS[2]).abs() < 2e-4);
            assert!((side(1, 2) - 2.0 * BODY_HALF_EXTENTS[0]).abs() < 2e-4);
        }
    }
    assert_eq!(runs[1]["frames"].as_u64(), Some(50), "a shorter run has its own frame count");
    assert!(runs.iter().all(|r| r.get("perceived").is_none()), "a run on the true terrain shows no perception");
}

#[test]
fn a_perceived_run_shows_what_each_update_gave_the_filter() {
    let mut config =
        SimConfig { perception: Some(PerceptionSettings::default()), ..SimConfig::new(Scenario::Step, true) };
    config.max_time = 3.0;
    let run = sim::run(&config, |_| {}).expect("simulation");
    let updates = &run.perception.as_ref().expect("perception record").updates;
    let page = animation(&[("perceived", &run)], &Scenario::Step.terrain().unwrap()).unwrap();
    let data = page_data(&page.html);
    let shown = data["runs"][0]["perceived"].as_array().expect("perceived updates");
    // Updates are applied at 0 s (before the first cycle), then 0.5 s after each 1 Hz
    // request: 1.5 and 2.5 s within 3 s.
    assert_eq!(shown.len(), updates.len());
    assert_eq!(shown.len(), 3);
    for (u, recorded) in shown.iter().zip(updates) {
        assert!((u["t"].as_f64().unwrap() - recorded.applied_at).abs() < 1e-4);
        let rects = u["edges"].as_array().unwrap();
        assert_eq!(rects.len(), recorded.edges.len());
        // Each rectangle bounds the box's eight corners projected on x-z.
        for (rect, b) in rects.iter().zip(&recorded.edges) {
            let r = numbers(rect);
            let corners: Vec<Vector3<f64>> = (0..8)
                .map(|k| {
                    let sign = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                    let local = b.half_extents().component_mul(&Vector3::new(sign(0), sign(1), sign(2)));
                    b.center() + b.rotation() * local
                })
                .collect();
            for (axis, (c, h)) in [(0, (r[0], r[2])), (2, (r[1], r[3]))] {
                let lo = corners.iter().map(|p| p[axis]).fold(f64::INFINITY, f64::min);
                let hi = corners.iter().map(|p| p[axis]).fold(f64::NEG_INFINITY, f64::max);
                assert!((c - h - lo).abs() < 2e-4 && (c + h - hi).abs() < 2e-4, "{r:?} vs [{lo}, {hi}]");
            }
        }
        // The ground line steps through the update's levels at their heights.
        let heights: Vec<f64> = u["ground"].as_array().unwrap().iter().map(|p| numbers(p)[1]).collect();
        let levels = recorded.ground.levels();
        assert_eq!(heights.len(), 2 * levels.len());
        for (pair, level) in heights.chunks(2).zip(levels) {
            assert!(pair.iter().all(|z| (z - level.height).abs() < 1e-4));
        }
    }
    // The robot faces the step from the start: the step's nosing is seen at once.
    assert!(!updates[0].edges.is_empty());
}
