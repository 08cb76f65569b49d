//! Tachyon 3's barrier set, in the model's terms: the generated [`Catalog`] (its rows)
//! and [`Environment`] (its runtime parameters), with typed helpers for what a
//! scenario hands the filter: edge cuboids, floors, foothold half-planes, swing legs and
//! stability bounds.
//!
//! Everything structural is generated from `systems/tachyon3/spec/tachyon3.py`: the row
//! layout (joint limits 4 per leg, foot height 1 per leg, stability lower and upper per
//! leg, body–edge SSAT 1 per edge slot, toe–edge certified clearance 6 per edge slot, foothold
//! half-planes per leg up to its capacity, then the foothold pull, one control-Lyapunov row
//! per leg), the kernels and [`FAMILIES`]. This module
//! only names rows ([`RowSlot`]) and fills parameters.
//!
//! ```
//! use cbfgen_tachyon3::catalog::{Capacity, Catalog, EdgeCuboid, Environment, Family};
//! use cbfgen_tachyon3::model::standard_posture;
//! use nalgebra::Vector3;
//!
//! let mut catalog = Catalog::new(Capacity::PAPER_WORST_CASE)?;
//! assert_eq!(catalog.len(), 269 + 6); // the paper's 269 barrier rows, and a pull per leg
//! let mut env = Environment::new(Capacity::PAPER_WORST_CASE)?;
//! let step = cbfgen::OrientedBox::axis_aligned(Vector3::new(0.8, 0.0, 0.06), Vector3::new(0.02, 1.0, 0.02))?;
//! env.push_edge(EdgeCuboid::from_box(&step))?;
//! catalog.evaluate(&standard_posture(), &env)?;
//! let (body_edge, _) = catalog.rows().iter().zip(catalog.slots())
//!     .find(|(_, s)| s.family == Family::BodyEdge && s.instance == 0).unwrap();
//! assert!(body_edge.active && body_edge.h() > 0.0);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use crate::generated as gen;
use crate::model::{State, NU};
use cbfgen::error::{finite, CbfError};
use cbfgen::geometry::OrientedBox;
use cbfgen::nalgebra::{Matrix3, Vector3};
use cbfgen::system::{self, BarrierSet, RowLayout};

pub use gen::{default_settings, Capacity, FAMILIES};

/// Every ECBF row of the model for one [`Capacity`], and the storage they are evaluated
/// into (the generated barrier set).
pub type Catalog = gen::Barriers;
/// What the robot perceives and plans this cycle (the generated parameters): obstacles,
/// floors, footholds, swing legs, stability bounds. Sized once by its [`Capacity`];
/// updating it never allocates.
pub type Environment = gen::Params;
/// The ECBF filter on the Tachyon 3 catalog.
pub type Tachyon3Filter = gen::Filter;
/// One evaluated ECBF row: `lie = [h, L_f h, L_f² h, 0, 0]`, `lg = L_g L_f h`.
pub type Row = system::Row<NU>;
/// An edge cuboid in the kernels' parameter layout (centre, rotation, half extents).
pub type EdgeCuboid = gen::BodyEdgeParams;
/// A foothold half-plane on the world xy plane: `normal · p_xy + offset ≥ 0` inside.
pub type HalfPlane = gen::FootholdParams;
/// Eq. 13's `a (x_toe − x_body) + b ≥ 0`: `a = ±1` for a lower / upper bound on the
/// toe's x relative to the body's (origin frame), `b` \[m\].
pub type StabilityBound = gen::StabilityParams;

/// Every barrier family of this model has relative degree 2 (found by the generator; a
/// model change that alters one stops the build here).
pub const RELATIVE_DEGREE: usize = 2;
/// The foothold pull's `V` looks ahead by the toe's velocity, so its rate depends on
/// the input: relative degree 1.
pub const PULL_RELATIVE_DEGREE: usize = 1;
const _: () = {
    let mut i = 0;
    while i < FAMILIES.len() {
        let expected = match FAMILIES[i].kind {
            system::FamilyKind::Barrier => RELATIVE_DEGREE,
            system::FamilyKind::Lyapunov => PULL_RELATIVE_DEGREE,
        };
        assert!(FAMILIES[i].relative_degree == expected);
        i += 1;
    }
};

