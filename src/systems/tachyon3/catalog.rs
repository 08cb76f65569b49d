//! The constraint catalog: every ECBF row of the Tachyon 3 model, laid out once and
//! evaluated each control cycle into preallocated storage.
//!
//! The row layout is fixed when the catalog is built from a [`Capacity`]. The QP's
//! sparsity pattern can then be fixed too, and rows that do not apply this cycle (an
//! unused obstacle slot, a foothold edge of a foot in stance) are flagged inactive, not
//! removed. Order: joint limits (4 per leg), foot height (1 per leg), static stability
//! (lower and upper per leg), body–edge SSAT (1 per edge slot), toe–edge superellipsoid
//! (6 per edge slot), foothold half-spaces (per leg, its capacity).
//!
//! ```
//! use cbfgen::systems::tachyon3::catalog::{Capacity, Catalog, EdgeCuboid, Environment};
//! use cbfgen::systems::tachyon3::model::standard_posture;
//! use nalgebra::Vector3;
//!
//! let mut catalog = Catalog::new(Capacity::PAPER_WORST_CASE)?;
//! assert_eq!(catalog.len(), 269);
//! let mut env = Environment::new(Capacity::PAPER_WORST_CASE)?;
//! let step = cbfgen::OrientedBox::axis_aligned(Vector3::new(0.8, 0.0, 0.06), Vector3::new(0.02, 1.0, 0.02))?;
//! env.push_edge(EdgeCuboid::from_box(&step))?;
//! catalog.evaluate(&standard_posture(), &env)?;
//! let body_edge = catalog.rows().iter().zip(catalog.slots())
//!     .find(|(_, s)| s.family == cbfgen::systems::tachyon3::catalog::Family::BodyEdge && s.instance == 0).unwrap().0;
//! assert!(body_edge.active && body_edge.h() > 0.0);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use crate::error::{finite, CbfError};
use crate::filter::{EcbfFilter, FilterSettings};
use crate::generated::tachyon3 as gen;
use crate::geometry::OrientedBox;
use crate::system::{self, BarrierSet, FamilyInfo, FamilyParams, Poles, RowLayout};
use crate::systems::tachyon3::model::{self, State, ECBF_POLES, INPUT_LIMITS, LEG_NAMES, NU};

/// Every family of this model has relative degree 2, as [`FAMILIES`] declares to the
/// filter. A model change that alters a degree stops the build here instead of
/// misreading rows.
pub const RELATIVE_DEGREE: usize = 2;
const _: () = assert!(
    gen::BODY_EDGE_SSAT_RELATIVE_DEGREE == RELATIVE_DEGREE
        && gen::JOINT_LIMITS_LF_RELATIVE_DEGREE == RELATIVE_DEGREE
        && gen::TOE_EDGE_LF_RELATIVE_DEGREE == RELATIVE_DEGREE
        && gen::FOOTHOLD_LF_RELATIVE_DEGREE == RELATIVE_DEGREE
        && gen::FOOT_HEIGHT_LF_RELATIVE_DEGREE == RELATIVE_DEGREE
        && gen::STABILITY_LF_RELATIVE_DEGREE == RELATIVE_DEGREE
);

const LEGS: usize = 6;
const JOINT_ROWS_PER_LEG: usize = 4;

/// The constraint families of the paper's section IV.
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
    /// Toe sphere vs edge cuboid by superellipsoid (eq. 11).
    ToeEdge,
    /// Swing toe inside a convex foothold half-space (eq. 12).
    Foothold,
}

impl Family {
    /// Every family, in [`Family::index`] order.
    pub const ALL: [Family; 6] = [
        Family::JointLimits,
        Family::FootHeight,
        Family::Stability,
        Family::BodyEdge,
        Family::ToeEdge,
        Family::Foothold,
    ];

    /// Position in [`Family::ALL`], for per-family tables.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Lower-case name, as used in the CLI and the benches.
    pub const fn name(self) -> &'static str {
        match self {
            Family::JointLimits => "joint_limits",
            Family::FootHeight => "foot_height",
            Family::Stability => "stability",
            Family::BodyEdge => "body_edge",
            Family::ToeEdge => "toe_edge",
            Family::Foothold => "foothold",
        }
    }
}

