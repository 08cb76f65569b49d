//! The segmented terrain against independent geometry: a patch's distance against the
//! nearest of many points sampled over it; a foothold region's margin at a point on the
//! patch against the point's distance to the nearest edge segment, less the margin; the
//! nearest patch against a search by those distances; and every malformed patch refused.

use cbfgen_anymal::terrain::{Patch, Terrain};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn segment_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let s = ((0..3).map(|i| (p[i] - a[i]) * ab[i]).sum::<f64>() / (0..3).map(|i| ab[i] * ab[i]).sum::<f64>())
        .clamp(0.0, 1.0);
    norm(sub(p, [a[0] + s * ab[0], a[1] + s * ab[1], a[2] + s * ab[2]]))
}

/// A random convex patch: a rectangle or a regular polygon (3–6 sides), turned, tilted up
/// to 30° about a random horizontal axis, anywhere.
fn random_patch(rng: &mut ChaCha8Rng) -> Patch {
    let sides = rng.random_range(3..=6);
    let (rx, ry) = (rng.random_range(0.05..0.4), rng.random_range(0.05..0.4));
    let turn = rng.random_range(0.0..std::f64::consts::TAU);
    let planar: Vec<[f64; 2]> = (0..sides)
        .map(|k| {
            let a = turn + std::f64::consts::TAU * k as f64 / sides as f64;
            [rx * a.cos(), ry * a.sin()]
        })
        .collect();
    let (tilt, axis): (f64, f64) = (rng.random_range(0.0..0.5), rng.random_range(0.0..std::f64::consts::TAU));
    // Rotate (u, v, 0) by `tilt` about the horizontal axis (cos axis, sin axis, 0).
    let (k, c, s) = ([axis.cos(), axis.sin(), 0.0], tilt.cos(), tilt.sin());
    let centre = [rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0), rng.random_range(-0.5..0.5)];
    let vertices: Vec<[f64; 3]> = planar
        .iter()
        .map(|&[u, v]| {
            let p = [u, v, 0.0];
            let kdotp = k[0] * p[0] + k[1] * p[1];
            let kxp = [k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]];
            std::array::from_fn(|i| centre[i] + p[i] * c + kxp[i] * s + k[i] * kdotp * (1.0 - c))
        })
        .collect();
    Patch::new(&vertices).expect("a convex planar patch")
}

/// Points spread over the patch (fans of its triangles, `steps` per side).
fn samples(patch: &Patch, steps: usize) -> Vec<[f64; 3]> {
    let v = patch.vertices();
    let mut out = Vec::new();
    for t in 1..v.len() - 1 {
        let (a, b, c) = (v[0], v[t], v[t + 1]);
        for i in 0..=steps {
            for j in 0..=steps - i {
                let (s, r) = (i as f64 / steps as f64, j as f64 / steps as f64);
                out.push(std::array::from_fn(|k| a[k] + s * (b[k] - a[k]) + r * (c[k] - a[k])));
            }
        }
    }
    out
}

#[test]
fn a_patchs_distance_is_the_nearest_sampled_points() {
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    for _ in 0..200 {
        let patch = random_patch(&mut rng);
        let points = samples(&patch, 60);
        for _ in 0..20 {
            let p = [rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), rng.random_range(-1.0..1.0)];
            let exact = patch.distance(p);
            let sampled = points.iter().map(|q| norm(sub(p, *q))).fold(f64::INFINITY, f64::min);
            // The samples are at most 0.8 m / 60 apart along a side.
            assert!(exact <= sampled + 1e-12 && sampled - exact <= 0.015, "{exact} vs sampled {sampled}");
        }
    }
}

#[test]
fn a_regions_margin_on_the_patch_is_the_distance_to_its_edges_less_the_margin() {
    let mut rng = ChaCha8Rng::seed_from_u64(25);
    for _ in 0..200 {
        let patch = random_patch(&mut rng);
        let margin = rng.random_range(0.0..0.04);
        let Ok(region) = patch.region(margin) else { continue };
        assert_eq!(region.normal, patch.normal());
        let v = patch.vertices();
        for p in samples(&patch, 12) {
            let to_edge =
                (0..v.len()).map(|k| segment_distance(p, v[k], v[(k + 1) % v.len()])).fold(f64::INFINITY, f64::min);
            let got = region.margin(p);
            assert!((got - (to_edge - margin)).abs() < 1e-9, "margin {got} for {to_edge} - {margin}");
            // Lifted off the plane along its normal (a foot centre above it): the same.
            let n = patch.normal();
            let lifted = std::array::from_fn(|i| p[i] + 0.03 * n[i]);
            assert!((region.margin(lifted) - got).abs() < 1e-9);
        }
    }
    let stone = Patch::rectangle([0.0; 3], [0.1, 0.05], 0.3).unwrap();
    assert!(stone.region(0.049).is_ok());
    assert!(stone.region(0.05).is_err(), "a margin reaching the centre leaves nothing");
    assert!(stone.region(-0.01).is_err() && stone.region(f64::NAN).is_err());
}

#[test]
fn the_nearest_patch_is_the_one_at_the_least_distance() {
    let mut rng = ChaCha8Rng::seed_from_u64(26);
    let terrain = Terrain::new((0..30).map(|_| random_patch(&mut rng)).collect()).unwrap();
    for _ in 0..500 {
        let p = [rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), rng.random_range(-1.0..1.0)];
        let (k, d) = terrain.nearest(p).unwrap();
        for patch in terrain.patches() {
            assert!(d <= patch.distance(p));
        }
        assert_eq!(d, terrain.patches()[k].distance(p));
    }
    assert!(Terrain::new(Vec::new()).is_err());
}

#[test]
fn malformed_patches_are_refused() {
    let square = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    assert!(Patch::new(&square).is_ok());
    let mut clockwise = square;
    clockwise.reverse();
    let patch = Patch::new(&clockwise).unwrap();
    assert_eq!(patch.normal(), [0.0, 0.0, 1.0], "clockwise vertices are turned round");
    assert!(Patch::new(&square[..2]).is_err(), "two vertices");
    let seven: Vec<[f64; 3]> = (0..7)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 7.0;
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    assert!(Patch::new(&seven).is_err(), "more sides than a region holds");
    let dart = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 0.2, 0.0], [0.0, 1.0, 0.0]];
    assert!(Patch::new(&dart).is_err(), "not convex");
    let warped = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.01], [0.0, 1.0, 0.0]];
    assert!(Patch::new(&warped).is_err(), "not planar");
    let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    assert!(Patch::new(&line).is_err(), "no area");
    let wall = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
    assert!(Patch::new(&wall).is_err(), "vertical");
    let nan = [[0.0, 0.0, 0.0], [1.0, 0.0, f64::NAN], [1.0, 1.0, 0.0]];
    assert!(Patch::new(&nan).is_err(), "not finite");
    assert!(Patch::rectangle([0.0; 3], [0.0, 0.1], 0.0).is_err());
}
