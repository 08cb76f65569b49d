//! The robot against the true terrain, computed here independently of the code under
//! test: the terrain's solids rebuilt from its changes of height alone (a floor slab, and
//! one block for each raised stretch between two changes), and the signed distances of
//! the body box and the wheel spheres to them from parry3d, a collision library (GJK and
//! its contact queries), not from `cbfgen::sat` or `cbfgen::sphere_box`.
//!
//! A contact is a riser's when its normal is more than 30° from vertical, as
//! `cbfgen_tachyon3::terrain::solid` and MuJoCo's contacts in `cbfgen.physics`
//! read it.
#![allow(dead_code)]

use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::{State, BODY_HALF_EXTENTS, TOE_RADIUS};
use cbfgen_tachyon3::sim::{Sample, SimResult};
use cbfgen_tachyon3::terrain::Terrain;
use parry3d_f64::math::{Pose, Rotation, Vector};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Cuboid};

/// Penetration the tests tolerate \[m\].
pub const PENETRATION_TOLERANCE: f64 = 1e-3;

/// Solid blocks as parry shapes.
pub struct Solids {
    blocks: Vec<(Pose, Cuboid)>,
}

/// Smallest signed distances at one state, or over a run \[m\]; negative = depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The body box to the nearest solid.
    pub body: f64,
    /// The nearest wheel to the nearest solid (about 0 on a tread).
    pub wheel: f64,
    /// The nearest wheel to a solid where the contact normal is over 30° from vertical.
    pub wheel_riser: f64,
}

impl Measured {
    const FAR: Measured = Measured { body: f64::INFINITY, wheel: f64::INFINITY, wheel_riser: f64::INFINITY };

    fn min(self, o: Measured) -> Measured {
        Measured {
            body: self.body.min(o.body),
            wheel: self.wheel.min(o.wheel),
            wheel_riser: self.wheel_riser.min(o.wheel_riser),
        }
    }
}

fn block(x: [f64; 2], y: f64, z: [f64; 2]) -> (Pose, Cuboid) {
    block_xyz(x, [-y, y], z)
}

/// The axis-aligned block spanning `x`, `y` and `z` (each `[from, to]`).
fn block_xyz(x: [f64; 2], y: [f64; 2], z: [f64; 2]) -> (Pose, Cuboid) {
    let mid = |r: [f64; 2]| 0.5 * (r[0] + r[1]);
    let half = |r: [f64; 2]| 0.5 * (r[1] - r[0]);
    (
        Pose::from_parts(Vector::new(mid(x), mid(y), mid(z)), Rotation::IDENTITY),
        Cuboid::new(Vector::new(half(x), half(y), half(z))),
    )
}

impl Solids {
    /// `terrain`'s solids from its changes of height: everything below z = 0 (a slab 20 m
    /// long and wide, 1 m deep), and for each stretch at a height above 0 a block from the
    /// floor up to it, `half_width` either side of the path (the last stretch 10 m long).
    pub fn of(terrain: &Terrain) -> Self {
        let changes = terrain.changes();
        let mut blocks = vec![block([changes[0][0] - 10.0, changes[0][0] + 10.0], 10.0, [-1.0, 0.0])];
        for (k, &[x, height]) in changes.iter().enumerate() {
            let end = changes.get(k + 1).map_or(x + 10.0, |next| next[0]);
            if height > 0.0 {
                blocks.push(block([x, end], terrain.half_width(), [0.0, height]));
            }
        }
        Self { blocks }
    }

    /// Axis-aligned blocks, each `[x, y, z]` ranges `[from, to]` \[m\]: a world written
    /// out by hand.
    pub fn blocks(blocks: &[[[f64; 2]; 3]]) -> Self {
        Self { blocks: blocks.iter().map(|&[x, y, z]| block_xyz(x, y, z)).collect() }
    }