const LEGS: usize = 6;

/// The constraint families of the paper's section IV, in [`FAMILIES`] order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Family {
    /// Knee length and hip angle, min and max (eq. 4–6).
    JointLimits,
    /// Toe wheel bottom above the floor plane.
    FootHeight,
    /// Approximate static stability, eq. 13; instance 0 = lower, 1 = upper bound.
    Stability,
    /// Body vs edge cuboid by the smooth SAT minus its certified margin (eq. 10).
    BodyEdge,
    /// Toe sphere vs edge cuboid by the certified sphere–box clearance of
    /// [`sphere_box`](cbfgen::sphere_box): a smooth distance from the toe centre to the
    /// cuboid less the toe radius and a 1.2 mm margin, so `h ≥ 0` proves the toe clear
    /// (`h` in metres). It replaces the paper's superellipsoid (eq. 11), which is inscribed
    /// in the inflated cuboid and so let a toe that read safe touch it at edges and corners.
    ToeEdge,
    /// Swing toe inside a convex foothold half-space (eq. 12).
    Foothold,
    /// The control-Lyapunov pull of a swing toe outside its foothold towards it
    /// (section IV-D); see [`foothold`](crate::foothold). Its relaxation is convergence
    /// given up, never a safety verdict.
    FootholdPull,
}

/// How many families the model has: the length of per-family arrays.
pub const FAMILY_COUNT: usize = Family::ALL.len();

impl Family {
    /// Every family, in [`Family::index`] order.
    pub const ALL: [Family; 7] = [
        Family::JointLimits,
        Family::FootHeight,
        Family::Stability,
        Family::BodyEdge,
        Family::ToeEdge,
        Family::Foothold,
        Family::FootholdPull,
    ];

    /// Position in [`Family::ALL`] and in [`FAMILIES`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The spec's name, as used in the CLI and the benches.
    pub const fn name(self) -> &'static str {
        FAMILIES[self.index()].name
    }
}

// The enum follows the spec's family order; a reordered spec stops the build.
const _: () = {
    assert!(FAMILIES.len() == Family::ALL.len());
    assert!(Family::JointLimits.index() == gen::family::JOINT_LIMITS);
    assert!(Family::FootHeight.index() == gen::family::FOOT_HEIGHT);
    assert!(Family::Stability.index() == gen::family::STABILITY);
    assert!(Family::BodyEdge.index() == gen::family::BODY_EDGE);
    assert!(Family::ToeEdge.index() == gen::family::TOE_EDGE);
    assert!(Family::Foothold.index() == gen::family::FOOTHOLD);
    assert!(Family::FootholdPull.index() == gen::family::FOOTHOLD_PULL);
};

/// Where a row sits in the model's terms: family, leg, instance and input columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowSlot {
    /// The constraint family the row belongs to.
    pub family: Family,
    /// The leg, in [`LEG_NAMES`](crate::model::LEG_NAMES) order; `None`
    /// for body–edge rows.
    pub leg: Option<usize>,
    /// Index within the family and leg: joint row (knee min, knee max, hip min, hip max),
    /// stability bound (0 lower, 1 upper), edge slot or foothold edge; 0 for foot height.
    pub instance: usize,
    /// Input columns where `L_g L_f h` can be non-zero (the row's sparsity in the QP).
    pub columns: &'static [usize],
}

