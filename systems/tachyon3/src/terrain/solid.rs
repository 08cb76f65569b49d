//! The robot against the solid terrain, by exact geometry: how far each wheel and the
//! body are from the floor and every step as a solid block ([`Terrain::solid_boxes`]),
//! independent of the filter's smooth model and of the edge cuboids it avoids.
//!
//! * A **wheel** (toe sphere) against a solid: the exact sphere–box signed distance
//!   ([`sphere_box::exact_distance`]): the gap between the surfaces, negative inside.
//! * The **body** against a solid: the exact SAT's signed separation
//!   ([`sat::separation`]): the gap along the best separating axis when apart (the
//!   distance itself when a face is nearest, a lower bound otherwise), minus the least
//!   translation that parts them when they overlap (the penetration depth).
//!
//! Each distance is to one solid; the terrain's is the smallest over its solids, and the
//! deepest overlap with any one solid is what "into the terrain" means. A wheel standing
//! on a tread touches it (distance ≈ 0, a hair below in a model that lets the wheel
//! press into the floor), so **penetration** is depth beyond
//! [`PENETRATION_TOLERANCE`] (1 mm) into a solid, for wheels and body alike.
//!
//! Where a part meets a solid is told by the contact normal, as MuJoCo's contacts are
//! read in `cbfgen.physics`: within 30° of vertical it is a [`Face::Tread`]
//! (a wheel rolling over a nosing's rounded-off corner included); steeper, a
//! [`Face::Riser`] (a riser, a nosing met from the front, a side). A wheel's **riser
//! clearance** is its distance to the solids where the normal is a riser's, and a
//! **riser contact** is a wheel at riser clearance ≤ 0: touching a riser, which a wheel
//! on its tread never needs to.

use nalgebra::Vector3;

use super::Terrain;
use crate::generated as gen;
use crate::model::{self, State, TOE_RADIUS};
use cbfgen::error::CbfError;
use cbfgen::geometry::OrientedBox;
use cbfgen::sat;
use cbfgen::sphere_box;

/// Depth into a solid that counts as penetration \[m\].
pub const PENETRATION_TOLERANCE: f64 = 1e-3;

/// A contact normal within this angle of vertical meets a tread \[rad\] (30°).
pub const TREAD_NORMAL_ANGLE: f64 = std::f64::consts::FRAC_PI_6;

/// What part of a solid a robot part is nearest to (or deepest in), by the contact
/// normal: within [`TREAD_NORMAL_ANGLE`] of vertical, a tread; steeper, a riser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Face {
    /// A level face met from above (or below).
    Tread,
    /// A face met from the side: a riser, a nosing from the front, the terrain's sides.
    Riser,
}

impl Face {
    /// `tread` or `riser`, as in the CSVs.
    pub fn name(self) -> &'static str {
        match self {
            Face::Tread => "tread",
            Face::Riser => "riser",
        }
    }

    fn of_normal(normal: &Vector3<f64>) -> Self {
        if normal.z.abs() >= TREAD_NORMAL_ANGLE.cos() * normal.norm() {
            Face::Tread
        } else {
            Face::Riser
        }
    }
}

/// Which part of the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// The body box.
    Body,
    /// The wheel (toe sphere) of a leg, in [`LEG_NAMES`](model::LEG_NAMES) order.
    Wheel(usize),
}

impl Part {
    /// `body`, or the leg's name (`LF`, …, `RR`).
    pub fn name(self) -> &'static str {
        match self {
            Part::Body => "body",
            Part::Wheel(leg) => model::LEG_NAMES[leg],
        }
    }
}

/// One robot part's exact signed distance to one solid of the terrain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Signed distance \[m\]: the gap when apart, minus the depth when inside.
    pub distance: f64,
    /// The robot's part.
    pub part: Part,
    /// The solid, as [`Terrain::solid_boxes`] orders them: 0 is the floor, `k` the
    /// `k`-th raised level (step `k` of a staircase).
    pub solid: usize,
    /// Tread or riser, by the contact normal.
    pub face: Face,
}

impl Contact {
    /// `floor` or `step k`: the solid, named.
    pub fn solid_name(&self) -> String {
        if self.solid == 0 {
            "floor".into()
        } else {
            format!("step {}", self.solid)
        }
    }