/// Where a row sits: its family, leg (if any), instance within that leg/family (edge
/// slot, foothold edge, joint row…) and the input columns its `L_g L_f h` can touch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowSlot {
    /// The constraint family the row belongs to.
    pub family: Family,
    /// The leg, in [`LEG_NAMES`] order; `None` for body–edge rows.
    pub leg: Option<usize>,
    /// Index within the family and leg: joint row (knee min, knee max, hip min, hip max),
    /// stability bound (0 lower, 1 upper), edge slot or foothold edge; 0 for foot height.
    pub instance: usize,
    /// Input columns (indices into [`Input`](crate::systems::tachyon3::model::Input)) where `L_g L_f h` can be
    /// non-zero: the row's fixed sparsity pattern in the QP.
    pub columns: &'static [usize],
}

/// One evaluated ECBF row of the Tachyon 3 model: `lie = [h, L_f h, L_f² h, 0, 0]` and
/// `lg = L_g L_f h` (dense over the 17 inputs; zero outside the slot's columns).
/// Inactive rows keep stale values.
pub type Row = system::Row<NU>;

/// The ECBF filter on the Tachyon 3 catalog.
pub type Tachyon3Filter = EcbfFilter<Catalog, NU>;

/// Each family's fixed description, in [`Family::index`] order, with the defaults of
/// [`default_settings`].
pub const FAMILIES: [FamilyInfo; 6] = {
    const fn info(family: Family, row_names: &'static [&'static str], activation: f64) -> FamilyInfo {
        FamilyInfo {
            name: family.name(),
            relative_degree: RELATIVE_DEGREE,
            row_names,
            defaults: FamilyParams { poles: Poles::from_array(ECBF_POLES), slack_weight: 1e4, activation },
        }
    }
    [
        info(Family::JointLimits, &["knee_min", "knee_max", "hip_min", "hip_max"], f64::INFINITY),
        info(Family::FootHeight, &["foot_height"], f64::INFINITY),
        info(Family::Stability, &["lower", "upper"], f64::INFINITY),
        // h of the body–edge SSAT is a lower bound on the distance [m].
        info(Family::BodyEdge, &["body_edge"], 0.5),
        // Toe within twice the inflated edge half-extent.
        info(Family::ToeEdge, &LEG_NAMES, 15.0),
        info(Family::Foothold, &["half_space"], f64::INFINITY),
    ]
};

impl EcbfFilter<Catalog, NU> {
    /// The filter on a catalog laid out for `capacity`:
    /// `EcbfFilter::new(Catalog::new(capacity)?, settings)`.
    ///
    /// # Errors
    /// As [`Catalog::new`] and [`EcbfFilter::new`].
    pub fn with_capacity(capacity: Capacity, settings: FilterSettings<NU>) -> Result<Self, CbfError> {
        EcbfFilter::new(Catalog::new(capacity)?, settings)
    }

    /// Where each row sits in the model's terms (family, leg, instance, input columns).
    pub fn slots(&self) -> &[RowSlot] {
        self.barriers().slots()
    }
}

/// The filter settings of the model file: its poles and input limits, slack weight 10⁴,
/// activation 0.5 m for the body–edge SSAT and 15 for the toe superellipsoid (every other
/// family always applies), unit input weights and [`SolverSettings::default`](crate::filter::SolverSettings::default).
pub fn default_settings() -> FilterSettings<NU> {
    FilterSettings::defaults(&FAMILIES, INPUT_LIMITS.map(|l| -l), INPUT_LIMITS)
}