impl RowSlot {
    /// The slot of a row of the generated layout.
    pub fn of(layout: &RowLayout) -> Self {
        let family = Family::ALL[layout.family];
        let (leg, instance) = match family {
            Family::JointLimits => (Some(layout.member), layout.row),
            Family::BodyEdge => (None, layout.instance),
            Family::ToeEdge => (Some(layout.row), layout.instance),
            Family::FootHeight | Family::Stability | Family::Foothold | Family::FootholdPull => {
                (Some(layout.member), layout.instance)
            }
        };
        Self { family, leg, instance, columns: layout.columns }
    }
}

impl Catalog {
    /// Rows laid out, active or not (the capacity's `rows()`).
    pub fn len(&self) -> usize {
        BarrierSet::rows(self).len()
    }

    /// Always `false`: the 42 joint-limit, foot-height and stability rows are always there.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The rows as last evaluated, in layout order (inactive rows hold stale values).
    pub fn rows(&self) -> &[Row] {
        BarrierSet::rows(self)
    }

    /// Where each row sits, in row order.
    pub fn slots(&self) -> impl ExactSizeIterator<Item = RowSlot> + '_ {
        BarrierSet::layout(self).iter().map(RowSlot::of)
    }

    /// Evaluate every applicable row at state `x` in environment `env` (no family depends
    /// on time). Does not allocate; rows that do not apply are marked inactive.
    ///
    /// # Errors
    /// A state outside [`system::validate_state`]'s domain, a parameter outside its domain
    /// ([`CbfError::ParamOutOfDomain`]: an edge cuboid's as [`OrientedBox::new`] takes
    /// them), or an environment of another capacity. Rows are left as they were.
    pub fn evaluate(&mut self, x: &State, env: &Environment) -> Result<(), CbfError> {
        BarrierSet::evaluate(self, 0.0, x, env)
    }
}

/// What the Tachyon 3 filter adds to the generic [`EcbfFilter`](cbfgen::filter::EcbfFilter)
/// (a trait because the filter type is the core's): construction from a [`Capacity`] and
/// rows named in the model's terms.
pub trait Tachyon3FilterExt: Sized {
    /// The filter on a catalog laid out for `capacity`.
    ///
    /// # Errors
    /// As [`Catalog::new`] and [`EcbfFilter::new`](cbfgen::filter::EcbfFilter::new).
    fn with_capacity(capacity: Capacity, settings: cbfgen::filter::FilterSettings<NU>) -> Result<Self, CbfError>;

    /// Where row `i` sits in the model's terms.
    ///
    /// # Panics
    /// If `i` is not a row.
    fn slot(&self, i: usize) -> RowSlot;

    /// Where each row sits, in row order.
    fn slots(&self) -> impl ExactSizeIterator<Item = RowSlot> + '_;
}

impl Tachyon3FilterExt for Tachyon3Filter {
    fn with_capacity(capacity: Capacity, settings: cbfgen::filter::FilterSettings<NU>) -> Result<Self, CbfError> {
        Self::new(Catalog::new(capacity)?, settings)
    }

    fn slot(&self, i: usize) -> RowSlot {
        RowSlot::of(&BarrierSet::layout(self.barriers())[i])
    }

    fn slots(&self) -> impl ExactSizeIterator<Item = RowSlot> + '_ {
        self.barriers().slots()
    }
}

impl Capacity {
    /// The paper's worst case: 20 edge cuboids × (6 toes + body) = 140 collision rows, plus
    /// 24 joint-limit, 6 foot-height, 12 stability and 87 foothold rows: 269 barrier rows.
    /// The catalog lays out 6 more, the foothold pull's, which apply only to a swing toe
    /// outside its foothold, whose foothold rows are then off.
    pub const PAPER_WORST_CASE: Capacity = Capacity::edges(20, [15, 15, 15, 14, 14, 14]);

    /// Most edge cuboids a catalog may reserve (the spec's): 7 rows each, so 7175
    /// collision rows, far beyond what a 1 ms QP can take.
    pub const MAX_EDGES: usize = gen::BODY_EDGE_MAX_CAPACITY;

    /// Most foothold half-planes per leg (the spec's).
    pub const MAX_FOOTHOLD_EDGES: usize = gen::FOOTHOLD_MAX_CAPACITY;

