//! The run's animation page: as many frames as it says, every run's series that long,
//! one frame per 40 ms of the run, and a body that is the body box.

use cbfgen::systems::tachyon3::model::BODY_HALF_EXTENTS;
use cbfgen::systems::tachyon3::sim::animation::{animation, FRAME_PERIOD};
use cbfgen::systems::tachyon3::sim::{self, Scenario, SimConfig};

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

    let start = page.html.find(r#"<script type="application/json" id="data">"#).expect("data") + 42;
    let end = start + page.html[start..].find("</script>").expect("end of data");
    let data: serde_json::Value = serde_json::from_str(&page.html[start..end]).expect("valid JSON");
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
        let t: Vec<f64> = run["t"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!(t.windows(2).all(|w| (w[1] - w[0] - FRAME_PERIOD).abs() < 1e-4));
        // The body's side view is the box's: adjacent corners 2 hz and 2 hx apart (to
        // the page's 0.1 mm).
        for body in run["body"].as_array().unwrap() {
            let c: Vec<f64> = body.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
            let side = |i: usize, j: usize| (c[2 * i] - c[2 * j]).hypot(c[2 * i + 1] - c[2 * j + 1]);
            assert!((side(0, 1) - 2.0 * BODY_HALF_EXTENTS[2]).abs() < 2e-4);
            assert!((side(1, 2) - 2.0 * BODY_HALF_EXTENTS[0]).abs() < 2e-4);
        }
    }
    assert_eq!(runs[1]["frames"].as_u64(), Some(50), "a shorter run has its own frame count");
}
