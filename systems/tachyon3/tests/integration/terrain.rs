//! Terrain of any profile: heights and edge cuboids checked against hand-computed values
//! and against the solid boxes a scanner sees, and bad dimensions rejected with typed
//! errors.

use cbfgen::OrientedBox;
use cbfgen_tachyon3::terrain::{Level, Profile, Stairs, Terrain};
use nalgebra::Vector3;

fn inside(boxes: &[OrientedBox], p: Vector3<f64>) -> bool {
    boxes.iter().any(|b| {
        let local = b.rotation().inverse() * (p - b.center());
        (0..3).all(|i| local[i].abs() < b.half_extents()[i])
    })
}

/// The hardware stairs and the named shapes a flight does not make.
fn shapes() -> [Terrain; 5] {
    [
        Stairs::HARDWARE.terrain().expect("stairs"),
        Terrain::unequal_rises(),
        Terrain::landing(),
        Terrain::single_box(),
        Terrain::platform(),
    ]
}

#[test]
fn the_hardware_stairs_profile_reads_the_heights_worked_by_hand() {
    let terrain = Stairs::HARDWARE.terrain().expect("terrain");
    let ground = terrain.profile();
    // Risers at 1.00, 1.35, 1.70, 2.05, 2.40 m; 16.5 cm each.
    for (x, h) in [(-5.0, 0.0), (0.999, 0.0), (1.001, 0.165), (1.36, 0.33), (2.0, 0.495), (2.39, 0.66), (9.0, 0.825)] {
        assert!((ground.height_at(x) - h).abs() < 1e-12, "height at {x}: {}", ground.height_at(x));
    }
    assert_eq!(ground.flat_region(1.5), (1.35, 1.7));
    assert_eq!(ground.flat_region(0.0), (f64::NEG_INFINITY, 1.0));
    assert!((ground.final_height() - 0.825).abs() < 1e-12);
    assert!((ground.last_change() - 2.4).abs() < 1e-12);
    // A wheel resting on the first nosing (centre 5 cm before the riser, bottom on the
    // tread's top) stands on the step; the same wheel on the floor does not.
    let on_nosing = [0.95, 0.0, 0.165 + 0.1];
    let on_floor = [0.95, 0.0, 0.1];
    assert_eq!(ground.floors_under(&[on_nosing, on_floor, on_floor, on_floor, on_floor, on_floor])[..2], [0.165, 0.0]);
}

#[test]
fn every_edge_cuboid_sits_in_the_corner_of_its_upper_level() {
    for terrain in shapes() {
        let solids = terrain.solid_boxes().expect("boxes");
        let edges = terrain.edges().expect("edges");
        assert_eq!(edges.len(), terrain.changes().len());
        for (edge, &[x, _]) in edges.iter().zip(terrain.changes()) {
            let s = edge.half[0];
            let c = edge.center;
            // Inside the terrain, touching the top face and the riser (or drop) face:
            // a point just above it and one just beyond its outer side are in the air.
            assert!(inside(&solids, c), "{c:?} not inside the terrain");
            assert!(!inside(&solids, c + Vector3::new(0.0, 0.0, s + 1e-4)), "{c:?}: the top is not the tread");
            let outward = if (c.x - x) > 0.0 { -1.0 } else { 1.0 };
            assert!((c.x - x).abs() - s < 1e-12, "{c:?}: not against the change at x = {x}");
            assert!(!inside(&solids, c + Vector3::new(outward * (s + 1e-4), 0.0, 0.0)), "{c:?}: not at the face");
            assert!(inside(&solids, c + Vector3::new(outward * (s - 1e-4), 0.0, s - 1e-4)), "{c:?}: corner");
        }
    }
}

