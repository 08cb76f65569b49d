//! Seed 004's stepping stones (section V): square stones along a forward trot, displaced at
//! random; the trunk stops when its feet reach the last stones. Two layouts
//! ([`StoneLayout`]):
//!
//! - **Under the gait** (the default): one stone under each foothold the trot asks for.
//!   The paper's easy case, where the CBF in the whole-body QP alone suffices ("only when
//!   the stepping-stones are placed close to the nominal gait").
//! - **Rows**: each side's stones on a fixed pitch that does not match the trot's stride,
//!   so a nominal foothold falls anywhere between two stones and the planner must move it
//!   by up to half a gap ([`StoneField::rows`]).
//!
//! The trot's speed is chosen so that each hind foot lands on the stones its front foot
//! used: a front and a hind foot of one side land an odd number of swings apart, so the
//! hind foot reaches the front foot's footholds when `v = d / (k T)` for the distance `d`
//! between their standing positions, `T` the swing time and `k` odd ([`StoneField::swings_between`],
//! 7 by default: 0.337 m/s at T = 0.3 s, stones 0.202 m apart along a side). Before that
//! the hind feet step on stones of their own between their starting stones and the front
//! feet's. Footholds within [`MERGE`] of each other share a stone.
//!
//! The seed's text lost its displacement figures; these are assumed (docs/anymal.md):
//! uniform within ±10 mm along the walk, ±15 mm across, ±20 mm in height, per stone, from a
//! seeded ChaCha8 stream, so a field is the same on every machine (the rows: ±30 / ±20 /
//! ±20 mm). The four stones the robot starts on are not displaced (it stands on them at
//! `z = 0`).
//!
//! ```
//! use cbfgen_anymal::stones::{SteppingStones, StoneField};
//!
//! let field = SteppingStones::new(&StoneField { strides: 4, seed: 7, ..StoneField::default() })?;
//! assert!(field.stones().len() >= 8);
//! // Every foothold the trot asks for is on a stone, within the displacements.
//! let trot = field.trot();
//! for foot in 0..4 {
//!     let goal = trot.foothold_for(foot, 2.0);
//!     let (_, distance) = field.terrain().nearest([goal[0], goal[1], 0.0]).unwrap();
//!     assert!(distance <= 0.021);
//! }
//! // The rows: stones a fixed pitch apart (here undisplaced), wherever the trot's
//! // footholds fall.
//! let rows = SteppingStones::new(&StoneField { strides: 4, displacement: [0.0; 3], ..StoneField::rows() })?;
//! let mut left: Vec<f64> = rows.stones().iter().filter(|s| s.top[1] > 0.0).map(|s| s.top[0]).collect();
//! left.sort_by(f64::total_cmp);
//! assert!(left.len() >= 6 && left.windows(3).all(|w| ((w[2] - w[1]) - (w[1] - w[0])).abs() < 1e-9));
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use cbfgen::error::{within, CbfError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::gait::Trot;
use crate::terrain::{Patch, Terrain};
use crate::wbc::FEET;

/// Footholds this close (horizontally) share a stone, centred between them \[m\]: a hind
/// foot's first foothold beside its front foot's starting stone is half a swing's travel
/// (5 cm) ahead of it, the others coincide.
pub const MERGE: f64 = 0.06;

/// A stone field's description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StoneField {
    /// Strides each foot takes (two swings each) before the trunk stops.
    pub strides: usize,
    /// Swing time \[s\] (a stance lasts as long).
    pub swing: f64,
    /// How high a swing foot rises above the surfaces it goes between \[m\].
    pub lift: f64,
    /// Odd number of swings between a front foot's and its hind foot's landing on one
    /// stone: the speed is the feet's distance over this many swings.
    pub swings_between: usize,
    /// A stone's top side \[m\].
    pub size: f64,
    /// The largest displacement of a stone along the walk, across it and in height \[m\].
    pub displacement: [f64; 3],
    /// The random stream's seed.
    pub seed: u64,
    /// Where the stones lie before they are displaced.
    pub layout: StoneLayout,
}

/// Where a field's stones lie before their random displacement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StoneLayout {
    /// One stone under each foothold the trot asks for (footholds within [`MERGE`] share
    /// one).
    UnderTheGait,
    /// A row of stones under each side's feet, `pitch` apart along the walk \[m\], laid
    /// without regard to the trot's footholds. The pitch is rounded so that a side's front
    /// and hind starting stones are both in its row (to the feet's distance over a whole
    /// number of pitches).
    Rows {
        /// The stones' spacing along the walk \[m\], before rounding.
        pitch: f64,
    },
}