    /// A sphere's signed distance to each solid, with its contact normal's angle from
    /// vertical \[rad\].
    fn sphere(&self, center: [f64; 3], radius: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let pose = Pose::from_parts(Vector::new(center[0], center[1], center[2]), Rotation::IDENTITY);
        let ball = Ball::new(radius);
        self.blocks.iter().map(move |(at, cuboid)| {
            let c = query::contact(at, cuboid, &pose, &ball, 100.0).expect("supported").expect("within 100 m");
            (c.dist, c.normal1.z.abs().clamp(0.0, 1.0).acos())
        })
    }

    /// The body box's signed distance to the nearest solid: the distance when apart,
    /// minus the penetration depth when in.
    fn body(&self, x: &State) -> f64 {
        let (center, rotation, _) = gen::world_kinematics(x);
        let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_fn(|i, j| rotation[i][j]));
        let q = nalgebra::UnitQuaternion::from_rotation_matrix(&r);
        let pose =
            Pose::from_parts(Vector::new(center[0], center[1], center[2]), Rotation::from_xyzw(q.i, q.j, q.k, q.w));
        let body = Cuboid::new(Vector::new(BODY_HALF_EXTENTS[0], BODY_HALF_EXTENTS[1], BODY_HALF_EXTENTS[2]));
        self.blocks
            .iter()
            .map(|(at, cuboid)| {
                let d = query::distance(at, cuboid, &pose, &body).expect("supported").distance;
                if d > 0.0 {
                    d
                } else {
                    query::contact(at, cuboid, &pose, &body, 0.0).expect("supported").map_or(0.0, |c| c.dist.min(0.0))
                }
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Body and wheels at state `x`.
    pub fn measure(&self, x: &State) -> Measured {
        let (_, _, toes) = gen::world_kinematics(x);
        let (mut wheel, mut wheel_riser) = (f64::INFINITY, f64::INFINITY);
        for toe in toes {
            for (d, angle) in self.sphere(toe, TOE_RADIUS) {
                wheel = wheel.min(d);
                if angle > std::f64::consts::FRAC_PI_6 {
                    wheel_riser = wheel_riser.min(d);
                }
            }
        }
        Measured { body: self.body(x), wheel, wheel_riser }
    }

    /// The smallest of each over the samples.
    pub fn over<'a>(&self, samples: impl IntoIterator<Item = &'a Sample>) -> Measured {
        samples.into_iter().map(|s| self.measure(&s.x)).fold(Measured::FAR, Measured::min)
    }
}

/// The run measured against its course's solids, every cycle; and checked against what
/// the run's summary reports: the wheels' and the riser clearance to 1e-9 m (the same
/// exact quantities), the body's no larger than the distance (the SAT's separation is a
/// lower bound on it) and within 1e-9 m of it when the body goes in (both the depth).
pub fn measured_run(terrain: &Terrain, result: &SimResult) -> Measured {
    measured_run_in(&Solids::of(terrain), result)
}

/// [`measured_run`] against `solids`.
pub fn measured_run_in(solids: &Solids, result: &SimResult) -> Measured {
    let m = solids.over(&result.samples);
    let s = &result.summary;
    assert!(
        (s.min_toe_clearance() - m.wheel).abs() < 1e-9,
        "wheels: reported {} measured {}",
        s.min_toe_clearance(),
        m.wheel
    );
    assert!(
        (s.min_toe_riser_clearance() - m.wheel_riser).abs() < 1e-9,
        "riser: reported {} measured {}",
        s.min_toe_riser_clearance(),
        m.wheel_riser
    );
    assert!(s.min_body_clearance() <= m.body + 1e-9, "body: reported {} measured {}", s.min_body_clearance(), m.body);
    if m.body < 0.0 {
        assert!(
            (s.min_body_clearance() - m.body).abs() < 1e-9,
            "body depth: reported {} measured {}",
            s.min_body_clearance(),
            m.body
        );
    }
    m
}

/// Neither the body nor a wheel more than [`PENETRATION_TOLERANCE`] into the solids.
pub fn assert_out_of_the_terrain(what: &str, m: Measured) {
    assert!(m.body > -PENETRATION_TOLERANCE && m.wheel > -PENETRATION_TOLERANCE, "{what}: {m:?}");
}
