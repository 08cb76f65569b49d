//! Courses that are not one profile along x: straight flights placed in the plane, joined
//! where the robot turns.
//!
//! Each [`Flight`] is a [`Terrain`] in its own frame (its path along local x, its levels'
//! heights above its floor) and a [`Placement`] that puts that frame in the world: an
//! origin, a heading and a lift. The gait plans in the current flight's frame, exactly as
//! on a straight course; the filter and the exact clearance checks see the world.
//! [`Route::turn_on_landing`] is the paper's kind of course with a turn: three steps, a
//! landing on which the robot turns 90° left, three more steps.

use nalgebra::{Rotation3, Vector3};

use super::{Profile, Terrain};
use crate::catalog::{EdgeCuboid, HalfPlane};
use crate::model::State;
use cbfgen::error::CbfError;
use cbfgen::geometry::OrientedBox;

/// Where a flight's frame sits in the world: local (x, y, z) maps to
/// `origin + Rz(heading) (x, y) ` and `z + lift`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The frame's origin, world xy \[m\].
    pub origin: [f64; 2],
    /// Its x axis's angle from world x, counter-clockwise \[rad\].
    pub heading: f64,
    /// How far its floor (height 0) is above the world's \[m\].
    pub lift: f64,
}

impl Placement {
    /// The world frame itself.
    pub const IDENTITY: Placement = Placement { origin: [0.0, 0.0], heading: 0.0, lift: 0.0 };

    /// `x` with the origin's position and yaw in this frame (the origin-relative body and
    /// toes, and the velocities along the heading, do not change).
    pub fn local_state(&self, x: &State) -> State {
        if *self == Self::IDENTITY {
            return *x;
        }
        let (s, c) = self.heading.sin_cos();
        let (dx, dy) = (x[0] - self.origin[0], x[1] - self.origin[1]);
        let mut local = *x;
        (local[0], local[1]) = (c * dx + s * dy, -s * dx + c * dy);
        local[3] = x[3] - self.heading;
        local
    }

    /// `local`, a state in this frame, in the world: the inverse of
    /// [`Placement::local_state`].
    pub fn world_state(&self, local: &State) -> State {
        if *self == Self::IDENTITY {
            return *local;
        }
        let (s, c) = self.heading.sin_cos();
        let mut x = *local;
        (x[0], x[1]) = (self.origin[0] + c * local[0] - s * local[1], self.origin[1] + s * local[0] + c * local[1]);
        x[3] = local[3] + self.heading;
        x
    }

    /// A world point in this frame (z less the lift).
    pub fn local_point(&self, p: &[f64; 3]) -> [f64; 3] {
        let (s, c) = self.heading.sin_cos();
        let (dx, dy) = (p[0] - self.origin[0], p[1] - self.origin[1]);
        [c * dx + s * dy, -s * dx + c * dy, p[2] - self.lift]
    }

    /// A box of this frame in the world.
    ///
    /// # Errors
    /// As [`OrientedBox::new`] (none for a valid box and a finite placement).
    pub fn world_box(&self, b: &OrientedBox) -> Result<OrientedBox, CbfError> {
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), self.heading);
        let center = turn * b.center() + Vector3::new(self.origin[0], self.origin[1], self.lift);
        OrientedBox::new(center, turn * b.rotation(), *b.half_extents())
    }

    /// A half-plane of this frame's xy in the world: `n · p_local + b ≥ 0` is
    /// `(R n) · (p − origin) + b ≥ 0` (the same half-plane, bit for bit, in the world
    /// frame itself).
    ///
    /// # Errors
    /// None for a valid half-plane (a rotation keeps its normal a unit vector).
    pub fn world_half_plane(&self, h: &HalfPlane) -> Result<HalfPlane, CbfError> {
        if *self == Self::IDENTITY {
            return Ok(*h);
        }
        let (s, c) = self.heading.sin_cos();
        let n = [c * h.normal[0] - s * h.normal[1], s * h.normal[0] + c * h.normal[1]];
        HalfPlane::new(n, h.offset - n[0] * self.origin[0] - n[1] * self.origin[1])
    }
}

/// One straight flight of a route.
#[derive(Debug, Clone, PartialEq)]
pub struct Flight {
    /// The terrain in the flight's own frame.
    pub terrain: Terrain,
    /// Where that frame is in the world.
    pub placement: Placement,
    /// Where (local x of the robot's origin) the robot turns to face the next flight;
    /// `None` for the last flight.
    pub turn_at: Option<f64>,
}

impl Flight {
    /// The ground along the flight as the gait reads it, heights in the world.
    ///
    /// # Errors
    /// A lift that takes a height beyond ±100 m.
    pub fn profile(&self) -> Result<Profile, CbfError> {
        self.terrain.profile().lifted(self.placement.lift)
    }
}

/// Flights the robot climbs one after the other, turning between them.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    flights: Vec<Flight>,
}

impl Route {
    /// A route of one flight: a straight course in the world frame.
    pub fn straight(terrain: Terrain) -> Self {
        Self { flights: vec![Flight { terrain, placement: Placement::IDENTITY, turn_at: None }] }
    }

