//! Step-to-step 3D-LIP dynamics with heading, and the frames the robot plans in.
//!
//! With the CoM at constant height `H`, each horizontal axis obeys `p̈ = β² (p − f)`,
//! `β = √(g/H)`, while the stance foot `f` stays put. Over one step of fixed duration `T`
//! the closed form is, per axis,
//!
//! ```text
//! [p; v]_{k+1} = A_d [p; v]_k + B_d f_k
//! A_d = [cosh βT, sinh βT / β; β sinh βT, cosh βT],   B_d = [1 − cosh βT; −β sinh βT]
//! ```
//!
//! and the heading integrates the turning rate, `θ_{k+1} = θ_k + ω_k T`. Stacking both
//! axes and the heading gives `x_{k+1} = A_L x_k + B_L u_k` with `x = [p_x, v_x, p_y, v_y, θ]`
//! and `u = [f_x, f_y, ω]` (paper eqs. 2–6).
//!
//! The pendulum equation is the same along any pair of orthogonal horizontal axes and
//! under any shift of origin, so the dynamics hold unchanged in every local frame; only the
//! conversion between frames ([`Frame`]) needs the heading.

use cbfgen::error::{finite, positive, CbfError};

/// State `[p_x, v_x, p_y, v_y, θ]` in some frame.
pub type LipState = [f64; 5];
/// Input `[f_x, f_y, ω]` in the same frame as the state.
pub type LipInput = [f64; 3];

/// Gravitational acceleration [m/s²].
pub const GRAVITY: f64 = 9.81;

/// A 3D-LIP: CoM height and step duration, and the closed-form step matrices they give.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lip {
    /// CoM height `H` \[m\].
    pub height: f64,
    /// Step duration `T` \[s\].
    pub step_time: f64,
    /// `β = √(g/H)` [1/s].
    pub beta: f64,
    /// Per-axis `A_d` (row-major).
    pub a_d: [[f64; 2]; 2],
    /// Per-axis `B_d`.
    pub b_d: [f64; 2],
}

impl Lip {
    /// The step matrices for CoM height `height` and step duration `step_time`.
    ///
    /// # Errors
    /// A non-finite or non-positive height or step time.
    pub fn new(height: f64, step_time: f64) -> Result<Self, CbfError> {
        positive("CoM height", height)?;
        positive("step time", step_time)?;
        Ok(Self::from_checked(height, step_time))
    }

    /// [`Lip::new`] for values already known to be finite and positive.
    pub(crate) fn from_checked(height: f64, step_time: f64) -> Self {
        let beta = (GRAVITY / height).sqrt();
        let (ch, sh) = ((beta * step_time).cosh(), (beta * step_time).sinh());
        Self { height, step_time, beta, a_d: [[ch, sh / beta], [beta * sh, ch]], b_d: [1.0 - ch, -beta * sh] }
    }

    /// One axis over one step: `[p, v]` with the stance foot at `f`.
    pub fn axis_step(&self, p: f64, v: f64, f: f64) -> (f64, f64) {
        let [[a00, a01], [a10, a11]] = self.a_d;
        (a00 * p + a01 * v + self.b_d[0] * f, a10 * p + a11 * v + self.b_d[1] * f)
    }

    /// `x_{k+1} = A_L x_k + B_L u_k`.
    pub fn step(&self, x: &LipState, u: &LipInput) -> LipState {
        let (px, vx) = self.axis_step(x[0], x[1], u[0]);
        let (py, vy) = self.axis_step(x[2], x[3], u[1]);
        [px, vx, py, vy, x[4] + u[2] * self.step_time]
    }
}

/// A planar frame: where its origin is and which way its x-axis points, in the global frame.
///
/// This is the report's homogeneous transform `T_k = [R(θ) o; 0 1]` (section 3.1): points
/// (CoM, feet, obstacle corners) map with rotation and shift, velocities and directions
/// with the rotation alone, and headings add.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Origin in global coordinates \[m\].
    pub origin: [f64; 2],
    /// Angle of the frame's x-axis from the global x-axis \[rad\].
    pub heading: f64,
}

impl Frame {
    /// The global frame.
    pub const GLOBAL: Frame = Frame { origin: [0.0, 0.0], heading: 0.0 };

    /// A frame with origin `origin` and x-axis at `heading`.
    ///
    /// # Errors
    /// A non-finite coordinate or heading.
    pub fn new(origin: [f64; 2], heading: f64) -> Result<Self, CbfError> {
        finite("frame origin x", origin[0])?;
        finite("frame origin y", origin[1])?;
        finite("frame heading", heading)?;
        Ok(Self { origin, heading })
    }

    /// Rotate a local vector into global axes: `R(θ) v`.
    pub fn vector_to_global(&self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.heading.sin_cos();
        [c * v[0] - s * v[1], s * v[0] + c * v[1]]
    }

    /// Rotate a global vector into local axes: `R(θ)ᵀ v`.
    pub fn vector_to_local(&self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.heading.sin_cos();
        [c * v[0] + s * v[1], -s * v[0] + c * v[1]]
    }

    /// A local point in global coordinates: `T [p; 1]`.
    pub fn point_to_global(&self, p: [f64; 2]) -> [f64; 2] {
        let r = self.vector_to_global(p);
        [r[0] + self.origin[0], r[1] + self.origin[1]]
    }

    /// A global point in local coordinates: `T⁻¹ [p; 1]`.
    pub fn point_to_local(&self, p: [f64; 2]) -> [f64; 2] {
        self.vector_to_local([p[0] - self.origin[0], p[1] - self.origin[1]])
    }

    /// A local state in global coordinates (positions shifted and rotated, velocities
    /// rotated, heading added).
    pub fn state_to_global(&self, x: &LipState) -> LipState {
        let p = self.point_to_global([x[0], x[2]]);
        let v = self.vector_to_global([x[1], x[3]]);
        [p[0], v[0], p[1], v[1], self.heading + x[4]]
    }

    /// A global state in local coordinates; the inverse of [`Frame::state_to_global`].
    pub fn state_to_local(&self, x: &LipState) -> LipState {
        let p = self.point_to_local([x[0], x[2]]);
        let v = self.vector_to_local([x[1], x[3]]);
        [p[0], v[0], p[1], v[1], x[4] - self.heading]
    }

    /// The frame a robot plans its next step in after reaching local state `x`: origin at
    /// its CoM, x-axis along its heading (`θ_glob ← θ_glob + θ_loc`).
    pub fn following(&self, x: &LipState) -> Frame {
        Frame { origin: self.point_to_global([x[0], x[2]]), heading: self.heading + x[4] }
    }
}