/// How many obstacle and foothold rows the catalog reserves.
///
/// The fields are public; [`Capacity::validate`] (called by [`Catalog::new`],
/// [`Environment::new`] and the filter) bounds them by [`Capacity::MAX_EDGES`] and
/// [`Capacity::MAX_FOOTHOLD_EDGES`], so a typo cannot ask for gigabytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capacity {
    /// Edge cuboids: each brings 1 body row and 6 toe rows.
    pub edges: usize,
    /// Foothold polygon edges per leg.
    pub foothold_edges: [usize; LEGS],
}

impl Capacity {
    /// The paper's worst case: 20 edge cuboids × (6 toes + body) = 140 collision rows, plus
    /// 24 joint-limit, 6 foot-height, 12 stability and 87 foothold rows: 269 rows.
    pub const PAPER_WORST_CASE: Capacity = Capacity { edges: 20, foothold_edges: [15, 15, 15, 14, 14, 14] };

    /// Most edge cuboids a catalog may reserve: 7 rows each, so 7175 collision rows,
    /// far beyond what a 1 ms QP can take (the paper's worst case has 20).
    pub const MAX_EDGES: usize = 1025;

    /// Most foothold half-planes per leg.
    pub const MAX_FOOTHOLD_EDGES: usize = 256;

    /// # Errors
    /// [`CbfError::TooLarge`] when a count is above its maximum.
    pub fn validate(&self) -> Result<(), CbfError> {
        if self.edges > Self::MAX_EDGES {
            return Err(CbfError::TooLarge { what: "edge capacity", value: self.edges, max: Self::MAX_EDGES });
        }
        for &n in &self.foothold_edges {
            if n > Self::MAX_FOOTHOLD_EDGES {
                return Err(CbfError::TooLarge {
                    what: "foothold edge capacity",
                    value: n,
                    max: Self::MAX_FOOTHOLD_EDGES,
                });
            }
        }
        Ok(())
    }

    /// Rows a catalog of this capacity holds (saturating, so an unvalidated capacity
    /// cannot wrap the count).
    pub fn rows(&self) -> usize {
        let fixed = LEGS * (JOINT_ROWS_PER_LEG + 1 + 2);
        let footholds = self.foothold_edges.iter().fold(0usize, |a, &n| a.saturating_add(n));
        fixed.saturating_add(self.edges.saturating_mul(1 + LEGS)).saturating_add(footholds)
    }
}

/// An edge cuboid in the kernels' argument layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeCuboid {
    center: [f64; 3],
    rotation: [f64; 9],
    half: [f64; 3],
}

impl EdgeCuboid {
    /// The edge cuboid of box `b` (already validated, so this cannot fail).
    pub fn from_box(b: &OrientedBox) -> Self {
        let (center, rotation, half) = b.kernel_args();
        Self { center, rotation, half }
    }

    /// Centre, world frame \[m\].
    pub fn center(&self) -> &[f64; 3] {
        &self.center
    }

    /// Rotation, row-major; its columns are the cuboid's axes.
    pub fn rotation(&self) -> &[f64; 9] {
        &self.rotation
    }

    /// Half extents \[m\].
    pub fn half_extents(&self) -> &[f64; 3] {
        &self.half
    }
}

/// A foothold half-space on the world xy plane: `normal · p_xy + offset ≥ 0` inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfPlane {
    normal: [f64; 2],
    offset: f64,
}

impl HalfPlane {
    /// The half-plane `normal · p_xy + offset ≥ 0`, stored with a unit normal (the same
    /// set, so any positive scale of `(normal, offset)` is the same half-plane and an
    /// extreme but finite scale is harmless).
    ///
    /// # Errors
    /// Non-finite values, a zero normal, or a boundary further than
    /// [`model::STATE_LIMIT`] from the origin.
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
        crate::system::coordinate("half-plane distance from the origin", offset)?;
        Ok(Self { normal: [n[0] / length, n[1] / length], offset })
    }

    /// The inward unit normal `a`.
    pub fn normal(&self) -> &[f64; 2] {
        &self.normal
    }

    /// The offset `b` \[m\]: the signed distance of the origin from the boundary.
    pub fn offset(&self) -> f64 {
        self.offset
    }
}

