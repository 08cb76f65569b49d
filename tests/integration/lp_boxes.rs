//! Table I's LP query (the growth distance solved by Clarabel, `cbfgen_testkit::lp_boxes`)
//! gives the exact SAT's verdict: the bench times a query that answers the same question.

use cbfgen::{sat, OrientedBox};
use cbfgen_testkit::boxes::random_pairs;
use cbfgen_testkit::lp_boxes::{growth_distance, settings};
use nalgebra::Vector3;

#[test]
fn lp_verdict_matches_exact_sat_on_random_pairs() {
    // The bench's own pairs (seed 7, spread 1) and a denser set with more overlaps.
    let pairs: Vec<_> = random_pairs(7, 1024, 1.0).into_iter().chain(random_pairs(23, 4000, 0.6)).collect();
    let (mut compared, mut overlapping) = (0, 0);
    for (a, b) in &pairs {
        let s = sat::separation(a, b);
        if s.abs() <= 1e-6 {
            continue; // touching within the solver's tolerance: either verdict is right
        }
        let t = growth_distance(a, b, settings()).unwrap_or_else(|| panic!("Clarabel failed on {a:?} / {b:?}"));
        assert_eq!(t > 1.0, s > 0.0, "LP t* = {t}, SAT separation {s} on {a:?} / {b:?}");
        compared += 1;
        overlapping += (s < 0.0) as usize;
    }
    assert!(compared >= 4900, "{compared}");
    // Both verdicts must be well represented, or agreement proves little.
    assert!(overlapping > compared / 5 && overlapping < compared * 4 / 5, "{overlapping} of {compared}");
}

#[test]
fn lp_growth_distance_is_the_hand_computed_factor() {
    // Cubes of half size 1 and 0.5, centres 3 m apart along x: they touch when grown by
    // t with 1·t + 0.5·t = 3, i.e. t* = 2; at 1.2 m apart t* = 0.8.
    let a = OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(1.0, 1.0, 1.0)).unwrap();
    let far = OrientedBox::axis_aligned(Vector3::new(3.0, 0.2, 0.0), Vector3::new(0.5, 0.5, 0.5)).unwrap();
    let near = OrientedBox::axis_aligned(Vector3::new(1.2, 0.0, 0.0), Vector3::new(0.5, 0.5, 0.5)).unwrap();
    let t_far = growth_distance(&a, &far, settings()).unwrap();
    let t_near = growth_distance(&a, &near, settings()).unwrap();
    assert!((t_far - 2.0).abs() < 1e-6, "{t_far}");
    assert!((t_near - 0.8).abs() < 1e-6, "{t_near}");
}
