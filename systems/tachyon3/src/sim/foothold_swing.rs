//! The paper's section IV-D case, isolated: a swing toe that starts outside its foothold.
//!
//! The standard posture; tripod [`TRIPODS`]`[0]` swings. Its nominal input lifts the three
//! toes 8 cm and holds them there, holds the origin, and knows nothing of the footholds.
//! Each foothold is a slanted quadrilateral (a convex polygon, not a strip) whose inset
//! edge lies `shift` metres ahead of its toe, as after a re-planned landing. The filter
//! runs at 1 kHz, the model integrates by Euler; [`OutsideRule`] says what happens while
//! a toe is out. `cargo run --release -p cbfgen-tachyon3 --example foothold_pull` draws
//! the result; `tests/foothold.rs` checks it.

use super::gait::{GaitParams, TRIPODS};
use super::DT;
use crate::catalog::{self, Capacity, Environment, Tachyon3Filter, Tachyon3FilterExt};
use crate::foothold::{depth, polygon_half_planes};
use crate::generated as gen;
use crate::model::{self, State, NU, TOE_BLOCK};
use cbfgen::error::CbfError;
use cbfgen::filter::Verdict;

/// How the toes lift: 8 cm above where they stand \[m\].
const LIFT: f64 = 0.08;
/// A foothold's inset: the toe radius and 2 cm, as the gait's strips \[m\].
pub const INSET: f64 = 0.12;
/// How far inside its foothold a pulled toe is aimed \[m\].
pub const MARGIN: f64 = 0.01;

/// What happens while a swing toe is outside its foothold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutsideRule {
    /// [`Environment::guide_toe`]: the leg's foothold rows off, the CLF pull on.
    Pull,
    /// The foothold rows stay on: the ECBF is asked to recover from `h < 0`.
    KeepRows,
}

/// One swing, cycle by cycle.
#[derive(Debug, Clone)]
pub struct FootholdSwing {
    /// The swinging legs, [`LEG_NAMES`](crate::model::LEG_NAMES) order.
    pub legs: [usize; 3],
    /// Each leg's foothold polygon, before the inset (world xy \[m\]).
    pub polygons: [[[f64; 2]; 4]; 3],
    /// Time after each cycle \[s\].
    pub t: Vec<f64>,
    /// The swing toes' world xy after each cycle \[m\].
    pub toes: Vec<[[f64; 2]; 3]>,
    /// How deep each toe is inside its inset foothold after each cycle (negative: outside)
    /// \[m\].
    pub depth: Vec<[f64; 3]>,
    /// Whether the cycle's safety verdict was relaxed, and its convergence verdict.
    pub relaxed: Vec<(bool, bool)>,
}

impl FootholdSwing {
    /// When each toe first entered its foothold \[s\], if it did.
    pub fn entered(&self) -> [Option<f64>; 3] {
        std::array::from_fn(|i| self.depth.iter().zip(&self.t).find(|(d, _)| d[i] >= -1e-6).map(|(_, &t)| t))
    }

    /// The largest world x acceleration of a swing toe \[m/s²\] (second differences of
    /// its path: the toe's own acceleration and the origin's add).
    pub fn peak_accel(&self) -> f64 {
        let accel = |w: &[[[f64; 2]; 3]], i: usize| (w[2][i][0] - 2.0 * w[1][i][0] + w[0][i][0]) / (DT * DT);
        self.toes.windows(3).flat_map(|w| (0..3).map(move |i| accel(w, i).abs())).fold(0.0, f64::max)
    }

    /// Cycles whose safety verdict was relaxed.
    pub fn safety_relaxed(&self) -> usize {
        self.relaxed.iter().filter(|r| r.0).count()
    }

    /// Cycles whose convergence verdict was relaxed (the pull given up).
    pub fn convergence_relaxed(&self) -> usize {
        self.relaxed.iter().filter(|r| r.1).count()
    }
}

/// The swing's duration in the gait's default timing: a toe in its foothold by then has
/// entered it before touchdown \[s\].
pub fn swing_time() -> f64 {
    GaitParams::default().swing_time
}

/// Run one swing of 1.5 × [`swing_time`] with footholds `shift` metres ahead of the toes.
///
/// # Errors
/// A filter error (none on this scene; a regression would show here).
pub fn swing_into_footholds(rule: OutsideRule, shift: f64) -> Result<FootholdSwing, CbfError> {
    let legs = TRIPODS[0];
    let mut filter = Tachyon3Filter::with_capacity(Capacity::PAPER_WORST_CASE, catalog::default_settings())?;
    let mut env = Environment::new(Capacity::PAPER_WORST_CASE)?;
    let mut x = model::standard_posture();
    let start = toes_xy(&x, legs);
    let polygons: [[[f64; 2]; 4]; 3] = std::array::from_fn(|i| {
        let (ty, x0) = (start[i][1], start[i][0] + shift - INSET);
        [[x0, ty - 0.4], [x0 + 0.5, ty - 0.4], [x0 + 0.4, ty + 0.4], [x0, ty + 0.4]]
    });
    let edges = polygons.iter().map(|p| polygon_half_planes(p, INSET)).collect::<Result<Vec<_>, _>>()?;
    let lifted = legs.map(|leg| x[TOE_BLOCK + 4 * leg + 1] + LIFT);
    let mut swinging = [false; 6];
    for leg in legs {
        swinging[leg] = true;
    }
    let cycles = (1.5 * swing_time() / DT).round() as usize;
    let mut run = FootholdSwing {
        legs,
        polygons,
        t: Vec::with_capacity(cycles),
        toes: Vec::with_capacity(cycles),
        depth: Vec::with_capacity(cycles),
        relaxed: Vec::with_capacity(cycles),
    };
    for k in 0..cycles {
        let toes = toes_xy(&x, legs);
        env.set_swing(swinging);
        for (i, &leg) in legs.iter().enumerate() {
            env.set_foothold(leg, &edges[i])?;
            if rule == OutsideRule::Pull {
                env.guide_toe(leg, toes[i], MARGIN)?;
            }
        }
        let mut u_ref = [0.0; NU];
        u_ref[gen::input::A] = -4.0 * x[gen::state::V];
        for (i, &leg) in legs.iter().enumerate() {
            let (ix, iz) = (TOE_BLOCK + 4 * leg, TOE_BLOCK + 4 * leg + 1);
            u_ref[gen::input::LF_AX + 2 * leg] = -8.0 * x[ix + 2];
            u_ref[gen::input::LF_AZ + 2 * leg] = 40.0 * (lifted[i] - x[iz]) - 12.0 * x[iz + 2];
        }
        let out = *filter.update(&x, &u_ref, &env)?;
        let dx = model::xdot(&x, &out.u);
        for (xi, d) in x.iter_mut().zip(dx) {
            *xi += DT * d;
        }
        let toes = toes_xy(&x, legs);
        run.t.push((k + 1) as f64 * DT);
        run.depth.push(std::array::from_fn(|i| depth(&edges[i], toes[i])));
        run.toes.push(toes);
        run.relaxed.push((out.safety.verdict == Verdict::Relaxed, out.convergence.verdict == Verdict::Relaxed));
    }
    Ok(run)
}

/// The world xy of each of `legs`' toes.
fn toes_xy(x: &State, legs: [usize; 3]) -> [[f64; 2]; 3] {
    let (_, _, toes) = gen::world_kinematics(x);
    legs.map(|leg| [toes[leg][0], toes[leg][1]])
}
