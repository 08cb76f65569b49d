//! Convex foothold polygons, and the switch between the foothold barrier and its
//! control-Lyapunov pull (the paper's section IV-D).
//!
//! A swing toe inside its foothold is kept there by the foothold rows (eq. 12, one
//! half-plane per polygon edge). A toe outside it — the region moved under it after a
//! perception update, or the toe was pushed out by a row of higher priority — cannot be
//! kept inside a set it is not in; instead the leg's foothold rows are switched off and
//! the foothold pull, a control Lyapunov function of the lowest priority, brings the toe
//! towards the nearest point of the polygon. Once the toe is in, the rows come back on.
//! [`Environment::guide_toe`] makes that choice each cycle.
//!
//! ```
//! use cbfgen_tachyon3::catalog::{Capacity, Environment};
//! use cbfgen_tachyon3::foothold::{polygon_half_planes, ToeGuide};
//!
//! let mut env = Environment::new(Capacity::PAPER_WORST_CASE)?;
//! // A tread 35 cm deep from x = 1.0, 1.2 m wide; toe centres keep 12 cm from its sides.
//! let tread = [[1.0, -0.6], [1.35, -0.6], [1.35, 0.6], [1.0, 0.6]];
//! env.set_foothold(0, &polygon_half_planes(&tread, 0.12)?)?;
//! // A toe 10 cm short of the tread's inset edge is pulled, to 1 cm inside that edge.
//! match env.guide_toe(0, [1.02, 0.4], 0.01)? {
//!     ToeGuide::Pulled { target, outside } => {
//!         assert!((target[0] - 1.13).abs() < 1e-12 && (target[1] - 0.4).abs() < 1e-12);
//!         assert!((outside - 0.10).abs() < 1e-12);
//!     }
//!     ToeGuide::Kept => unreachable!("the toe is outside"),
//! }
//! // Inside, the foothold rows keep it.
//! assert_eq!(env.guide_toe(0, [1.2, 0.4], 0.01)?, ToeGuide::Kept);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use crate::catalog::{Environment, HalfPlane};
use crate::generated::FootholdPullParams;
use cbfgen::error::{finite, CbfError};
use cbfgen::system;

/// Feasibility tolerance of [`nearest_inside`] \[m\]: a point within this of every
/// half-plane counts as inside (the intersections it tests are computed, not exact).
const FEASIBLE: f64 = 1e-9;

