//! Terrain of any profile: flat levels along x on a floor at height 0, each `half_width`
//! either side of the path. It gives the gait its ground truth ([`Terrain::profile`]),
//! the filter the true edge cuboids ([`Terrain::edges`]) and a scanner solid boxes to
//! see ([`Terrain::solid_boxes`]). Besides staircases ([`Stairs::terrain`](super::Stairs::terrain))
//! it makes the shapes a straight flight does not: unequal rises, a landing, a single
//! box to cross and a platform to climb onto and leave.

use nalgebra::Vector3;

use super::profile::{Level, Profile};
use crate::catalog::EdgeCuboid;
use cbfgen::error::CbfError;
use cbfgen::geometry::OrientedBox;

/// A profile of levels extruded over |y| ≤ `half_width`, with an edge cuboid at every
/// change of height.
#[derive(Debug, Clone, PartialEq)]
pub struct Terrain {
    profile: Profile,
    changes: Vec<[f64; 2]>,
    half_width: f64,
    edge_half_section: f64,
}

/// Most changes of height a terrain may have.
pub const MAX_CHANGES: usize = 100;

impl Terrain {
    /// Ground at height 0 up to the first change; at each change `[x, height]` the
    /// ground steps up or down to `height`, which holds until the next change (the last
    /// for good). An edge cuboid of square section `2 · edge_half_section` lies along
    /// each change, tucked into the corner of the upper level (at a rise, in front of its
    /// riser's top; at a drop, behind its top).
    ///
    /// # Errors
    /// No changes or more than [`MAX_CHANGES`]; a non-finite or out-of-range entry; x not
    /// increasing; a height below 0 or above 10 m; a change of height or a level's
    /// length not above the edge cuboid's section; a half width outside (0, 100] m or
    /// not above the section.
    pub fn new(changes: &[[f64; 2]], half_width: f64, edge_half_section: f64) -> Result<Self, CbfError> {
        if changes.is_empty() || changes.len() > MAX_CHANGES {
            return Err(CbfError::OutOfRange {
                what: "terrain changes",
                value: changes.len() as f64,
                range: "1 to 100",
            });
        }
        cbfgen::error::within("terrain half width [m]", half_width, 0.0, 100.0, "(0, 100]")?;
        cbfgen::error::within("edge cuboid half section [m]", edge_half_section, 0.0, 1.0, "(0, 1]")?;
        cbfgen::error::positive("edge cuboid half section [m]", edge_half_section)?;
        let section = 2.0 * edge_half_section;
        if half_width <= section {
            return Err(CbfError::OutOfRange {
                what: "terrain half width [m]",
                value: half_width,
                range: "above the edge cuboid's section",
            });
        }
        let mut levels = Vec::with_capacity(changes.len() + 1);
        let (mut begin, mut height) = (f64::NEG_INFINITY, 0.0);
        for &[x, h] in changes {
            cbfgen::error::within("terrain change x [m]", x, -1e3, 1e3, "[-1e3, 1e3]")?;
            cbfgen::error::within("terrain height [m]", h, 0.0, 10.0, "[0, 10]")?;
            if x - begin <= section {
                return Err(CbfError::OutOfRange {
                    what: "terrain level length [m]",
                    value: x - begin,
                    range: "above the edge cuboid's section",
                });
            }
            if (h - height).abs() <= section {
                return Err(CbfError::OutOfRange {
                    what: "terrain change of height [m]",
                    value: h - height,
                    range: "beyond the edge cuboid's section",
                });
            }
            levels.push(Level { begin, end: x, height, half_width });
            (begin, height) = (x, h);
        }
        levels.push(Level { begin, end: f64::INFINITY, height, half_width });
        Ok(Self { profile: Profile::new(levels)?, changes: changes.to_vec(), half_width, edge_half_section })
    }

    /// The ground along the path.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Each change of height, `[x, new height]`.
    pub fn changes(&self) -> &[[f64; 2]] {
        &self.changes
    }

    /// Half the terrain's width, centred on y = 0 \[m\].
    pub fn half_width(&self) -> f64 {
        self.half_width
    }

    /// x of the first change of height \[m\].
    pub fn first_change(&self) -> f64 {
        self.changes[0][0]
    }