    /// Flights in order.
    ///
    /// # Errors
    /// No flights, a flight but the last without a turn point or the last with one, or a
    /// non-finite placement or turn point.
    pub fn new(flights: Vec<Flight>) -> Result<Self, CbfError> {
        let n = flights.len();
        if n == 0 {
            return Err(CbfError::NotPositive { what: "route flights", value: 0.0 });
        }
        for (k, f) in flights.iter().enumerate() {
            let p = f.placement;
            for v in [p.origin[0], p.origin[1], p.heading, p.lift] {
                cbfgen::error::within("flight placement", v, -1e3, 1e3, "[-1e3, 1e3]")?;
            }
            if f.turn_at.is_some() == (k + 1 == n) {
                return Err(CbfError::OutOfRange {
                    what: "flight turn points (every flight but the last turns)",
                    value: k as f64,
                    range: "a turn point on all but the last",
                });
            }
            if let Some(s) = f.turn_at {
                cbfgen::error::within("flight turn point [m]", s, -1e3, 1e3, "[-1e3, 1e3]")?;
            }
        }
        Ok(Self { flights })
    }

    /// Three 16.5 × 35 cm steps (the hardware stairs', 2.4 m wide) up to a 2.4 m square
    /// landing, a 90° turn to the left on it, and three more steps up from its left side.
    pub fn turn_on_landing() -> Self {
        const RISE: f64 = 0.165;
        const RUN: f64 = 0.35;
        const HALF_WIDTH: f64 = 1.2;
        const SECTION: f64 = 0.025;
        let landing_begin = 1.0 + 2.0 * RUN;
        let top = 3.0 * RISE;
        let centre = landing_begin + HALF_WIDTH;
        let named = |changes: &[[f64; 2]]| {
            Terrain::new(changes, HALF_WIDTH, SECTION)
                .unwrap_or_else(|e| unreachable!("the named route's constants are valid: {e}"))
        };
        // Flight 1 along +x; the landing's far side drops back to the floor.
        let first = named(&[
            [1.0, RISE],
            [1.0 + RUN, 2.0 * RISE],
            [landing_begin, top],
            [landing_begin + 2.0 * HALF_WIDTH, 0.0],
        ]);
        // Flight 2 along +y from the landing's centre, its floor the landing.
        let second = named(&[[HALF_WIDTH, RISE], [HALF_WIDTH + RUN, 2.0 * RISE], [HALF_WIDTH + 2.0 * RUN, 3.0 * RISE]]);
        let turned = Placement { origin: [centre, 0.0], heading: std::f64::consts::FRAC_PI_2, lift: top };
        Self::new(vec![
            Flight { terrain: first, placement: Placement::IDENTITY, turn_at: Some(centre) },
            Flight { terrain: second, placement: turned, turn_at: None },
        ])
        .unwrap_or_else(|e| unreachable!("the named route is valid: {e}"))
    }

    /// The flights, in order.
    pub fn flights(&self) -> &[Flight] {
        &self.flights
    }

    /// Every change of height of every flight.
    pub fn changes(&self) -> usize {
        self.flights.iter().map(|f| f.terrain.changes().len()).sum()
    }

    /// The riser boxes ([`Terrain::riser_boxes`]) of every flight, in the world.
    ///
    /// # Errors
    /// As [`Terrain::riser_boxes`].
    pub fn riser_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        self.world_boxes(Terrain::riser_boxes)
    }

    /// The riser cuboids of every flight in the world, as the filter takes them.
    ///
    /// # Errors
    /// As [`Terrain::riser_boxes`].
    pub fn riser_cuboids(&self) -> Result<Vec<EdgeCuboid>, CbfError> {
        Ok(self.riser_boxes()?.iter().map(EdgeCuboid::from_box).collect())
    }

    /// The edge (nosing) boxes of every flight, in the world.
    ///
    /// # Errors
    /// As [`Terrain::edge_boxes`].
    pub fn edge_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        self.world_boxes(Terrain::edge_boxes)
    }

    /// The route as solid boxes in the world: the first flight's
    /// ([`Terrain::solid_boxes`]), and each later flight's raised levels reaching down to
    /// the world's floor (a later flight's own floor is the level it starts from, which
    /// the flights before it built).
    ///
    /// # Errors
    /// As [`Terrain::solid_boxes`].
    pub fn solid_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        let mut out = self.flights[0].terrain.solid_boxes()?;
        for f in &self.flights[1..] {
            for b in f.terrain.level_boxes(f.placement.lift)? {
                out.push(f.placement.world_box(&b)?);
            }
        }
        Ok(out)
    }

    fn world_boxes(
        &self,
        boxes: fn(&Terrain) -> Result<Vec<OrientedBox>, CbfError>,
    ) -> Result<Vec<OrientedBox>, CbfError> {
        let mut out = Vec::new();
        for f in &self.flights {
            for b in boxes(&f.terrain)? {
                out.push(f.placement.world_box(&b)?);
            }
        }
        Ok(out)
    }
}
