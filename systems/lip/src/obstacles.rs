//! Rectangular obstacles and the half-plane each one becomes for a step (LDCBF).
//!
//! At the start of a step, for the CoM at `p` and each obstacle, take the boundary point
//! `c` closest to `p` and the unit normal `η` pointing from the obstacle towards the free
//! side. The barrier for that step is the half-plane
//!
//! ```text
//! h(p) = ηᵀ (p − c) − δ ≥ 0
//! ```
//!
//! which is linear in `p` because `η` and `c` are frozen for the step. It lies inside the
//! true free space (a rectangle is convex, so it sits wholly on the far side of the
//! tangent line through `c`), and `h ≥ 0` keeps the CoM at least `δ` from the obstacle.
//!
//! # Two normals
//! [`BarrierForm::UnitNormal`] (the default) normalises `η`, so `h` is a distance in metres
//! and `δ` a clearance. The report's own `η = x − c` is unnormalised
//! ([`BarrierForm::ReportNormal`]): its `h = ‖x − c‖ · (distance past the line) − δ` is in
//! m², `δ` too, and at the CoM itself `h ≥ 0` reads `‖x − c‖ ≥ √δ`. The planned steps see a
//! margin of `δ/‖x − c‖` along the line, which shrinks as the robot is farther away.
//!
//! # CoM on or inside an obstacle
//! `η = (p − c)/‖p − c‖` is undefined there. We then use the outward normal of the edge
//! nearest to `p` (ties: the first of −x, +x, −y, +y), with `c` the projection of `p` onto
//! that edge, so `h < 0` and the barrier condition `h_{k+1} ≥ (1 − γ) h_k` pushes the CoM
//! out of the obstacle instead of failing. [`HalfPlane::inside`] flags this case.

use cbfgen::error::{finite, CbfError};

/// Which normal `η` the barrier's half-plane uses (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BarrierForm {
    /// `η = (x − c)/‖x − c‖`: `h` and `δ` in metres (ours).
    #[default]
    UnitNormal,
    /// `η = x − c`, as the report writes it: `h` and `δ` in m².
    ReportNormal,
}

impl BarrierForm {
    /// `"unit"` or `"report"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::UnitNormal => "unit",
            Self::ReportNormal => "report",
        }
    }
}

/// An axis-aligned rectangle in the global frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rectangle {
    /// Lower-left corner \[m\].
    pub min: [f64; 2],
    /// Upper-right corner \[m\].
    pub max: [f64; 2],
}

impl Rectangle {
    /// The rectangle `[x0, x1] × [y0, y1]`.
    ///
    /// # Errors
    /// A non-finite coordinate, or `x1 ≤ x0` / `y1 ≤ y0`.
    pub fn new(x0: f64, x1: f64, y0: f64, y1: f64) -> Result<Self, CbfError> {
        for v in [x0, x1, y0, y1] {
            finite("rectangle corner", v)?;
        }
        if x1 <= x0 || y1 <= y0 {
            return Err(CbfError::OutOfRange { what: "rectangle extent", value: (x1 - x0).min(y1 - y0), range: "> 0" });
        }
        Ok(Self { min: [x0, y0], max: [x1, y1] })
    }

    /// Centre \[m\].
    pub fn center(&self) -> [f64; 2] {
        [0.5 * (self.min[0] + self.max[0]), 0.5 * (self.min[1] + self.max[1])]
    }

    /// Euclidean distance from `p` to the rectangle (0 on or inside it).
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        let dx = (self.min[0] - p[0]).max(p[0] - self.max[0]).max(0.0);
        let dy = (self.min[1] - p[1]).max(p[1] - self.max[1]).max(0.0);
        dx.hypot(dy)
    }

    /// Signed distance: [`Rectangle::distance`] outside, minus the depth to the nearest
    /// edge inside (so a point on an edge is 0 and one inside is negative).
    pub fn signed_distance(&self, p: [f64; 2]) -> f64 {
        let depth = (p[0] - self.min[0]).min(self.max[0] - p[0]).min(p[1] - self.min[1]).min(self.max[1] - p[1]);
        if depth > 0.0 {
            -depth
        } else {
            self.distance(p)
        }
    }

    /// The barrier half-plane for a CoM at global `p` with margin `delta`, in the given
    /// form (see the module docs, also for the inside case, where both forms use the
    /// nearest edge's unit normal: the report's `x − c` is zero there).
    pub fn half_plane(&self, p: [f64; 2], delta: f64, form: BarrierForm) -> HalfPlane {
        let clamped = [p[0].clamp(self.min[0], self.max[0]), p[1].clamp(self.min[1], self.max[1])];
        let d = [p[0] - clamped[0], p[1] - clamped[1]];
        let dist = d[0].hypot(d[1]);
        if dist > 0.0 {
            let scale = match form {
                BarrierForm::UnitNormal => 1.0 / dist,
                BarrierForm::ReportNormal => 1.0,
            };
            return HalfPlane { normal: [d[0] * scale, d[1] * scale], point: clamped, delta, inside: false };
        }
        // On or inside: leave through the nearest edge.
        let gaps = [p[0] - self.min[0], self.max[0] - p[0], p[1] - self.min[1], self.max[1] - p[1]];
        let mut nearest = 0;
        for (i, g) in gaps.iter().enumerate() {
            if *g < gaps[nearest] {
                nearest = i;
            }
        }
        let (normal, point) = match nearest {
            0 => ([-1.0, 0.0], [self.min[0], p[1]]),
            1 => ([1.0, 0.0], [self.max[0], p[1]]),
            2 => ([0.0, -1.0], [p[0], self.min[1]]),
            _ => ([0.0, 1.0], [p[0], self.max[1]]),
        };
        HalfPlane { normal, point, delta, inside: true }
    }
}

/// The linear barrier `h(p) = ηᵀ (p − c) − δ` of one obstacle for one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfPlane {
    /// Normal `η`, pointing away from the obstacle (unit, or `x − c` in the report's form).
    pub normal: [f64; 2],
    /// Boundary point `c` \[m\].
    pub point: [f64; 2],
    /// Margin `δ` \[m\].
    pub delta: f64,
    /// The CoM was on or inside the obstacle when this was built.
    pub inside: bool,
}

impl HalfPlane {
    /// `h(p)`.
    pub fn h(&self, p: [f64; 2]) -> f64 {
        self.normal[0] * (p[0] - self.point[0]) + self.normal[1] * (p[1] - self.point[1]) - self.delta
    }

    /// The same half-plane expressed in `frame`'s local coordinates.
    pub fn to_local(&self, frame: &super::model::Frame) -> HalfPlane {
        HalfPlane { normal: frame.vector_to_local(self.normal), point: frame.point_to_local(self.point), ..*self }
    }
}