    /// The box along each change of height, in order: the edge cuboids as the exact
    /// clearance checks and figures take them.
    ///
    /// # Errors
    /// None for a terrain built by [`Terrain::new`] (the boxes are checked again).
    pub fn edge_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        let s = self.edge_half_section;
        let mut below = 0.0;
        let mut out = Vec::with_capacity(self.changes.len());
        for &[x, h] in &self.changes {
            // Tucked into the upper level's corner: past the riser at a rise, before the
            // drop at a drop.
            let (cx, top) = if h > below { (x + s, h) } else { (x - s, below) };
            out.push(OrientedBox::axis_aligned(Vector3::new(cx, 0.0, top - s), Vector3::new(s, self.half_width, s))?);
            below = h;
        }
        Ok(out)
    }

    /// The box along each change of height that the filter keeps the wheels and the body
    /// out of: the nosing and the whole riser below it, one box from the lower level's
    /// height to the upper level's top, `2 · edge_half_section` deep into the upper
    /// level (its section as wide as the edge cuboid's, [`Terrain::edge_boxes`], which is
    /// its top).
    ///
    /// Why one box from the lower tread to the upper: a nosing cuboid alone leaves the
    /// riser below it open, and a wheel (radius 0.1 m) rolling on the lower tread meets
    /// the riser at its own centre's height, 10 cm up, below a 5 cm cuboid under a rise
    /// over 15 cm (it could go 13 mm into a 20 cm riser with the cuboid's rows met). Its
    /// top is the tread's own height, as the nosing's: a wheel standing on the upper
    /// tread stays outside it (its rows hold such a wheel a margin above its first
    /// 5 cm, as they did over the nosing); its bottom is the lower tread's, whose wheels
    /// meet only its face. A box cannot reach past the rise into the upper step without
    /// meeting wheels on that tread, and need not: a wheel outside this box whose
    /// centre is before the riser cannot reach the step's solid beyond the box
    /// (`systems/tachyon3/tests/integration/terrain.rs` checks it), and a wheel past the riser stands on the upper
    /// level, where its foot-height row keeps it above the tread.
    ///
    /// # Errors
    /// None for a terrain built by [`Terrain::new`] (the boxes are checked again).
    pub fn riser_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        let s = self.edge_half_section;
        let mut below = 0.0;
        let mut out = Vec::with_capacity(self.changes.len());
        for &[x, h] in &self.changes {
            // In the upper level: past the riser at a rise, before the drop at a drop.
            let cx = if h > below { x + s } else { x - s };
            let (lo, hi) = (below.min(h), below.max(h));
            let center = Vector3::new(cx, 0.0, 0.5 * (lo + hi));
            out.push(OrientedBox::axis_aligned(center, Vector3::new(s, self.half_width, 0.5 * (hi - lo)))?);
            below = h;
        }
        Ok(out)
    }

    /// The riser boxes ([`Terrain::riser_boxes`]), in order, as the filter takes them.
    ///
    /// # Errors
    /// As [`Terrain::riser_boxes`].
    pub fn riser_cuboids(&self) -> Result<Vec<EdgeCuboid>, CbfError> {
        Ok(self.riser_boxes()?.iter().map(EdgeCuboid::from_box).collect())
    }

    /// The edge cuboid along each change of height, in order, as the filter takes them.
    ///
    /// # Errors
    /// As [`Terrain::edge_boxes`].
    pub fn edges(&self) -> Result<Vec<EdgeCuboid>, CbfError> {
        Ok(self.edge_boxes()?.iter().map(EdgeCuboid::from_box).collect())
    }

    /// The terrain as solid boxes, for a scanner to see: a floor (top at z = 0, from 4 m
    /// before the first change to 4 m past the last, 3 m wider than the terrain either
    /// side) and one box per raised level (the last one 3 m long).
    ///
    /// # Errors
    /// None for a terrain built by [`Terrain::new`] (the boxes are checked again).
    pub fn solid_boxes(&self) -> Result<Vec<OrientedBox>, CbfError> {
        let (first, last) = (self.first_change(), self.profile.last_change());
        let (lo, hi) = (first - 4.0, last + 4.0);
        let mut boxes = vec![OrientedBox::axis_aligned(
            Vector3::new((lo + hi) / 2.0, 0.0, -0.5),
            Vector3::new((hi - lo) / 2.0, self.half_width + 3.0, 0.5),
        )?];
        boxes.extend(self.level_boxes(0.0)?);
        Ok(boxes)
    }

    /// One box per raised level (the last one 3 m long), from `below` metres under the
    /// terrain's floor up to the level's top: `below` is 0 on the floor, and a flight
    /// placed on a landing reaches down to the world's floor ([`Route`](super::route::Route)).
    ///
    /// # Errors
    /// None for a terrain built by [`Terrain::new`] and a finite `below` ≥ 0.
    pub fn level_boxes(&self, below: f64) -> Result<Vec<OrientedBox>, CbfError> {
        let last = self.profile.last_change();
        self.profile
            .levels()
            .iter()
            .filter(|l| l.height > 0.0)
            .map(|level| {
                let (end, bottom) = (level.end.min(last + 3.0), -below);
                OrientedBox::axis_aligned(
                    Vector3::new((level.begin + end) / 2.0, 0.0, (level.height + bottom) / 2.0),
                    Vector3::new((end - level.begin) / 2.0, self.half_width, (level.height - bottom) / 2.0),
                )
            })
            .collect()
    }

    /// Four steps of unequal rise (10, 18, 12, 16 cm) and run (35, 30, 40 cm) from x = 1 m.
    pub fn unequal_rises() -> Self {
        Self::named(&[[1.0, 0.10], [1.35, 0.28], [1.65, 0.40], [2.05, 0.56]], 1.0)
    }

    /// Three 15 × 32 cm steps, a 1.2 m landing, two more steps.
    pub fn landing() -> Self {
        Self::named(&[[1.0, 0.15], [1.32, 0.30], [1.64, 0.45], [2.84, 0.60], [3.16, 0.75]], 1.0)
    }

    /// A single box on the floor to cross: 12 cm high, 60 cm long, 1.6 m wide.
    pub fn single_box() -> Self {
        Self::named(&[[1.0, 0.12], [1.6, 0.0]], 0.8)
    }

    /// A platform to climb onto and roll off: 20 cm high, 1.5 m long.
    pub fn platform() -> Self {
        Self::named(&[[1.0, 0.20], [2.5, 0.0]], 1.0)
    }

    /// The named shapes' dimensions are constants that pass [`Terrain::new`].
    fn named(changes: &[[f64; 2]], half_width: f64) -> Self {
        Self::new(changes, half_width, super::Stairs::HARDWARE.edge_half_section)
            .unwrap_or_else(|e| unreachable!("a named terrain's constants are valid: {e}"))
    }
}