    /// Where, in a few words without commas (for CSVs): `RR step 2 riser`, `body floor tread`.
    pub fn place(&self) -> String {
        format!("{} {} {}", self.part.name(), self.solid_name(), self.face.name())
    }

    /// The nearer of two contacts (the first when equal; NaN distances never win).
    pub fn nearer(self, other: Self) -> Self {
        if other.distance < self.distance {
            other
        } else {
            self
        }
    }
}

impl std::fmt::Display for Contact {
    /// `+1.234 mm, RR wheel to the riser of step 2` (or `of the floor`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let part = match self.part {
            Part::Body => "body".to_string(),
            Part::Wheel(_) => format!("{} wheel", self.part.name()),
        };
        let solid = if self.solid == 0 { "the floor".to_string() } else { self.solid_name() };
        write!(f, "{:+.3} mm, {part} to the {} of {solid}", self.distance * 1e3, self.face.name())
    }
}

/// The robot's exact clearances to the solid terrain at one state (or the least of
/// several: [`TerrainClearance::nearer`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TerrainClearance {
    /// The body's nearest (or deepest) solid.
    pub body: Contact,
    /// The nearest (or deepest) wheel–solid pair: about 0 for a wheel on a tread.
    pub wheel: Contact,
    /// The nearest wheel–solid pair whose normal is a riser's (`None`: no wheel has one,
    /// which cannot happen on a terrain with a change of height).
    pub wheel_riser: Option<Contact>,
}

impl TerrainClearance {
    /// Part by part, the nearer of two clearances (the least over the states they were
    /// measured at).
    pub fn nearer(self, other: Self) -> Self {
        Self {
            body: self.body.nearer(other.body),
            wheel: self.wheel.nearer(other.wheel),
            wheel_riser: match (self.wheel_riser, other.wheel_riser) {
                (Some(a), Some(b)) => Some(a.nearer(b)),
                (a, b) => a.or(b),
            },
        }
    }
}

/// A terrain's solids, ready to measure the robot against.
#[derive(Debug, Clone, PartialEq)]
pub struct SolidTerrain {
    solids: Vec<OrientedBox>,
}

impl SolidTerrain {
    /// The solids of `terrain`: its floor and one block per raised level.
    ///
    /// # Errors
    /// As [`Terrain::solid_boxes`].
    pub fn new(terrain: &Terrain) -> Result<Self, CbfError> {
        Ok(Self { solids: terrain.solid_boxes()? })
    }

    /// Solids given as boxes (a course with turns: [`Route::solid_boxes`](super::route::Route::solid_boxes)).
    pub fn from_boxes(solids: Vec<OrientedBox>) -> Self {
        Self { solids }
    }

    /// The solids, floor first.
    pub fn solids(&self) -> &[OrientedBox] {
        &self.solids
    }

    /// A sphere's (centre, radius) exact signed distance to solid `k`, and the face by
    /// the normal from the solid's nearest point to the centre (for a centre inside, the
    /// normal of the face it is least deep under).
    pub fn sphere_to(&self, k: usize, center: &Vector3<f64>, radius: f64) -> (f64, Face) {
        let b = &self.solids[k];
        let distance = sphere_box::exact_distance(center, radius, b);
        let local = b.rotation().inverse() * (center - b.center());
        let half = b.half_extents();
        let nearest = Vector3::from_fn(|i, _| local[i].clamp(-half[i], half[i]));
        let outward = local - nearest;
        let local_normal = if outward.iter().any(|&v| v != 0.0) {
            outward
        } else {
            // Inside: the face it is least deep under.
            let depth = Vector3::from_fn(|i, _| half[i] - local[i].abs());
            let axis = depth.imin();
            Vector3::from_fn(|i, _| if i == axis { local[i].signum() } else { 0.0 })
        };
        (distance, Face::of_normal(&(b.rotation() * local_normal)))
    }

    /// A box's exact SAT separation from solid `k`, and the face by the SAT's axis.
    pub fn box_to(&self, k: usize, b: &OrientedBox) -> (f64, Face) {
        let (gap, axis) = sat::separation_with_axis(&self.solids[k], b);
        (gap, Face::of_normal(&axis))
    }