    /// Room for `edges` edge cuboids (each a body row and six toe rows) and
    /// `foothold_edges[leg]` foothold half-planes per leg.
    pub const fn edges(edges: usize, foothold_edges: [usize; LEGS]) -> Self {
        Capacity { body_edge: edges, toe_edge: edges, foothold: foothold_edges }
    }
}

impl EdgeCuboid {
    /// The edge cuboid of box `b` (already validated, so this cannot fail).
    pub fn from_box(b: &OrientedBox) -> Self {
        Self { center: *b.center(), rotation: *b.rotation().matrix(), half: *b.half_extents() }
    }

    /// (centre, rotation, half extents): the kernels' arguments, in the types `Params` and
    /// every generated kernel take them.
    pub fn kernel_args(&self) -> (Vector3<f64>, Matrix3<f64>, Vector3<f64>) {
        (self.center, self.rotation, self.half)
    }
}

impl HalfPlane {
    /// The half-plane `normal · p_xy + offset ≥ 0`, stored with a unit normal (the same
    /// set, so any positive scale of `(normal, offset)` is the same half-plane and an
    /// extreme but finite scale is harmless).
    ///
    /// # Errors
    /// Non-finite values, a zero normal, or a boundary further than
    /// [`STATE_LIMIT`](cbfgen::system::STATE_LIMIT) from the origin.
    pub fn new(normal: [f64; 2], offset: f64) -> Result<Self, CbfError> {
        finite("half-plane normal", normal[0])?;
        finite("half-plane normal", normal[1])?;
        finite("half-plane offset", offset)?;
        // Divide by the larger component first: hypot of it and the scaled smaller one
        // neither overflows nor underflows.
        let big = normal[0].abs().max(normal[1].abs());
        if big == 0.0 {
            return Err(CbfError::NotPositive { what: "half-plane normal length", value: 0.0 });
        }
        let n = [normal[0] / big, normal[1] / big];
        let length = n[0].hypot(n[1]);
        let offset = offset / big / length;
        system::coordinate("half-plane distance from the origin", offset)?;
        Ok(Self { normal: [n[0] / length, n[1] / length].into(), offset })
    }
}

impl Environment {
    /// Add an edge cuboid: it fills the next body–edge and toe–edge slot.
    ///
    /// # Errors
    /// [`CbfError::CapacityExceeded`] when every edge slot is taken;
    /// [`CbfError::ParamOutOfDomain`] (naming the slot it would have filled) for a cuboid
    /// [`OrientedBox::new`] would refuse, built field by field: half extents outside
    /// [`MIN_HALF_EXTENT`](cbfgen::geometry::MIN_HALF_EXTENT)..=[`MAX_HALF_EXTENT`](cbfgen::geometry::MAX_HALF_EXTENT),
    /// a rotation that is not proper, a centre beyond ±1e6 m or not finite (the spec gives
    /// the generated parameters the same domain). Nothing changes then.
    pub fn push_edge(&mut self, edge: EdgeCuboid) -> Result<(), CbfError> {
        let capacity = self.body_edge.capacity().min(self.toe_edge.capacity());
        let filled = self.body_edge.as_slice().len().max(self.toe_edge.as_slice().len());
        if filled >= capacity {
            return Err(CbfError::CapacityExceeded { what: "edge cuboids", capacity });
        }
        edge.validate().map_err(|e| e.in_instance(filled))?;
        self.body_edge.push(edge)?;
        self.toe_edge.push(gen::ToeEdgeParams { center: edge.center, rotation: edge.rotation, half: edge.half })
    }