/// Eq. 13's `a (x_toe − x_body) + b ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StabilityBound {
    /// Slope \[–\]: +1 for a lower bound on the toe's x relative to the body's (origin
    /// frame), −1 for an upper bound.
    pub a: f64,
    /// Offset \[m\]: with `a = ±1` the row allows `x_toe − x_body ≥ −b` (lower bound) or
    /// `x_toe − x_body ≤ b` (upper).
    pub b: f64,
}

/// What the robot perceives and plans this cycle: obstacles, floors, footholds, gait.
/// Sized once by its [`Capacity`]; updating it never allocates.
#[derive(Debug, Clone)]
pub struct Environment {
    capacity: Capacity,
    edges: Vec<EdgeCuboid>,
    /// Floor height under each toe, world frame \[m\].
    pub floor_z: [f64; LEGS],
    footholds: [Vec<HalfPlane>; LEGS],
    /// Which legs swing; foothold rows apply to swinging legs only.
    pub swing: [bool; LEGS],
    /// Lower and upper stability bounds per leg; `None` leaves the rows inactive.
    pub stability: [[Option<StabilityBound>; 2]; LEGS],
}

impl Environment {
    /// An empty environment (no edges, no footholds, floors at 0, no swing legs).
    ///
    /// # Errors
    /// A capacity above its maximum ([`Capacity::validate`]).
    pub fn new(capacity: Capacity) -> Result<Self, CbfError> {
        capacity.validate()?;
        Ok(Self {
            capacity,
            edges: Vec::with_capacity(capacity.edges),
            floor_z: [0.0; LEGS],
            footholds: std::array::from_fn(|leg| Vec::with_capacity(capacity.foothold_edges[leg])),
            swing: [false; LEGS],
            stability: [[None; 2]; LEGS],
        })
    }

    /// The capacity this environment is sized for; it must be the catalog's.
    pub fn capacity(&self) -> Capacity {
        self.capacity
    }

    /// The public fields' domain, checked by [`Catalog::evaluate`] every cycle (edges and
    /// half-planes are checked when they are made): floor heights and both stability
    /// numbers finite with magnitude ≤ [`model::STATE_LIMIT`], so no row is built from
    /// a number the state itself could not hold.
    ///
    /// # Errors
    /// The first value outside that domain.
    pub fn validate(&self) -> Result<(), CbfError> {
        for &z in &self.floor_z {
            crate::system::coordinate("floor height", z)?;
        }
        for b in self.stability.iter().flatten().flatten() {
            crate::system::coordinate("stability slope", b.a)?;
            crate::system::coordinate("stability offset", b.b)?;
        }
        Ok(())
    }

    /// The edge cuboids pushed so far; edge `i` fills body–edge and toe–edge instance `i`.
    pub fn edges(&self) -> &[EdgeCuboid] {
        &self.edges
    }

    /// # Errors
    /// [`CbfError::CapacityExceeded`] when every edge slot is taken.
    pub fn push_edge(&mut self, edge: EdgeCuboid) -> Result<(), CbfError> {
        if self.edges.len() == self.capacity.edges {
            return Err(CbfError::CapacityExceeded { what: "edge cuboids", capacity: self.capacity.edges });
        }
        self.edges.push(edge);
        Ok(())
    }

    /// Remove every edge cuboid, so their rows go inactive; keeps the storage.
    pub fn clear_edges(&mut self) {
        self.edges.clear();
    }

    /// Replace leg `leg`'s foothold polygon with `edges` half-planes.
    ///
    /// # Errors
    /// More edges than the leg's capacity, or `leg >= 6`.
    pub fn set_foothold(&mut self, leg: usize, edges: &[HalfPlane]) -> Result<(), CbfError> {
        let capacity = *self.capacity.foothold_edges.get(leg).ok_or(CbfError::NoSuchLeg { leg })?;
        if edges.len() > capacity {
            return Err(CbfError::CapacityExceeded { what: "foothold edges", capacity });
        }
        self.footholds[leg].clear();
        self.footholds[leg].extend_from_slice(edges);
        Ok(())
    }