    /// Every wheel and the body at state `x`, against every solid.
    ///
    /// # Errors
    /// A state whose body pose is not a valid box (non-finite entries).
    pub fn clearance(&self, x: &State) -> Result<TerrainClearance, CbfError> {
        let (_, _, toes) = gen::world_kinematics(x);
        let body = model::body_box(x)?;
        let far = Contact { distance: f64::INFINITY, part: Part::Body, solid: 0, face: Face::Tread };
        let (mut body_nearest, mut wheel, mut wheel_riser) = (far, far, None::<Contact>);
        for k in 0..self.solids.len() {
            let (distance, face) = self.box_to(k, &body);
            body_nearest = body_nearest.nearer(Contact { distance, part: Part::Body, solid: k, face });
            for (leg, toe) in toes.iter().enumerate() {
                let (distance, face) = self.sphere_to(k, &Vector3::from(*toe), TOE_RADIUS);
                let contact = Contact { distance, part: Part::Wheel(leg), solid: k, face };
                wheel = wheel.nearer(contact);
                if face == Face::Riser {
                    wheel_riser = Some(wheel_riser.map_or(contact, |c| c.nearer(contact)));
                }
            }
        }
        Ok(TerrainClearance { body: body_nearest, wheel, wheel_riser })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One 20 cm step at x = 1 m: hand-placed wheels and bodies, hand-computed distances.
    #[test]
    fn hand_placed_wheels_and_bodies_on_one_step() {
        let terrain = Terrain::new(&[[1.0, 0.2]], 1.0, 0.025).expect("terrain");
        let solids = SolidTerrain::new(&terrain).expect("solids");
        let r = 0.1;
        // On the floor, 5 mm before the riser: touching the floor's tread, 5 mm from the riser.
        let (d, face) = solids.sphere_to(0, &Vector3::new(0.895, 0.0, 0.1), r);
        assert!(d.abs() < 1e-12 && face == Face::Tread, "{d} {face:?}");
        let (d, face) = solids.sphere_to(1, &Vector3::new(0.895, 0.0, 0.1), r);
        assert!((d - 0.005).abs() < 1e-12 && face == Face::Riser, "{d} {face:?}");
        // 3 mm into the riser.
        let (d, face) = solids.sphere_to(1, &Vector3::new(0.903, 0.0, 0.1), r);
        assert!((d + 0.003).abs() < 1e-12 && face == Face::Riser, "{d} {face:?}");
        // Rolling over the nosing, centre 2 cm before the riser and 0.1 m above the
        // step's top along the normal: a tread contact (11.3° from vertical).
        let c = Vector3::new(1.0, 0.0, 0.2) + Vector3::new(-0.02, 0.0, 0.098).normalize() * 0.1;
        let (d, face) = solids.sphere_to(1, &c, r);
        assert!(d.abs() < 1e-12 && face == Face::Tread, "{d} {face:?}");
        // A body pushed 4 mm into the riser from the front, level.
        let body =
            OrientedBox::axis_aligned(Vector3::new(0.504, 0.0, 0.15), Vector3::new(0.5, 0.3, 0.125)).expect("body");
        let (d, face) = solids.box_to(1, &body);
        assert!((d + 0.004).abs() < 1e-12 && face == Face::Riser, "{d} {face:?}");
        // ... and 7.5 cm above the floor: a tread gap.
        let (d, face) = solids.box_to(0, &body);
        assert!((d - 0.025).abs() < 1e-12 && face == Face::Tread, "{d} {face:?}");
    }

    #[test]
    fn the_standard_posture_rests_its_wheels_on_the_floor() {
        let terrain = Terrain::new(&[[3.0, 0.2]], 1.0, 0.025).expect("terrain");
        let c = SolidTerrain::new(&terrain).expect("solids").clearance(&model::standard_posture()).expect("state");
        assert!(c.wheel.distance.abs() < 1e-12 && c.wheel.face == Face::Tread && c.wheel.solid == 0, "{c:?}");
        assert!((c.body.distance - model::NOMINAL_CLEARANCE).abs() < 1e-12, "{c:?}");
        let riser = c.wheel_riser.expect("a riser");
        assert_eq!((riser.solid, riser.face), (1, Face::Riser));
        assert!(riser.distance > 2.0, "{riser:?}");
    }
}
