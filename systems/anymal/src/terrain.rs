//! A segmented terrain and the foothold regions the MPC takes from it (seed 004, IV-D):
//! planar convex patches; for a contact phase, the patch nearest where the gait would put
//! the foot at mid-stance; inside it, the convex polygon shrunk by a margin, as the
//! half-spaces of eqs. 23–25 ([`Region`]).
//!
//! Patches are convex (a stepping stone's top, a step's tread): the seed grows a convex
//! polygon inside a non-convex segment from the projected reference point, which these do
//! not need, and a non-convex patch is refused rather than approximated silently.
//!
//! ```
//! use cbfgen_anymal::terrain::{Patch, Terrain};
//!
//! // Two 30 cm stones, 10 cm apart, the second 5 cm higher.
//! let terrain = Terrain::new(vec![
//!     Patch::rectangle([0.0, 0.0, 0.0], [0.15, 0.15], 0.0)?,
//!     Patch::rectangle([0.4, 0.0, 0.05], [0.15, 0.15], 0.0)?,
//! ])?;
//! let (stone, _) = terrain.nearest([0.35, 0.02, 0.1]).unwrap();
//! assert_eq!(stone, 1);
//! let region = terrain.patches()[stone].region(0.02)?;
//! assert!(region.margin([0.4, 0.0, 0.08]) > 0.12); // well inside the shrunk stone
//! assert!(region.margin([0.26, 0.0, 0.08]) < 0.0); // within 2 cm of its edge: outside
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use cbfgen::error::{finite, within, CbfError};

use crate::gait::Trot;
use crate::mpc::{Region, MAX_SIDES};
use crate::vec3::{cross, dot, norm, sub};

/// How far a vertex may lie off its patch's plane \[m\].
pub const PLANARITY: f64 = 1e-6;

/// A planar convex patch of terrain: its vertices in order around it (either way), the
/// plane's upward unit normal.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    vertices: Vec<[f64; 3]>,
    normal: [f64; 3],
}

impl Patch {
    /// A patch from its vertices, in order around it.
    ///
    /// # Errors
    /// Fewer than 3 or more than [`MAX_SIDES`] vertices, a non-finite one, no area, a
    /// vertex off the plane by more than [`PLANARITY`], a plane steeper than vertical, or a
    /// polygon that is not convex.
    pub fn new(vertices: &[[f64; 3]]) -> Result<Self, CbfError> {
        let n = vertices.len();
        if !(3..=MAX_SIDES).contains(&n) {
            return Err(CbfError::OutOfRange { what: "patch vertices", value: n as f64, range: "[3, MAX_SIDES]" });
        }
        for v in vertices.iter().flatten() {
            finite("patch vertex", *v)?;
        }
        // Newell's normal: robust for any simple polygon, its length twice the area.
        let mut normal = [0.0; 3];
        for (k, a) in vertices.iter().enumerate() {
            let b = &vertices[(k + 1) % n];
            normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
            normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
            normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
        }
        let area = norm(&normal) / 2.0;
        if area <= 1e-8 {
            return Err(CbfError::OutOfRange { what: "patch area [m²]", value: area, range: "(1e-8, ∞)" });
        }
        let mut vertices = vertices.to_vec();
        normal.iter_mut().for_each(|v| *v /= 2.0 * area);
        if normal[2] < 0.0 {
            // Given clockwise seen from above: keep them counter-clockwise about the upward normal.
            vertices.reverse();
            normal.iter_mut().for_each(|v| *v = -*v);
        }
        if normal[2] <= 0.0 {
            return Err(CbfError::OutOfRange { what: "patch normal z", value: normal[2], range: "(0, 1]" });
        }
        let origin = vertices[0];
        for v in &vertices {
            let off = dot(&sub(v, &origin), &normal).abs();
            if off > PLANARITY {
                return Err(CbfError::OutOfRange {
                    what: "patch vertex off its plane [m]",
                    value: off,
                    range: "[0, 1e-6]",
                });
            }
        }
        for k in 0..n {
            let (a, b, c) = (&vertices[k], &vertices[(k + 1) % n], &vertices[(k + 2) % n]);
            let turn = dot(&cross(&sub(b, a), &sub(c, b)), &normal);
            if turn <= 0.0 {
                return Err(CbfError::OutOfRange {
                    what: "patch turn at a vertex (convex: > 0)",
                    value: turn,
                    range: "(0, ∞)",
                });
            }
        }
        Ok(Self { vertices, normal })
    }

    /// A horizontal rectangle centred at `center` with half-sizes `half` along its own
    /// axes, turned `yaw` about z.
    ///
    /// # Errors
    /// Non-positive or non-finite sizes, a non-finite centre or yaw.
    pub fn rectangle(center: [f64; 3], half: [f64; 2], yaw: f64) -> Result<Self, CbfError> {
        for h in half {
            within("patch half-size [m]", h, 1e-6, 1e3, "[1e-6, 1e3]")?;
        }
        let (c, s) = (finite("patch yaw", yaw)?.cos(), yaw.sin());
        let corner = |u: f64, v: f64| [center[0] + c * u - s * v, center[1] + s * u + c * v, center[2]];
        let (a, b) = (half[0], half[1]);
        Self::new(&[corner(-a, -b), corner(a, -b), corner(a, b), corner(-a, b)])
    }

    /// The vertices, counter-clockwise about the normal.
    pub fn vertices(&self) -> &[[f64; 3]] {
        &self.vertices
    }

    /// The plane's upward unit normal.
    pub fn normal(&self) -> [f64; 3] {
        self.normal
    }