    /// Grow the cuboid of every body–edge row by `clearance` along each of its axes (the
    /// toe–edge rows keep the true cuboids, from which this grows): `h ≥ 0` then keeps the
    /// model's body `clearance` away from each edge, so that anything within `clearance`
    /// of it, such as the body turned by a roll the model does not hold
    /// ([`model::roll_clearance`](crate::model::roll_clearance)), is clear too. 0 restores
    /// the true cuboids. Edges pushed later are not grown: call it again.
    ///
    /// # Errors
    /// A clearance that is negative, not finite, or grows a cuboid past
    /// [`MAX_HALF_EXTENT`](cbfgen::geometry::MAX_HALF_EXTENT); nothing changes then.
    pub fn set_body_clearance(&mut self, clearance: f64) -> Result<(), CbfError> {
        finite("body clearance", clearance)?;
        if clearance < 0.0 {
            return Err(CbfError::OutOfRange { what: "body clearance [m]", value: clearance, range: "[0, inf)" });
        }
        // Every grown cuboid checked before any is written, so a refusal changes nothing.
        for (k, (body, toe)) in self.body_edge.as_slice().iter().zip(self.toe_edge.as_slice()).enumerate() {
            EdgeCuboid { half: toe.half.add_scalar(clearance), ..*body }.validate().map_err(|e| e.in_instance(k))?;
        }
        let toes = self.toe_edge.as_slice();
        for (body, toe) in self.body_edge.as_mut_slice().iter_mut().zip(toes) {
            body.half = toe.half.add_scalar(clearance);
        }
        Ok(())
    }

    /// Remove every edge cuboid, so their rows go inactive; keeps the storage.
    pub fn clear_edges(&mut self) {
        self.body_edge.clear();
        self.toe_edge.clear();
    }

    /// The edge cuboids pushed so far; edge `i` fills body–edge and toe–edge instance `i`.
    pub fn edges(&self) -> &[EdgeCuboid] {
        self.body_edge.as_slice()
    }

    /// Floor height under each toe, world frame \[m\].
    pub fn floors(&self) -> [f64; LEGS] {
        self.foot_height.map(|[p]| p.floor_z)
    }

    /// Set the floor height under each toe \[m\].
    pub fn set_floors(&mut self, floor_z: [f64; LEGS]) {
        for (p, z) in self.foot_height.iter_mut().zip(floor_z) {
            p[0].floor_z = z;
        }
    }

    /// Which legs swing: foothold rows (or, for a toe outside its foothold, the
    /// foothold pull of [`guide_toe`](Environment::guide_toe)) apply to swinging legs only.
    pub fn swing(&self) -> [bool; LEGS] {
        std::array::from_fn(|leg| self.foothold[leg].is_enabled() || self.foothold_pull[leg][0].is_some())
    }

    /// Set which legs swing; a standing leg keeps its foothold half-planes, inactive.
    /// Every foothold pull is switched off: [`guide_toe`](Environment::guide_toe), called
    /// after this, switches on those a swing toe needs.
    pub fn set_swing(&mut self, swing: [bool; LEGS]) {
        for ((set, pull), on) in self.foothold.iter_mut().zip(&mut self.foothold_pull).zip(swing) {
            set.set_enabled(on);
            *pull = [None];
        }
    }

    /// Replace leg `leg`'s foothold polygon with `edges` half-planes.
    ///
    /// # Errors
    /// More edges than the leg's capacity, or `leg >= 6`.
    pub fn set_foothold(&mut self, leg: usize, edges: &[HalfPlane]) -> Result<(), CbfError> {
        let len = self.foothold.len();
        let set = self.foothold.get_mut(leg).ok_or(CbfError::NoSuchIndex { what: "leg", index: leg, len })?;
        if edges.len() > set.capacity() {
            return Err(CbfError::CapacityExceeded { what: "foothold edges", capacity: set.capacity() });
        }
        set.clear();
        for &edge in edges {
            set.push(edge)?;
        }
        Ok(())
    }

    /// Leg `leg`'s foothold half-planes.
    ///
    /// # Panics
    /// If `leg >= 6`.
    pub fn foothold(&self, leg: usize) -> &[HalfPlane] {
        self.foothold[leg].as_slice()
    }
}