/// The box the filter keeps the robot out of at each change of height: it spans the whole
/// riser, from the lower tread to the upper, inside the terrain; a wheel standing on the
/// lower tread up to 3 mm from the riser is certified clear of it (its toe row does not
/// hold it off), as is one on the upper tread 2 cm past it; and a wheel before the riser,
/// above the lower tread, is exactly as far from the upper level's solid as from the box:
/// the box is all of that solid such a wheel can reach.
#[test]
fn each_riser_box_spans_its_riser_and_is_all_of_the_step_a_wheel_before_it_can_reach() {
    use cbfgen::sphere_box::{self, Smoothing, Sphere};
    use rand::{Rng, SeedableRng};
    let r = cbfgen_tachyon3::model::TOE_RADIUS;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(32);
    let steep = Stairs { rise: 0.2, run: 0.25, count: 3, ..Stairs::HARDWARE }.terrain().expect("steep stairs");
    for terrain in shapes().into_iter().chain([steep]) {
        let solids = terrain.solid_boxes().expect("boxes");
        let risers = terrain.riser_boxes().expect("riser boxes");
        assert_eq!(risers.len(), terrain.changes().len());
        let mut below = 0.0;
        for (b, &[x, h]) in risers.iter().zip(terrain.changes()) {
            let (lo, hi) = (f64::min(below, h), f64::max(below, h));
            // Into the upper level: +x at a rise, -x at a drop.
            let up = if h > below { 1.0 } else { -1.0 };
            let (c, half) = (b.center(), b.half_extents());
            // Worked by hand: 5 cm deep into the upper level from the riser, lower to upper
            // tread, as wide as the terrain.
            assert!((c.x - (x + up * 0.025)).abs() < 1e-12 && (half.x - 0.025).abs() < 1e-12, "{b:?}");
            assert!((c.z - 0.5 * (lo + hi)).abs() < 1e-12 && (half.z - 0.5 * (hi - lo)).abs() < 1e-12, "{b:?}");
            assert!((half.y - terrain.half_width()).abs() < 1e-12, "{b:?}");
            assert!(inside(&solids, *c), "{b:?} not inside the terrain");
            let upper = solids
                .iter()
                .find(|s| {
                    let p = Vector3::new(x + up * 0.01, 0.0, hi - 0.01);
                    let local = p - s.center();
                    (0..3).all(|i| local[i].abs() < s.half_extents()[i])
                })
                .expect("the upper level's solid");
            let p = Smoothing::new(cbfgen_tachyon3::generated::TOE_ALPHA).expect("alpha");
            let clear =
                |center: Vector3<f64>| sphere_box::certified_separated(&Sphere::new(center, r).expect("sphere"), b, &p);
            assert!(clear(Vector3::new(x - up * (r + 0.003), 0.0, lo + r)), "{b:?}: lower tread");
            assert!(clear(Vector3::new(x + up * (0.05 + 0.02), 0.0, hi + r)), "{b:?}: upper tread");
            for _ in 0..2000 {
                let center = Vector3::new(
                    x - up * rng.random_range(0.0..0.4),
                    rng.random_range(-0.5..0.5),
                    lo + r + rng.random_range(0.0..0.5),
                );
                let to_box = sphere_box::exact_distance(&center, r, b);
                let to_solid = sphere_box::exact_distance(&center, r, upper);
                assert!((to_box - to_solid).abs() < 1e-12, "{center:?}: {to_box} to the box, {to_solid} to the solid");
            }
            below = h;
        }
    }
}

#[test]
fn the_stairs_edges_are_the_nosing_cuboids_stairs_edge_places() {
    let stairs = Stairs::HARDWARE;
    for (k, edge) in stairs.terrain().expect("terrain").edges().expect("edges").iter().enumerate() {
        assert_eq!(*edge, stairs.edge(k).expect("edge"));
    }
}

#[test]
fn bad_terrain_is_a_typed_error() {
    let s = 0.025;
    for (changes, half_width) in [
        (vec![], 1.0),
        (vec![[1.0, f64::NAN]], 1.0),
        (vec![[f64::INFINITY, 0.1]], 1.0),
        (vec![[1e300, 0.1]], 1.0),
        (vec![[1.0, 0.1], [0.9, 0.2]], 1.0),
        (vec![[1.0, 0.1], [1.0 + 0.04, 0.2]], 1.0),
        (vec![[1.0, 0.1], [2.0, 0.12]], 1.0),
        (vec![[1.0, -0.2]], 1.0),
        (vec![[1.0, 0.1]], f64::MAX),
        (vec![[1.0, 0.1]], 0.04),
        (vec![[1.0, 1e300]], 1.0),
    ] {
        assert!(Terrain::new(&changes, half_width, s).is_err(), "{changes:?} {half_width}");
    }
    assert!(Terrain::new(&[[1.0, 0.1]], 1.0, 0.0).is_err());
    assert!(Terrain::new(&vec![[1.0, 0.1]; 101], 1.0, s).is_err());

    let level = |begin: f64, end: f64| Level { begin, end, height: 0.0, half_width: 1.0 };
    for levels in [
        vec![],
        vec![level(0.0, f64::INFINITY)],
        vec![level(f64::NEG_INFINITY, 1.0)],
        vec![level(f64::NEG_INFINITY, 1.0), level(1.5, f64::INFINITY)],
        vec![level(f64::NEG_INFINITY, 1.0), level(1.0, 1.0), level(1.0, f64::INFINITY)],
        vec![Level { height: f64::NAN, ..level(f64::NEG_INFINITY, f64::INFINITY) }],
        vec![Level { half_width: 0.0, ..level(f64::NEG_INFINITY, f64::INFINITY) }],
    ] {
        assert!(Profile::new(levels.clone()).is_err(), "{levels:?}");
    }
}