/// The half-planes of the convex polygon `vertices` (either winding, at least 3,
/// world xy \[m\]) shrunk by `inset` \[m\]: a toe centre inside them keeps `inset` from
/// every side (the toe radius and a margin, for a toe on a perceived tread). Meant for
/// planning time, when a polygon changes, not for every control cycle: it allocates.
///
/// # Errors
/// Fewer than 3 vertices, a non-finite coordinate or inset, a negative inset, a
/// repeated vertex, a polygon that is not convex or has no area, or an inset that
/// leaves nothing of it.
pub fn polygon_half_planes(vertices: &[[f64; 2]], inset: f64) -> Result<Vec<HalfPlane>, CbfError> {
    finite("foothold inset", inset)?;
    if inset < 0.0 {
        return Err(CbfError::OutOfRange { what: "foothold inset", value: inset, range: "[0, inf)" });
    }
    let n = vertices.len();
    if n < 3 {
        return Err(CbfError::OutOfRange { what: "foothold polygon vertices", value: n as f64, range: "[3, inf)" });
    }
    for v in vertices {
        finite("foothold polygon vertex", v[0])?;
        finite("foothold polygon vertex", v[1])?;
    }
    let edge = |i: usize| {
        let (a, b) = (vertices[i], vertices[(i + 1) % n]);
        [b[0] - a[0], b[1] - a[1]]
    };
    // Twice the signed area says the winding; every turn must have its sign (convex).
    let area2: f64 =
        (0..n).map(|i| vertices[i][0] * vertices[(i + 1) % n][1] - vertices[(i + 1) % n][0] * vertices[i][1]).sum();
    let scale = vertices.iter().map(|v| v[0].abs().max(v[1].abs())).fold(1.0, f64::max);
    if area2.is_nan() || area2.abs() <= 1e-12 * scale * scale {
        return Err(CbfError::OutOfRange { what: "foothold polygon area", value: area2 / 2.0, range: "not 0" });
    }
    let winding = area2.signum();
    for i in 0..n {
        let (d, e) = (edge(i), edge((i + 1) % n));
        if d == [0.0, 0.0] {
            return Err(CbfError::OutOfRange { what: "foothold polygon edge length", value: 0.0, range: "(0, inf)" });
        }
        if winding * (d[0] * e[1] - d[1] * e[0]) < 0.0 {
            return Err(CbfError::OutOfRange {
                what: "foothold polygon turn at a vertex (not convex)",
                value: winding * (d[0] * e[1] - d[1] * e[0]),
                range: "[0, inf)",
            });
        }
    }
    let planes = (0..n)
        .map(|i| {
            // The inward normal is the edge turned towards the interior.
            let d = edge(i);
            let normal = [-winding * d[1], winding * d[0]];
            let a = vertices[i];
            let length = d[0].hypot(d[1]);
            HalfPlane::new(normal, -(normal[0] * a[0] + normal[1] * a[1]) - inset * length)
        })
        .collect::<Result<Vec<_>, _>>()?;
    if nearest_inside(&planes, vertices[0], 0.0).is_none() {
        return Err(CbfError::OutOfRange {
            what: "foothold inset (leaves no polygon)",
            value: inset,
            range: "smaller",
        });
    }
    Ok(planes)
}

/// How deep `p` is inside the half-planes \[m\]: the smallest `normal · p + offset`,
/// negative outside (by how far past the most violated edge); `+inf` with no edges.
pub fn depth(edges: &[HalfPlane], p: [f64; 2]) -> f64 {
    edges.iter().map(|e| e.normal[0] * p[0] + e.normal[1] * p[1] + e.offset).fold(f64::INFINITY, f64::min)
}

/// The point nearest `p` of the half-planes' intersection shrunk by `margin` (every
/// `normal · q + offset ≥ margin`), exactly: `p` itself if it is in, else the nearest
/// point of the feasible part of some edge line. `None` if the shrunk set is empty (or
/// unbounded away from every edge, which a polygon is not). O(n²) in the edges, no
/// allocation.
pub fn nearest_inside(edges: &[HalfPlane], p: [f64; 2], margin: f64) -> Option<[f64; 2]> {
    let h = |e: &HalfPlane, q: [f64; 2]| e.normal[0] * q[0] + e.normal[1] * q[1] + e.offset - margin;
    if edges.iter().all(|e| h(e, p) >= 0.0) {
        return Some(p);
    }
    let mut best: Option<([f64; 2], f64)> = None;
    for (i, e) in edges.iter().enumerate() {
        // Edge i's line: q(t) = foot + t * along, with foot the projection of p.
        let (n, along) = ([e.normal[0], e.normal[1]], [-e.normal[1], e.normal[0]]);
        let miss = h(e, p);
        let foot = [p[0] - miss * n[0], p[1] - miss * n[1]];
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for (j, other) in edges.iter().enumerate() {
            if j == i {
                continue;
            }
            // h_j(q(t)) = h_j(foot) + t * (normal_j · along) >= 0.
            let (at_foot, slope) = (h(other, foot), other.normal[0] * along[0] + other.normal[1] * along[1]);
            if slope.abs() <= 1e-15 {
                if at_foot < -FEASIBLE {
                    (lo, hi) = (1.0, 0.0);
                    break;
                }
            } else if slope > 0.0 {
                lo = lo.max(-at_foot / slope);
            } else {
                hi = hi.min(-at_foot / slope);
            }
        }
        if lo > hi + FEASIBLE {
            continue;
        }
        let t = 0.0f64.clamp(lo, hi.max(lo));
        if !t.is_finite() {
            continue;
        }
        let q = [foot[0] + t * along[0], foot[1] + t * along[1]];
        let d = (q[0] - p[0]).hypot(q[1] - p[1]);
        if best.is_none_or(|(_, b)| d < b) {
            best = Some((q, d));
        }
    }
    best.map(|(q, _)| q)
}

