//! Random and hand-built box pairs shared by the integration tests and the benches.

use cbfgen::OrientedBox;
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// A rotation drawn uniformly from SO(3) (Shoemake's subgroup algorithm).
pub fn random_rotation(rng: &mut impl Rng) -> Rotation3<f64> {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = nalgebra::Quaternion::new(
        b * (2.0 * PI * u3).cos(),
        a * (2.0 * PI * u2).sin(),
        a * (2.0 * PI * u2).cos(),
        b * (2.0 * PI * u3).sin(),
    );
    UnitQuaternion::from_quaternion(q).to_rotation_matrix()
}

pub fn random_vector(rng: &mut impl Rng, lo: f64, hi: f64) -> Vector3<f64> {
    Vector3::new(rng.random_range(lo..hi), rng.random_range(lo..hi), rng.random_range(lo..hi))
}

/// Boxes of 0.05–0.6 m half extent with centres within ±`spread` m: about 20% of pairs
/// overlap at spread 1, about 40% at spread 0.6.
pub fn random_box(rng: &mut impl Rng, spread: f64) -> OrientedBox {
    OrientedBox::new(random_vector(rng, -spread, spread), random_rotation(rng), random_vector(rng, 0.05, 0.6))
        .expect("random boxes are valid")
}

pub fn random_pairs(seed: u64, n: usize, spread: f64) -> Vec<(OrientedBox, OrientedBox)> {
    let mut r = rng(seed);
    (0..n).map(|_| (random_box(&mut r, spread), random_box(&mut r, spread))).collect()
}