impl Default for StoneField {
    /// Eight strides, T = 0.3 s, 10 cm lift, hind feet on the front feet's stones seven
    /// swings later, 14 cm stones, displacements ±10 / ±15 / ±20 mm, seed 0.
    fn default() -> Self {
        Self {
            strides: 8,
            swing: 0.3,
            lift: 0.1,
            swings_between: 7,
            size: 0.14,
            displacement: [0.010, 0.015, 0.020],
            seed: 0,
            layout: StoneLayout::UnderTheGait,
        }
    }
}

impl StoneField {
    /// The field away from the gait: the default's trot over rows of stones 0.24 m apart
    /// (the trot's stride is 0.202 m, so its footholds drift by 3.4 cm a stride against the
    /// stones), displaced by up to ±30 mm along the walk, ±20 mm across and ±20 mm in
    /// height.
    pub fn rows() -> Self {
        Self { layout: StoneLayout::Rows { pitch: 0.24 }, displacement: [0.030, 0.020, 0.020], ..Self::default() }
    }
}

/// A square stone: its top's centre (world) and half side \[m\]; axis-aligned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stone {
    /// The top's centre.
    pub top: [f64; 3],
    /// Half the side.
    pub half: f64,
}

impl Stone {
    /// The horizontal distance from `(x, y)` to the stone's top square (0 over it) \[m\].
    pub fn distance(&self, x: f64, y: f64) -> f64 {
        let dx = ((x - self.top[0]).abs() - self.half).max(0.0);
        let dy = ((y - self.top[1]).abs() - self.half).max(0.0);
        dx.hypot(dy)
    }
}

/// A stone field and the trot across it.
#[derive(Debug, Clone)]
pub struct SteppingStones {
    trot: Trot,
    stones: Vec<Stone>,
    terrain: Terrain,
}

impl SteppingStones {
    /// Lay the stones for `field`.
    ///
    /// # Errors
    /// Strides outside `[1, 1000]`, an even `swings_between` or one outside `[1, 99]`, a
    /// swing time outside `[0.1, 2]` s, a lift outside `[0, 0.5]` m, a size outside
    /// `[0.02, 2]` m, a displacement outside `[0, size / 4]`, or rows whose rounded pitch
    /// leaves less than 1 cm between displaced stones (or exceeds 1 m).
    pub fn new(field: &StoneField) -> Result<Self, CbfError> {
        within("strides", field.strides as f64, 1.0, 1000.0, "[1, 1000]")?;
        within("swings between a front and a hind landing", field.swings_between as f64, 1.0, 99.0, "[1, 99]")?;
        if field.swings_between.is_multiple_of(2) {
            return Err(CbfError::OutOfRange {
                what: "swings between a front and a hind landing (odd)",
                value: field.swings_between as f64,
                range: "odd",
            });
        }
        within("swing time [s]", field.swing, 0.1, 2.0, "[0.1, 2]")?;
        within("lift [m]", field.lift, 0.0, 0.5, "[0, 0.5]")?;
        within("stone size [m]", field.size, 0.02, 2.0, "[0.02, 2]")?;
        for d in field.displacement {
            within("stone displacement [m]", d, 0.0, field.size / 4.0, "[0, size / 4]")?;
        }
        let standing = Trot::from_standing(field.swing, field.lift, [0.0; 2]);
        // LF with LH and RF with RH: the mean distance between a side's feet.
        let home = standing.home;
        let d = 0.5 * ((home[0][0] - home[2][0]) + (home[1][0] - home[3][0]));
        let speed = d / (field.swings_between as f64 * field.swing);
        let trot = Trot { velocity: [speed, 0.0], duration: 2.0 * field.swing * field.strides as f64, ..standing };
        let nominal = match field.layout {
            StoneLayout::UnderTheGait => under_the_gait(&trot, field.strides),
            StoneLayout::Rows { pitch } => in_rows(&trot, field, pitch)?,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(field.seed);
        let mut random = |bound: f64| if bound > 0.0 { rng.random_range(-bound..=bound) } else { 0.0 };
        let half = 0.5 * field.size;
        let stones: Vec<Stone> = nominal
            .iter()
            .enumerate()
            .map(|(k, p)| {
                // The foot sphere's centre is a radius above the surface at its foothold.
                let surface = p[2] - crate::wbc_generated::FOOT_RADIUS;
                let shift = if k < FEET { [0.0; 3] } else { field.displacement.map(&mut random) };
                Stone { top: [p[0] + shift[0], p[1] + shift[1], surface + shift[2]], half }
            })
            .collect();
        let patches = stones.iter().map(|s| Patch::rectangle(s.top, [half, half], 0.0)).collect::<Result<_, _>>()?;
        Ok(Self { trot, stones, terrain: Terrain::new(patches)? })
    }

    /// The trot across the field (it stops on the last stones).
    pub fn trot(&self) -> &Trot {
        &self.trot
    }

    /// The stones, the four the robot starts on first.
    pub fn stones(&self) -> &[Stone] {
        &self.stones
    }

    /// The stones' tops as a segmented terrain.
    pub fn terrain(&self) -> &Terrain {
        &self.terrain
    }

    /// When the walk is over \[s\]: the trunk has stopped and every foot has stepped onto
    /// its last stone.
    pub fn end(&self) -> f64 {
        self.trot.swing + self.trot.duration + 3.0 * self.trot.swing
    }

    /// The top height of the stone nearest `(x, y)` horizontally \[m\].
    pub fn nearest_top(&self, x: f64, y: f64) -> f64 {
        self.stones
            .iter()
            .map(|s| (s.distance(x, y), s.top[2]))
            .fold((f64::INFINITY, 0.0), |best, s| if s.0 < best.0 { s } else { best })
            .1
    }

    /// The horizontal distance from a foot centre's `(x, y)` to the nearest stone's top
    /// (0 over a stone) \[m\]: a landing's misstep.
    pub fn misstep(&self, x: f64, y: f64) -> f64 {
        self.stones.iter().map(|s| s.distance(x, y)).fold(f64::INFINITY, f64::min)
    }
}

/// Every foothold the trot asks for, in the order the feet reach them (the stance under way
/// at the middle of each swing period, until two strides after the trunk stops), those
/// within [`MERGE`] merged into their mean; the four starting footholds first.
fn under_the_gait(trot: &Trot, strides: usize) -> Vec<[f64; 3]> {
    let mut footholds: Vec<([f64; 3], usize)> = Vec::new();
    for (_, p) in asked_footholds(trot, strides) {
        match footholds.iter_mut().find(|(q, _)| (p[0] - q[0]).hypot(p[1] - q[1]) <= MERGE) {
            // A running mean: the stone's centre between the footholds it carries.
            Some((q, n)) => {
                let m = *n as f64;
                *q = std::array::from_fn(|i| (q[i] * m + p[i]) / (m + 1.0));
                *n += 1;
            }
            None => footholds.push((p, 1)),
        }
    }
    footholds.into_iter().map(|(p, _)| p).collect()
}

/// Each foot and the foothold the trot asks of it, in the order the feet reach them: the
/// stance under way at the middle of each swing period, until two strides after the trunk
/// stops.
fn asked_footholds(trot: &Trot, strides: usize) -> impl Iterator<Item = (usize, [f64; 3])> + '_ {
    (0..2 * strides + 6).flat_map(move |period| {
        (0..FEET).map(move |foot| (foot, trot.foothold_for(foot, (period as f64 + 0.5) * trot.swing)))
    })
}

