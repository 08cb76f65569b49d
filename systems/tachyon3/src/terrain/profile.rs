//! The ground along the robot's path as the gait reads it: flat levels one after another
//! in world x, each with its height and the half width of ground it offers either side of
//! the path (y = 0). Built from the true terrain ([`Terrain`](super::Terrain)) or from
//! perceived planes ([`perceived`](crate::sim::perceived)).

use crate::model::TOE_RADIUS;
use cbfgen::error::CbfError;

/// One flat level: world x from `begin` (inclusive) to `end` (exclusive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// Where it begins \[m\]; −∞ for the first level.
    pub begin: f64,
    /// Where it ends \[m\]; +∞ for the last level.
    pub end: f64,
    /// Its height \[m\].
    pub height: f64,
    /// Ground either side of the path (|y| up to this) \[m\].
    pub half_width: f64,
}

/// Levels covering the whole x axis, in order, each ending where the next begins.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    levels: Vec<Level>,
}

/// Most levels a profile holds.
pub const MAX_LEVELS: usize = 1000;

impl Profile {
    /// A profile from its levels.
    ///
    /// # Errors
    /// No levels or more than [`MAX_LEVELS`]; a first level not beginning at −∞ or a last
    /// not ending at +∞; a level that does not begin where the one before ends or is
    /// empty; a height outside ±100 m or a half width outside (0, 100] m.
    pub fn new(levels: Vec<Level>) -> Result<Self, CbfError> {
        let (Some(first), Some(last)) = (levels.first(), levels.last()) else {
            return Err(CbfError::NotPositive { what: "profile levels", value: 0.0 });
        };
        if levels.len() > MAX_LEVELS {
            return Err(CbfError::OutOfRange {
                what: "profile levels",
                value: levels.len() as f64,
                range: "at most 1000",
            });
        }
        if first.begin != f64::NEG_INFINITY || last.end != f64::INFINITY {
            return Err(CbfError::OutOfRange {
                what: "profile extent",
                value: if first.begin.is_finite() { first.begin } else { last.end },
                range: "from -inf to +inf",
            });
        }
        for (k, level) in levels.iter().enumerate() {
            cbfgen::error::within("level height [m]", level.height, -100.0, 100.0, "[-100, 100]")?;
            cbfgen::error::within("level half width [m]", level.half_width, 0.0, 100.0, "(0, 100]")?;
            cbfgen::error::positive("level half width [m]", level.half_width)?;
            if k + 1 < levels.len() {
                cbfgen::error::within("level end [m]", level.end, -1e4, 1e4, "[-1e4, 1e4]")?;
            }
            let contiguous = k == 0 || levels[k - 1].end == level.begin;
            if !contiguous || level.end <= level.begin {
                return Err(CbfError::OutOfRange {
                    what: "level begin [m]",
                    value: level.begin,
                    range: "where the level before ends, below its own end",
                });
            }
        }
        Ok(Self { levels })
    }

    /// The same levels, each `lift` higher \[m\].
    ///
    /// # Errors
    /// A height that leaves ±100 m.
    pub fn lifted(&self, lift: f64) -> Result<Self, CbfError> {
        Self::new(self.levels.iter().map(|l| Level { height: l.height + lift, ..*l }).collect())
    }

    /// The levels, in order of x.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// Index of the level holding world `x` (NaN reads as the last level).
    fn index(&self, x: f64) -> usize {
        self.levels.partition_point(|l| l.end <= x).min(self.levels.len() - 1)
    }

    /// The level holding world `x`.
    pub fn level_at(&self, x: f64) -> &Level {
        &self.levels[self.index(x)]
    }

    /// Ground height at world `x` \[m\].
    pub fn height_at(&self, x: f64) -> f64 {
        self.level_at(x).height
    }

    /// x where the level holding world `x` begins and ends.
    pub fn flat_region(&self, x: f64) -> (f64, f64) {
        let level = self.level_at(x);
        (level.begin, level.end)
    }

    /// Height of the last level (where every course ends) \[m\].
    pub fn final_height(&self) -> f64 {
        self.levels[self.levels.len() - 1].height
    }

    /// Where the last level begins: the last change of height \[m\] (−∞ on flat ground).
    pub fn last_change(&self) -> f64 {
        self.levels[self.levels.len() - 1].begin
    }

    /// The x at which to read the level a toe sphere of radius [`TOE_RADIUS`] centred at
    /// `toe` stands on. That is its centre's x, except for a wheel resting on a nosing:
    /// centre still before the riser, but bottom within a millimetre of the step's top,
    /// or higher. It stands on the step above, so this returns the riser's x (a nanometre
    /// past it, so that rounding cannot put it back before the riser). Reading the level
    /// under the centre instead would send such a toe down to the floor it has left.
    pub fn standing_x(&self, toe: &[f64; 3]) -> f64 {
        let (_, end) = self.flat_region(toe[0]);
        let above = self.height_at(end);
        if end - toe[0] < TOE_RADIUS && above > self.height_at(toe[0]) && toe[2] - TOE_RADIUS >= above - 1e-3 {
            end + 1e-9
        } else {
            toe[0]
        }
    }

    /// Ground height under each toe (world sphere centres, `LEG_NAMES` order) \[m\]: the
    /// level each toe stands on, by [`Profile::standing_x`].
    pub fn floors_under(&self, toes: &[[f64; 3]; 6]) -> [f64; 6] {
        toes.map(|toe| self.height_at(self.standing_x(&toe)))
    }
}
