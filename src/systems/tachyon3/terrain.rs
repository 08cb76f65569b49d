//! Terrain the examples, benches and simulations run on: a straight staircase, turned
//! into the filter's runtime obstacles (one edge cuboid along each step nosing, as the
//! paper extracts them from its map) and floor heights.

use nalgebra::Vector3;

use crate::error::CbfError;
use crate::geometry::OrientedBox;
use crate::systems::tachyon3::catalog::{Capacity, EdgeCuboid, Environment, HalfPlane, StabilityBound};

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
        crate::error::finite("stairs start x [m]", self.start_x)?;
        for (what, v) in [
            ("stair rise [m]", self.rise),
            ("stair run [m]", self.run),
            ("stairs half width [m]", self.half_width),
            ("edge cuboid half section [m]", self.edge_half_section),
        ] {
            crate::error::within(what, v, 0.0, Self::MAX_DIMENSION, "(0, 100]")?;
            crate::error::positive(what, v)?;
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

    /// Ground height at world `x` \[m\].
    pub fn height_at(&self, x: f64) -> f64 {
        if x < self.start_x {
            return 0.0;
        }
        let steps = ((x - self.start_x) / self.run).floor() as usize + 1;
        steps.min(self.count) as f64 * self.rise
    }

    /// Ground height under each toe (world sphere centres, `LEG_NAMES` order) \[m\]: the
    /// level each toe stands on, by [`Stairs::standing_x`].
    pub fn floors_under(&self, toes: &[[f64; 3]; 6]) -> [f64; 6] {
        toes.map(|toe| self.height_at(self.standing_x(&toe)))
    }

    /// The x at which to read the level a toe sphere of radius
    /// [`TOE_RADIUS`](crate::systems::tachyon3::model::TOE_RADIUS) centred at `toe` stands
    /// on. That is its centre's x, except for a wheel resting on a nosing: centre still
    /// before the riser, but bottom within a millimetre of the step's top, or higher. It
    /// stands on the step above, so this returns the riser's x (a nanometre past it, so
    /// that rounding cannot put it back before the riser). Reading the level under
    /// the centre instead would send such a toe down to the floor it has left.
    pub fn standing_x(&self, toe: &[f64; 3]) -> f64 {
        let r = crate::systems::tachyon3::model::TOE_RADIUS;
        let (_, end) = self.flat_region(toe[0]);
        let above = self.height_at(end);
        if end - toe[0] < r && above > self.height_at(toe[0]) && toe[2] - r >= above - 1e-3 {
            end + 1e-9
        } else {
            toe[0]
        }
    }

    /// One step of the same dimensions: the `step` scenario's obstacle.
    pub const SINGLE_STEP: Stairs = Stairs { count: 1, ..Stairs::HARDWARE };

    /// x where the flat region holding world `x` begins and ends (the ground before the
    /// stairs, a tread, or the top landing, which runs on).
    pub fn flat_region(&self, x: f64) -> (f64, f64) {
        if x < self.start_x {
            return (f64::NEG_INFINITY, self.start_x);
        }
        let k = (((x - self.start_x) / self.run).floor() as usize).min(self.count - 1);
        let begin = self.start_x + k as f64 * self.run;
        let end = if k + 1 == self.count { f64::INFINITY } else { begin + self.run };
        (begin, end)
    }

    /// Height of the top landing \[m\].
    pub fn top(&self) -> f64 {
        self.count as f64 * self.rise
    }

    /// The staircase as solid boxes, for a scanner to see: a floor (top at z = 0, 4 m
    /// before the first riser and 2 m past the top one, 3 m either side) and one box per
    /// step, from its riser to 1 m past the top riser.
    ///
    /// # Errors
    /// Stairs that fail [`Stairs::validate`].
    pub fn solid_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        self.validate()?;
        let end = self.start_x + (self.count - 1) as f64 * self.run + 1.0;
        let (floor_lo, floor_hi) = (self.start_x - 4.0, end + 2.0);
        let mut boxes = vec![OrientedBox::axis_aligned(
            Vector3::new((floor_lo + floor_hi) / 2.0, 0.0, -0.5),
            Vector3::new((floor_hi - floor_lo) / 2.0, self.half_width + 3.0, 0.5),
        )?];
        for k in 0..self.count {
            let (x0, top) = (self.start_x + k as f64 * self.run, (k + 1) as f64 * self.rise);
            boxes.push(OrientedBox::axis_aligned(
                Vector3::new((x0 + end) / 2.0, 0.0, top / 2.0),
                Vector3::new((end - x0) / 2.0, self.half_width, top / 2.0),
            )?);
        }
        Ok(boxes)
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
/// |y| within the stairs' half width less `r` (infinite ends are capped at ±100 m).
///
/// # Errors
/// An empty interval.
pub fn foothold_strip(stairs: &Stairs, x_begin: f64, x_end: f64, r: f64) -> Result<[HalfPlane; 4], CbfError> {
    let (lo, hi) = ((x_begin + r).max(-100.0), (x_end - r).min(100.0));
    let w = stairs.half_width - r;
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
    crate::error::positive("foothold radius", foothold_radius)?;
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
        let hip_x = crate::systems::tachyon3::model::HIP_POSITIONS[leg][0];
        env.stability[leg] =
            [Some(StabilityBound { a: 1.0, b: 0.25 - hip_x }), Some(StabilityBound { a: -1.0, b: 0.25 + hip_x })];
    }
    env.set_swing([true; 6]);
    Ok(env)
}