    /// Each edge's outward unit normal within the plane and its offset: the patch is
    /// `{ c on the plane : e · c ≤ d for every edge }`.
    fn edges(&self) -> impl Iterator<Item = ([f64; 3], f64)> + '_ {
        let n = self.vertices.len();
        (0..n).map(move |k| {
            let (a, b) = (&self.vertices[k], &self.vertices[(k + 1) % n]);
            let along = sub(b, a);
            let mut out = cross(&along, &self.normal);
            let length = norm(&out);
            out.iter_mut().for_each(|v| *v /= length);
            (out, dot(&out, a))
        })
    }

    /// The height of the plane above `(x, y)` \[m\].
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        let (o, n) = (&self.vertices[0], &self.normal);
        o[2] - (n[0] * (x - o[0]) + n[1] * (y - o[1])) / n[2]
    }

    /// The distance from `p` to the patch (the polygon, not its plane) \[m\].
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        let off = dot(&sub(&p, &self.vertices[0]), &self.normal);
        if self.edges().all(|(e, d)| dot(&e, &p) <= d) {
            return off.abs();
        }
        let n = self.vertices.len();
        (0..n)
            .map(|k| {
                let (a, b) = (&self.vertices[k], &self.vertices[(k + 1) % n]);
                let ab = sub(b, a);
                let s = (dot(&sub(&p, a), &ab) / dot(&ab, &ab)).clamp(0.0, 1.0);
                norm(&sub(&p, &[a[0] + s * ab[0], a[1] + s * ab[1], a[2] + s * ab[2]]))
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The patch shrunk by `margin` \[m\] on every edge, as a foothold region: one
    /// half-space per edge (normal within the plane, so a foot centre above the surface
    /// is judged by where it is over it), and the plane's normal for the friction cone.
    ///
    /// # Errors
    /// A negative or non-finite margin, or one that reaches the patch's centroid (what
    /// remains could be empty).
    pub fn region(&self, margin: f64) -> Result<Region, CbfError> {
        within("foothold margin [m]", margin, 0.0, 10.0, "[0, 10]")?;
        let mut sides = [([0.0; 3], 0.0); MAX_SIDES];
        for (slot, (e, d)) in sides.iter_mut().zip(self.edges()) {
            *slot = (e, d - margin);
        }
        let count = self.vertices.len();
        let inradius = self.inradius();
        if margin >= inradius {
            return Err(CbfError::OutOfRange {
                what: "foothold margin [m]",
                value: margin,
                range: "below the patch's inradius",
            });
        }
        Ok(Region {
            sides,
            count,
            normal: self.normal,
            surface: dot(&self.normal, &self.vertices[0]),
            centre: Some(self.centroid()),
        })
    }

    /// The radius of the largest circle inside the patch (a lower bound from its
    /// centroid, exact for a rectangle) \[m\].
    fn inradius(&self) -> f64 {
        let centroid = self.centroid();
        self.edges().map(|(e, d)| d - dot(&e, &centroid)).fold(f64::INFINITY, f64::min)
    }

    /// The mean of the vertices.
    fn centroid(&self) -> [f64; 3] {
        let n = self.vertices.len() as f64;
        std::array::from_fn(|i| self.vertices.iter().map(|v| v[i]).sum::<f64>() / n)
    }
}

/// Segmented terrain: the patches feet may stand on.
#[derive(Debug, Clone, PartialEq)]
pub struct Terrain {
    patches: Vec<Patch>,
}

impl Terrain {
    /// # Errors
    /// No patches.
    pub fn new(patches: Vec<Patch>) -> Result<Self, CbfError> {
        if patches.is_empty() {
            return Err(CbfError::OutOfRange { what: "terrain patches", value: 0.0, range: "[1, ∞)" });
        }
        Ok(Self { patches })
    }

    /// The patches.
    pub fn patches(&self) -> &[Patch] {
        &self.patches
    }

    /// The patch nearest `p` and its distance (the first of equals).
    pub fn nearest(&self, p: [f64; 3]) -> Option<(usize, f64)> {
        self.patches.iter().enumerate().map(|(k, patch)| (k, patch.distance(p))).fold(None, |best, (k, d)| match best {
            Some((_, b)) if b <= d => best,
            _ => Some((k, d)),
        })
    }
}

/// The foothold regions of a terrain for a gait (seed 004, IV-D): for a foot at a time,
/// the patch nearest where the gait puts it at mid-stance of the stance it is in (or lands
/// in), shrunk by the margin. Every patch's region is built once, so a lookup cannot fail.
#[derive(Debug, Clone)]
pub struct Footholds {
    terrain: Terrain,
    regions: Vec<Region>,
    margin: f64,
}

impl Footholds {
    /// # Errors
    /// A margin that [`Patch::region`] refuses on any patch.
    pub fn new(terrain: Terrain, margin: f64) -> Result<Self, CbfError> {
        let regions = terrain.patches.iter().map(|p| p.region(margin)).collect::<Result<Vec<_>, _>>()?;
        Ok(Self { terrain, regions, margin })
    }

    /// The terrain.
    pub fn terrain(&self) -> &Terrain {
        &self.terrain
    }

    /// The margin each patch was shrunk by \[m\].
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// The patch selected for foot `foot` at time `t` on `trot`.
    pub fn patch_for(&self, trot: &Trot, foot: usize, t: f64) -> usize {
        self.terrain.nearest(trot.foothold_for(foot, t)).map_or(0, |(k, _)| k)
    }

    /// The region for foot `foot` at time `t` on `trot`.
    pub fn region(&self, trot: &Trot, foot: usize, t: f64) -> Region {
        self.regions[self.patch_for(trot, foot, t)]
    }
}