    /// Leg `leg`'s foothold half-planes.
    ///
    /// # Panics
    /// If `leg >= 6`.
    pub fn foothold(&self, leg: usize) -> &[HalfPlane] {
        &self.footholds[leg]
    }
}

/// All rows of the model for one capacity, and the storage they are evaluated into.
#[derive(Debug, Clone)]
pub struct Catalog {
    capacity: Capacity,
    slots: Vec<RowSlot>,
    layout: Vec<RowLayout>,
    rows: Vec<Row>,
}

impl Catalog {
    /// Lay out every row for `capacity`.
    ///
    /// # Errors
    /// A capacity above its maximum ([`Capacity::validate`]).
    pub fn new(capacity: Capacity) -> Result<Self, CbfError> {
        capacity.validate()?;
        let mut slots = Vec::with_capacity(capacity.rows());
        for leg in 0..LEGS {
            for instance in 0..JOINT_ROWS_PER_LEG {
                let columns = &gen::JOINT_LIMITS_INPUT_COLUMNS[leg];
                slots.push(RowSlot { family: Family::JointLimits, leg: Some(leg), instance, columns });
            }
        }
        for leg in 0..LEGS {
            let columns = &gen::FOOT_HEIGHT_INPUT_COLUMNS[leg];
            slots.push(RowSlot { family: Family::FootHeight, leg: Some(leg), instance: 0, columns });
        }
        for leg in 0..LEGS {
            for instance in 0..2 {
                let columns = &gen::STABILITY_INPUT_COLUMNS[leg];
                slots.push(RowSlot { family: Family::Stability, leg: Some(leg), instance, columns });
            }
        }
        for instance in 0..capacity.edges {
            let columns = &gen::BODY_EDGE_SSAT_INPUT_COLUMNS;
            slots.push(RowSlot { family: Family::BodyEdge, leg: None, instance, columns });
        }
        for instance in 0..capacity.edges {
            for leg in 0..LEGS {
                let columns = &gen::TOE_EDGE_INPUT_COLUMNS[leg];
                slots.push(RowSlot { family: Family::ToeEdge, leg: Some(leg), instance, columns });
            }
        }
        for leg in 0..LEGS {
            for instance in 0..capacity.foothold_edges[leg] {
                let columns = &gen::FOOTHOLD_INPUT_COLUMNS[leg];
                slots.push(RowSlot { family: Family::Foothold, leg: Some(leg), instance, columns });
            }
        }
        debug_assert_eq!(slots.len(), capacity.rows());
        let layout = slots.iter().map(RowSlot::layout).collect();
        let rows = vec![Row::ZERO; slots.len()];
        Ok(Self { capacity, slots, layout, rows })
    }

    /// The capacity the rows were laid out for.
    pub fn capacity(&self) -> Capacity {
        self.capacity
    }

    /// Number of rows, active or not ([`Capacity::rows`]).
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Always `false`: the 42 joint-limit, foot-height and stability rows are always there.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Where each row sits (family, leg, instance, input columns), in row order; fixed at
    /// construction.
    pub fn slots(&self) -> &[RowSlot] {
        &self.slots
    }

    /// The rows as last evaluated, in [`Catalog::slots`] order (inactive rows hold stale
    /// values).
    pub fn rows(&self) -> &[Row] {
        &self.rows
    }

