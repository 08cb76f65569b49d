//! Terrain the examples, benches and simulations run on, turned into the filter's
//! runtime obstacles (one edge cuboid along each change of height, as the paper extracts
//! them from its map) and floor heights.
//!
//! * [`Stairs`] — a straight flight of equal steps (the hardware experiment's, and the
//!   Monte Carlo campaign's courses);
//! * [`Terrain`] — any profile of flat levels, and the shapes a flight does not make;
//! * [`Profile`] — the ground along the path as the gait reads it, true or perceived;
//! * [`route`] — straight flights placed in the plane, joined where the robot turns;
//! * [`SolidTerrain`] — the floor and every step as solid blocks, which the robot's
//!   wheels and body are measured against by exact geometry;
//! * [`edge_match`] — perceived edge cuboids matched to the true nosings.

pub mod edge_match;
pub mod profile;
pub mod route;
pub mod shapes;
pub mod solid;

pub use profile::{Level, Profile};
pub use shapes::Terrain;
pub use solid::SolidTerrain;

use nalgebra::Vector3;

use crate::catalog::{Capacity, EdgeCuboid, Environment, HalfPlane, StabilityBound};
use cbfgen::error::CbfError;
use cbfgen::geometry::OrientedBox;

/// Steps of equal `rise` × `run` going up in +x, spanning y ∈ [−half_width, half_width].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stairs {
    /// x of the first riser \[m\].
    pub start_x: f64,
    /// Height of each step \[m\].
    pub rise: f64,
    /// Depth of each tread, riser to riser \[m\].
    pub run: f64,
    /// Number of steps; the top landing is at `count · rise`.
    pub count: usize,
    /// Half the stairs' width, centred on y = 0 \[m\].
    pub half_width: f64,
    /// Half side of the square section of each nosing's edge cuboid \[m\].
    pub edge_half_section: f64,
}

impl Stairs {
    /// The hardware experiment's flight: 5 steps, 16.5 cm high, 35 cm deep.
    pub const HARDWARE: Stairs =
        Stairs { start_x: 1.0, rise: 0.165, run: 0.35, count: 5, half_width: 1.0, edge_half_section: 0.025 };

    /// Check the dimensions: every length finite and positive, at least one step, and an
    /// edge cuboid that fits inside one step (`2 · edge_half_section` below both rise and
    /// run). Every other method assumes stairs that pass.
    ///
    /// # Errors
    /// The first dimension that fails, named.
    pub fn validate(&self) -> Result<(), CbfError> {
        cbfgen::error::finite("stairs start x [m]", self.start_x)?;
        for (what, v) in [
            ("stair rise [m]", self.rise),
            ("stair run [m]", self.run),
            ("stairs half width [m]", self.half_width),
            ("edge cuboid half section [m]", self.edge_half_section),
        ] {
            cbfgen::error::within(what, v, 0.0, Self::MAX_DIMENSION, "(0, 100]")?;
            cbfgen::error::positive(what, v)?;
        }
        if self.count == 0 {
            return Err(CbfError::NotPositive { what: "stair count", value: 0.0 });
        }
        let section = 2.0 * self.edge_half_section;
        if !(section < self.rise && section < self.run) {
            return Err(CbfError::OutOfRange {
                what: "edge cuboid section [m]",
                value: section,
                range: "below the stair rise and run",
            });
        }
        Ok(())
    }

    /// Longest stair dimension accepted by [`Stairs::validate`] \[m\].
    pub const MAX_DIMENSION: f64 = 100.0;

    /// One step of the same dimensions: the `step` scenario's obstacle.
    pub const SINGLE_STEP: Stairs = Stairs { count: 1, ..Stairs::HARDWARE };

    /// The staircase as a [`Terrain`]: a rise at every riser, the top landing running on.
    ///
    /// # Errors
    /// Stairs that fail [`Stairs::validate`].
    pub fn terrain(&self) -> Result<Terrain, CbfError> {
        self.validate()?;
        let changes: Vec<[f64; 2]> =
            (0..self.count).map(|k| [self.start_x + k as f64 * self.run, (k + 1) as f64 * self.rise]).collect();
        Terrain::new(&changes, self.half_width, self.edge_half_section)
    }

    /// The cuboid along step `k`'s nosing: tucked into the corner of the tread and riser.
    ///
    /// # Errors
    /// Non-positive dimensions.
    pub fn edge(&self, k: usize) -> Result<EdgeCuboid, CbfError> {
        let s = self.edge_half_section;
        let center = Vector3::new(self.start_x + k as f64 * self.run + s, 0.0, (k + 1) as f64 * self.rise - s);
        Ok(EdgeCuboid::from_box(&OrientedBox::axis_aligned(center, Vector3::new(s, self.half_width, s))?))
    }
}

/// A convex foothold for a toe of radius `r`: world x in `[x_begin + r, x_end − r]` and
/// |y| within `half_width` less `r` (infinite ends are capped at ±100 m).
///
/// # Errors
/// An empty interval.
pub fn foothold_strip(half_width: f64, x_begin: f64, x_end: f64, r: f64) -> Result<[HalfPlane; 4], CbfError> {
    let (lo, hi) = ((x_begin + r).max(-100.0), (x_end - r).min(100.0));
    let w = half_width - r;
    if !(hi > lo && w > 0.0) {
        return Err(CbfError::OutOfRange { what: "foothold strip length", value: hi - lo, range: "(0, inf)" });
    }
    Ok([
        HalfPlane::new([1.0, 0.0], -lo)?,
        HalfPlane::new([-1.0, 0.0], hi)?,
        HalfPlane::new([0.0, 1.0], w)?,
        HalfPlane::new([0.0, -1.0], w)?,
    ])
}

/// An environment that fills every row of `capacity`: the staircase's nosings first,
/// then further edges up the same slope (a longer flight beyond the first `count`), a
/// regular foothold polygon of inradius `foothold_radius` around the world point
/// `foothold_center` for every leg, all legs swinging, and both stability bounds set
/// (each toe within ±0.25 m of its hip's x relative to the body).
/// The heaviest evaluation the catalog can be asked for.
///
/// # Errors
/// Invalid stair dimensions or a non-positive radius.
pub fn worst_case_environment(
    capacity: Capacity,
    stairs: &Stairs,
    foothold_center: [f64; 2],
    foothold_radius: f64,
) -> Result<Environment, CbfError> {
    cbfgen::error::positive("foothold radius", foothold_radius)?;
    let mut env = Environment::new(capacity)?;
    for k in 0..capacity.body_edge.min(capacity.toe_edge) {
        env.push_edge(stairs.edge(k)?)?;
    }
    for leg in 0..6 {
        let n = capacity.foothold[leg];
        let planes = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                // Inward normal −(cos a, sin a): n · (p − c) + r ≥ 0.
                let normal = [-a.cos(), -a.sin()];
                HalfPlane::new(
                    normal,
                    foothold_radius - normal[0] * foothold_center[0] - normal[1] * foothold_center[1],
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        env.set_foothold(leg, &planes)?;
        let hip_x = crate::model::HIP_POSITIONS[leg][0];
        env.stability[leg] =
            [Some(StabilityBound { a: 1.0, b: 0.25 - hip_x }), Some(StabilityBound { a: -1.0, b: 0.25 + hip_x })];
    }
    env.set_swing([true; 6]);
    Ok(env)
}