/// Each side's row of footholds from its hind foot's start, a rounded `pitch` apart, to a
/// pitch past the last foothold the trot asks of either foot on that side; the four
/// starting footholds first (in `LEGS` order), then the rest, left row first.
fn in_rows(trot: &Trot, field: &StoneField, pitch: f64) -> Result<Vec<[f64; 3]>, CbfError> {
    within("stone pitch [m]", pitch, field.size, 1.0, "[size, 1]")?;
    let mut nominal: Vec<[f64; 3]> = trot.home.to_vec();
    // LEGS order LF RF LH RH: each side's front foot and the hind foot behind it.
    for (front, hind) in [(0, 2), (1, 3)] {
        let (f, h) = (trot.home[front], trot.home[hind]);
        let span = f[0] - h[0];
        let pitches = (span / pitch).round().max(1.0) as usize;
        let step = span / pitches as f64;
        let gap = step - field.size - 2.0 * field.displacement[0];
        if gap < 0.01 {
            return Err(CbfError::OutOfRange {
                what: "stone pitch after rounding [m]",
                value: step,
                range: "at least size + 2 × displacement along + 1 cm",
            });
        }
        let last = asked_footholds(trot, field.strides)
            .filter(|(foot, _)| *foot == front || *foot == hind)
            .map(|(_, p)| p[0])
            .fold(f64::NEG_INFINITY, f64::max);
        let y = 0.5 * (f[1] + h[1]);
        // To a pitch past the last foothold; the front foot's starting stone (the
        // `pitches`-th) is already in, undisplaced.
        let count = ((last - h[0]) / step).floor() as usize + 1;
        nominal.extend((1..=count).filter(|&k| k != pitches).map(|k| [h[0] + k as f64 * step, y, h[2]]));
    }
    Ok(nominal)
}