    /// Evaluate every applicable row at state `x` in environment `env`. Does not
    /// allocate; rows that do not apply are marked inactive.
    ///
    /// Rows can still come out non-finite where the geometry is singular (a toe exactly
    /// at its hip joint) or an environment value is extreme; the filter checks every
    /// active row before it solves.
    ///
    /// # Errors
    /// A state outside [`model::validate_state`]'s domain (non-finite, or an entry beyond
    /// [`model::STATE_LIMIT`]), an environment outside [`Environment::validate`]'s, or one
    /// built for another capacity. Rows are left as they were.
    pub fn evaluate(&mut self, x: &State, env: &Environment) -> Result<(), CbfError> {
        if env.capacity != self.capacity {
            return Err(CbfError::CapacityMismatch);
        }
        model::validate_state(x)?;
        env.validate()?;
        // The slots laid out in `new` are the one source of row order. A leg's four
        // joint-limit rows come from one kernel call, kept while that leg's slots pass.
        let mut joint_rows: Option<(usize, JointRows)> = None;
        for (slot, row) in self.slots.iter().zip(self.rows.iter_mut()) {
            let (leg, i) = (slot.leg.unwrap_or(0), slot.instance);
            match slot.family {
                Family::JointLimits => {
                    let (lie, lg) = match joint_rows {
                        Some((cached, rows)) if cached == leg => rows,
                        _ => {
                            let rows = gen::JOINT_LIMITS[leg](x);
                            joint_rows = Some((leg, rows));
                            rows
                        }
                    };
                    row.store(&lie[i], &lg[i], slot.columns);
                }
                Family::FootHeight => {
                    let (lie, lg) = gen::FOOT_HEIGHT[leg](x, env.floor_z[leg]);
                    row.store(&lie[0], &lg[0], slot.columns);
                }
                Family::Stability => match env.stability[leg][i] {
                    Some(b) => {
                        let (lie, lg) = gen::STABILITY[leg](x, b.a, b.b);
                        row.store(&lie[0], &lg[0], slot.columns);
                    }
                    None => row.active = false,
                },
                Family::BodyEdge => match env.edges.get(i) {
                    Some(e) => {
                        let (lie, lg) = gen::body_edge_ssat(x, &e.center, &e.rotation, &e.half);
                        row.store(&lie[0], &lg[0], slot.columns);
                    }
                    None => row.active = false,
                },
                Family::ToeEdge => match env.edges.get(i) {
                    Some(e) => {
                        let (lie, lg) = gen::TOE_EDGE[leg](x, &e.center, &e.rotation, &e.half);
                        row.store(&lie[0], &lg[0], slot.columns);
                    }
                    None => row.active = false,
                },
                Family::Foothold => match env.footholds[leg].get(i).filter(|_| env.swing[leg]) {
                    Some(p) => {
                        let (lie, lg) = gen::FOOTHOLD[leg](x, &p.normal, p.offset);
                        row.store(&lie[0], &lg[0], slot.columns);
                    }
                    None => row.active = false,
                },
            }
        }
        Ok(())
    }
}

impl RowSlot {
    /// The slot in the generic layout: instance = leg (edge slot for the edge families,
    /// foothold edge for footholds), row = the row within it.
    fn layout(&self) -> RowLayout {
        let leg = self.leg.unwrap_or(0);
        let (instance, row) = match self.family {
            Family::JointLimits | Family::Stability => (leg, self.instance),
            Family::FootHeight => (leg, 0),
            Family::BodyEdge => (self.instance, 0),
            Family::ToeEdge => (self.instance, leg),
            Family::Foothold => (leg * Capacity::MAX_FOOTHOLD_EDGES + self.instance, 0),
        };
        RowLayout { family: self.family.index(), instance, row, columns: self.columns }
    }
}

/// One joint-limit kernel call: four rows of [h, L_f h, L_f² h] and their L_g L_f h.
type JointRows = (
    [[f64; RELATIVE_DEGREE + 1]; JOINT_ROWS_PER_LEG],
    [[f64; gen::JOINT_LIMITS_LF_INPUT_COLUMNS.len()]; JOINT_ROWS_PER_LEG],
);

impl BarrierSet<NU> for Catalog {
    type State = State;
    type Params = Environment;

    fn families(&self) -> &[FamilyInfo] {
        &FAMILIES
    }

    fn layout(&self) -> &[RowLayout] {
        &self.layout
    }

    fn rows(&self) -> &[Row] {
        &self.rows
    }

    /// [`Catalog::evaluate`]; no family of the model depends on time.
    fn evaluate(&mut self, _t: f64, x: &State, params: &Environment) -> Result<(), CbfError> {
        Catalog::evaluate(self, x, params)
    }
}