/// What [`Environment::guide_toe`] chose for a swing toe this cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToeGuide {
    /// The toe is inside its foothold: the foothold rows keep it, the pull is off.
    Kept,
    /// The toe is outside: the foothold rows are off and the pull brings it towards
    /// `target` (world xy \[m\]); `outside` is how far past the most violated edge it is
    /// \[m\].
    Pulled {
        /// The point the toe is pulled to: the polygon's nearest point, `margin` inside.
        target: [f64; 2],
        /// How far the toe is outside its foothold \[m\].
        outside: f64,
    },
}

impl Environment {
    /// Choose, for swing leg `leg` whose toe centre is at world xy `toe`, between its
    /// foothold rows (the toe is inside the leg's half-planes: they keep it) and the
    /// foothold pull (it is outside: the rows are switched off, and the pull's target is
    /// the polygon's nearest point `margin` metres inside every edge, or on the polygon
    /// if the polygon is narrower than that). Call it every cycle after
    /// [`set_foothold`](Environment::set_foothold); it does not allocate. A leg without
    /// half-planes is [`ToeGuide::Kept`].
    ///
    /// This switches the leg's foothold rows on or off, overriding
    /// [`set_swing`](Environment::set_swing) for that leg; use it for swinging legs only.
    ///
    /// # Errors
    /// `leg >= 6`, a toe outside the state's domain ([`STATE_LIMIT`](cbfgen::system::STATE_LIMIT))
    /// or not finite, a non-finite or negative margin, or half-planes with no common point
    /// (nothing to pull towards). The environment is unchanged then.
    pub fn guide_toe(&mut self, leg: usize, toe: [f64; 2], margin: f64) -> Result<ToeGuide, CbfError> {
        let len = self.foothold.len();
        if leg >= len {
            return Err(CbfError::NoSuchIndex { what: "leg", index: leg, len });
        }
        // Within the state's domain: a toe further out would make the pull's direction
        // overflow to zero length.
        system::coordinate("toe x", toe[0])?;
        system::coordinate("toe y", toe[1])?;
        finite("foothold pull margin", margin)?;
        if margin < 0.0 {
            return Err(CbfError::OutOfRange { what: "foothold pull margin", value: margin, range: "[0, inf)" });
        }
        let edges = self.foothold[leg].as_slice();
        let inside = depth(edges, toe);
        if inside >= 0.0 {
            self.foothold[leg].set_enabled(true);
            self.foothold_pull[leg] = [None];
            return Ok(ToeGuide::Kept);
        }
        let target = nearest_inside(edges, toe, margin).or_else(|| nearest_inside(edges, toe, 0.0)).ok_or(
            CbfError::OutOfRange {
                what: "foothold polygon (its half-planes share no point)",
                value: 0.0,
                range: "non-empty",
            },
        )?;
        let (dx, dy) = (target[0] - toe[0], target[1] - toe[1]);
        let distance = dx.hypot(dy);
        // Outside means at least one edge is violated, so the target is a positive distance away.
        let pull = FootholdPullParams { target: target.into(), direction: [dx / distance, dy / distance].into() };
        self.foothold[leg].set_enabled(false);
        self.foothold_pull[leg] = [Some(pull)];
        Ok(ToeGuide::Pulled { target, outside: -inside })
    }

    /// The foothold pull on leg `leg`, if it is on.
    ///
    /// # Panics
    /// If `leg >= 6`.
    pub fn foothold_pull(&self, leg: usize) -> Option<&FootholdPullParams> {
        self.foothold_pull[leg][0].as_ref()
    }
}
