//! A kinematic tree's rigid-body dynamics at run time, from numbers: the joint-space mass
//! matrix M(q) (the composite-rigid-body algorithm) and the forces C(q, v) v + g(q) that
//! hold it at zero acceleration (the recursive Newton–Euler algorithm), as Featherstone's
//! *Rigid Body Dynamics Algorithms* (ch. 5–6) and Pinocchio's `crba` and
//! `nonLinearEffects` compute them.
//!
//! A spec's `RigidBodyDynamics` (`symbolic/dynamics.py`) writes the same quantities as
//! expressions; unrolled, a floating quadruped's M and bias are ten thousand lines of
//! straight-line code. Here the tree is data — per body its parent, its joint's placement,
//! axis and kind, and its inertial — and the algorithms walk it, on the stack: no
//! allocation, no panic, O(bodies × depth) work.
//!
//! Conventions are the symbolic model's: every body's quantities are in its own frame, a
//! motion is (ω, v) — angular velocity and the velocity of the point at the frame's
//! origin — and a force (n, f), the moment about the origin and the force. Gravity enters
//! as an upward acceleration of the root. A floating root's six velocities come first,
//! ordered as Pinocchio's free flyer: the root's linear then angular velocity, both in its
//! own frame; their generalized forces are the force, then the moment, on the root.
//!
//! A pendulum of mass m on a massless rod of length l, turning about y, hangs along −z:
//! M = m l², and gravity pulls it back with m g l sin q.
//!
//! ```
//! use cbfgen::rigid_body::{Body, Joint, Root, Tree};
//!
//! let (m, l, g) = (2.0, 0.5, 9.81);
//! let bodies = [
//!     Body::ROOT,
//!     Body {
//!         joint: Joint::Revolute { axis: [0.0, 1.0, 0.0], coordinate: 0, velocity: 0 },
//!         mass: m,
//!         com: [0.0, 0.0, -l],
//!         ..Body::ROOT
//!     },
//! ];
//! let tree = Tree { bodies: &bodies, root: Root::Fixed, gravity: [0.0, 0.0, -g] };
//! let q = [0.3];
//! let mass: [[f64; 1]; 1] = tree.mass_matrix(&q);
//! let bias: [f64; 1] = tree.bias(&q, None, &[0.0]);
//! assert!((mass[0][0] - m * l * l).abs() < 1e-12);
//! assert!((bias[0] - m * g * l * q[0].sin()).abs() < 1e-12);
//! ```

use crate::scalar::Scalar;

/// How a body moves relative to its parent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Joint {
    /// Not at all: a fixed joint, or one held still (its value folded into the placement).
    Fixed,
    /// Turns about `axis` (a unit vector in the body's frame) by `q[coordinate]` \[rad\], at
    /// the rate `v[velocity]`.
    Revolute {
        /// The axis, in the body's frame (unit).
        axis: [f64; 3],
        /// Its index in the joint coordinates `q`.
        coordinate: usize,
        /// Its index in the generalized velocities `v`.
        velocity: usize,
    },
    /// Slides along `axis` (a unit vector in the body's frame) by `q[coordinate]` \[m\], at
    /// the rate `v[velocity]`.
    Prismatic {
        /// The axis, in the body's frame (unit).
        axis: [f64; 3],
        /// Its index in the joint coordinates `q`.
        coordinate: usize,
        /// Its index in the generalized velocities `v`.
        velocity: usize,
    },
}

/// One body of a tree: where its joint sits on its parent, how it moves, its inertial.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// The parent's index in the tree (always before this body); unused for the root.
    pub parent: usize,
    /// The body's frame in its parent's at zero joint coordinate: its axes as columns,
    /// row by row.
    pub rotation: [f64; 9],
    /// The body's origin in its parent's frame at zero joint coordinate \[m\].
    pub origin: [f64; 3],
    /// How it moves relative to its parent.
    pub joint: Joint,
    /// Mass \[kg\].
    pub mass: f64,
    /// Centre of mass, in the body's frame \[m\].
    pub com: [f64; 3],
    /// Rotational inertia about the centre of mass, in the body's frame, row by row \[kg m²\].
    pub inertia: [f64; 9],
}

impl Body {
    /// A massless body at its parent's origin with its parent's axes, fixed: the root's
    /// entry, and what `..Body::ROOT` fills the rest of a body with.
    pub const ROOT: Body = Body {
        parent: 0,
        rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        origin: [0.0; 3],
        joint: Joint::Fixed,
        mass: 0.0,
        com: [0.0; 3],
        inertia: [0.0; 9],
    };
}

/// How the tree's root (body 0) moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Root {
    /// It is the world: only the joints move.
    Fixed,
    /// It moves freely: velocities 0..6 are its twist in its own frame, linear then angular.
    Floating,
}

/// A tree of [`Body`]s, each after its parent, and the world's gravity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tree<'a> {
    /// The bodies, root first, every parent before its children.
    pub bodies: &'a [Body],
    /// Whether the root is the world or moves freely.
    pub root: Root,
    /// Gravity in the world \[m/s²\] (Pinocchio's: (0, 0, −9.81)).
    pub gravity: [f64; 3],
}

type Vec3<S> = [S; 3];
/// (angular, linear) for a motion; (moment, force) for a force.
type Spatial<S> = (Vec3<S>, Vec3<S>);
/// (rotation row by row, origin): a body's frame in its parent's.
type Placement<S> = ([S; 9], Vec3<S>);

/// The most bodies a tree may have: the algorithms keep per-body values on the stack.
pub const MAX_BODIES: usize = 64;

fn zero<S: Scalar>() -> S {
    S::from(0.0)
}

impl Tree<'_> {
    /// Why the tree cannot be walked: a parent not before its child, an index past `q`
    /// (`coordinates` entries) or `v` (`velocities`), a root that is not [`Body::ROOT`]'s
    /// kind of joint, a floating root without its six velocities, more than
    /// [`MAX_BODIES`] bodies, or a non-finite number. `None` when it can. A `const`, so a
    /// generated tree is checked when it compiles.
    pub const fn defect(&self, coordinates: usize, velocities: usize) -> Option<&'static str> {
        let bodies = self.bodies;
        if bodies.is_empty() || bodies.len() > MAX_BODIES {
            return Some("a tree has 1 to MAX_BODIES bodies");
        }
        if !matches!(bodies[0].joint, Joint::Fixed) {
            return Some("the root (body 0) has no joint: a floating root is Root::Floating");
        }
        let base = match self.root {
            Root::Fixed => 0,
            Root::Floating => 6,
        };
        if velocities < base {
            return Some("a floating root's six velocities come first");
        }
        let mut i = 0;
        while i < bodies.len() {
            let b = &bodies[i];
            if i > 0 && b.parent >= i {
                return Some("every body's parent comes before it");
            }
            match b.joint {
                Joint::Fixed => {}
                Joint::Revolute { coordinate, velocity, .. } | Joint::Prismatic { coordinate, velocity, .. } => {
                    if coordinate >= coordinates || velocity >= velocities || velocity < base {
                        return Some("a joint's coordinate or velocity index is out of range");
                    }
                }
            }
            if !b.mass.is_finite() || b.mass < 0.0 {
                return Some("a body's mass is negative or not finite");
            }
            let axis = match b.joint {
                Joint::Fixed => [0.0; 3],
                Joint::Revolute { axis, .. } | Joint::Prismatic { axis, .. } => axis,
            };
            if !(all_finite(&b.rotation)
                && all_finite(&b.origin)
                && all_finite(&b.com)
                && all_finite(&b.inertia)
                && all_finite(&axis))
            {
                return Some("a body's placement, axis or inertial is not finite");
            }
            i += 1;
        }
        None
    }

    /// The joint-space mass matrix M(q), `N` × `N` in velocity order; `q` holds the
    /// joints' coordinates. A tree with a [`defect`](Self::defect) gives NaN throughout.
    ///
    /// On any [`Scalar`]: on `f64` the matrix at `q`; on
    /// [`Interval`](crate::interval::Interval)s an enclosure of every matrix over the box
    /// `q` (what certifies a torque-controlled robot between the samples).
    pub fn mass_matrix<S: Scalar, const N: usize>(&self, q: &[S]) -> [[S; N]; N] {
        let mut m = [[zero::<S>(); N]; N];
        let n = self.bodies.len();
        if self.defect(q.len(), N).is_some() {
            return [[S::from(f64::NAN); N]; N];
        }
        let mut placement = [([zero::<S>(); 9], [zero::<S>(); 3]); MAX_BODIES];
        // Composite inertias, each as a 6 × 6 matrix on (ω, v) at its body's origin.
        let mut composite = [[[zero::<S>(); 6]; 6]; MAX_BODIES];
        for i in 0..n {
            placement[i] = self.placement(i, q);
            composite[i] = spatial_inertia(&self.bodies[i]);
        }
        for i in (1..n).rev() {
            let (r, p) = &placement[i];
            let carried = to_parent_inertia(&composite[i], r, p);
            let parent = &mut composite[self.bodies[i].parent];
            for (row, add) in parent.iter_mut().zip(&carried) {
                for (a, b) in row.iter_mut().zip(add) {
                    *a = *a + *b;
                }
            }
        }
        for (i, (body, inertia)) in self.bodies.iter().zip(&composite).enumerate().skip(1) {
            let Some((s, column)) = subspace::<S>(&body.joint) else { continue };
            // F = I_c S, carried up the tree; M[j][i] = S_j · F at every moving ancestor.
            let mut force = [zero::<S>(); 6];
            for (f, row) in force.iter_mut().zip(inertia) {
                *f = dot6(row, &s);
            }
            m[column][column] = dot6(&s, &force);
            let mut j = i;
            while j > 0 {
                let (r, p) = &placement[j];
                force = force_to_parent(&force, r, p);
                j = self.bodies[j].parent;
                if let Some((s_j, row)) = subspace::<S>(&self.bodies[j].joint) {
                    m[row][column] = dot6(&s_j, &force);
                    m[column][row] = m[row][column];
                }
            }
            if self.root == Root::Floating {
                // The root's columns: force then moment, in its frame.
                for k in 0..3 {
                    m[k][column] = force[3 + k];
                    m[3 + k][column] = force[k];
                    m[column][k] = m[k][column];
                    m[column][3 + k] = m[3 + k][column];
                }
            }
        }
        if self.root == Root::Floating {
            let c = &composite[0];
            // Free-flyer order (v, ω) against the spatial (ω, v).
            for a in 0..6 {
                for b in 0..6 {
                    m[a][b] = c[(a + 3) % 6][(b + 3) % 6];
                }
            }
        }
        m
    }

    /// C(q, v) v + g(q): the generalized forces at zero acceleration. `base_rotation` is
    /// a floating root's orientation in the world (its axes as columns, row by row), which
    /// gravity is seen through; a fixed root ignores it (None is the identity). On any
    /// [`Scalar`], as [`Tree::mass_matrix`].
    pub fn bias<S: Scalar, const N: usize>(&self, q: &[S], base_rotation: Option<&[S; 9]>, v: &[S; N]) -> [S; N] {
        self.inverse_dynamics(q, base_rotation, v, &[zero::<S>(); N])
    }

    /// The generalized forces τ = M(q) a + C(q, v) v + g(q) (the recursive Newton–Euler
    /// algorithm). A tree with a [`defect`](Self::defect) gives NaN throughout.
    pub fn inverse_dynamics<S: Scalar, const N: usize>(
        &self,
        q: &[S],
        base_rotation: Option<&[S; 9]>,
        v: &[S; N],
        a: &[S; N],
    ) -> [S; N] {
        let n = self.bodies.len();
        if self.defect(q.len(), N).is_some() {
            return [S::from(f64::NAN); N];
        }
        let lift = self.gravity.map(|g| S::from(-g));
        let z = zero::<S>();
        let mut velocity = [([z; 3], [z; 3]); MAX_BODIES];
        let mut acceleration = [([z; 3], [z; 3]); MAX_BODIES];
        let mut force = [([z; 3], [z; 3]); MAX_BODIES];
        let mut placement = [([z; 9], [z; 3]); MAX_BODIES];
        match self.root {
            Root::Fixed => acceleration[0] = ([z; 3], lift),
            Root::Floating => {
                let identity = Body::ROOT.rotation.map(S::from);
                let r = base_rotation.unwrap_or(&identity);
                velocity[0] = ([v[3], v[4], v[5]], [v[0], v[1], v[2]]);
                acceleration[0] = ([a[3], a[4], a[5]], add(&[a[0], a[1], a[2]], &transpose_times(r, &lift)));
            }
        }
        force[0] = body_force(&self.bodies[0], &velocity[0], &acceleration[0]);
        for i in 1..n {
            placement[i] = self.placement(i, q);
            let (r, p) = &placement[i];
            let ((w, lin), (dw, dlin)) = (velocity[self.bodies[i].parent], acceleration[self.bodies[i].parent]);
            let mut w_c = transpose_times(r, &w);
            let mut v_c = transpose_times(r, &add(&lin, &cross(&w, p)));
            let mut dw_c = transpose_times(r, &dw);
            let mut dv_c = transpose_times(r, &add(&dlin, &cross(&dw, p)));
            if let Some((s, k)) = subspace::<S>(&self.bodies[i].joint) {
                let (s_w, s_v) = ([s[0], s[1], s[2]], [s[3], s[4], s[5]]);
                let (jw, jv) = (scale(v[k], &s_w), scale(v[k], &s_v));
                w_c = add(&w_c, &jw);
                v_c = add(&v_c, &jv);
                // a = X a_parent + S a_k + v × (S v_k)
                dw_c = add(&add(&dw_c, &scale(a[k], &s_w)), &cross(&w_c, &jw));
                dv_c = add(&add(&dv_c, &scale(a[k], &s_v)), &add(&cross(&w_c, &jv), &cross(&v_c, &jw)));
            }
            velocity[i] = (w_c, v_c);
            acceleration[i] = (dw_c, dv_c);
            force[i] = body_force(&self.bodies[i], &velocity[i], &acceleration[i]);
        }
        let mut tau = [z; N];
        for i in (1..n).rev() {
            let (moment, f) = force[i];
            if let Some((s, k)) = subspace::<S>(&self.bodies[i].joint) {
                tau[k] = dot6(&s, &[moment[0], moment[1], moment[2], f[0], f[1], f[2]]);
            }
            let (r, p) = &placement[i];
            let f_p = times(r, &f);
            let n_p = add(&times(r, &moment), &cross(p, &f_p));
            let parent = &mut force[self.bodies[i].parent];
            parent.0 = add(&parent.0, &n_p);
            parent.1 = add(&parent.1, &f_p);
        }
        if self.root == Root::Floating {
            let (moment, f) = force[0];
            tau[..3].copy_from_slice(&f);
            tau[3..6].copy_from_slice(&moment);
        }
        tau
    }

    /// Body `i`'s frame in its parent's at `q`: (rotation, origin).
    fn placement<S: Scalar>(&self, i: usize, q: &[S]) -> Placement<S> {
        let b = &self.bodies[i];
        let (rotation, origin) = (b.rotation.map(S::from), b.origin.map(S::from));
        match b.joint {
            Joint::Fixed => (rotation, origin),
            Joint::Revolute { axis, coordinate, .. } => {
                (matmul(&rotation, &axis_rotation(&axis.map(S::from), q[coordinate])), origin)
            }
            Joint::Prismatic { axis, coordinate, .. } => {
                (rotation, add(&origin, &times(&rotation, &scale(q[coordinate], &axis.map(S::from)))))
            }
        }
    }
}

const fn all_finite(values: &[f64]) -> bool {
    let mut i = 0;
    while i < values.len() {
        if !values[i].is_finite() {
            return false;
        }
        i += 1;
    }
    true
}

/// The joint's motion per unit rate, (ω; v) in the body's frame, and its velocity index.
fn subspace<S: Scalar>(joint: &Joint) -> Option<([S; 6], usize)> {
    let z = zero::<S>();
    match *joint {
        Joint::Fixed => None,
        Joint::Revolute { axis, velocity, .. } => {
            Some(([S::from(axis[0]), S::from(axis[1]), S::from(axis[2]), z, z, z], velocity))
        }
        Joint::Prismatic { axis, velocity, .. } => {
            Some(([z, z, z, S::from(axis[0]), S::from(axis[1]), S::from(axis[2])], velocity))
        }
    }
}

/// I (ω, v) at the body's origin: f = m (v + ω × c), n = I_c ω + c × f.
fn inertia_times<S: Scalar>(b: &Body, (w, v): &Spatial<S>) -> Spatial<S> {
    let com = b.com.map(S::from);
    let f = scale(S::from(b.mass), &add(v, &cross(w, &com)));
    (add(&times(&b.inertia.map(S::from), w), &cross(&com, &f)), f)
}

/// The force a body's own inertia takes: I a + v ×* (I v).
fn body_force<S: Scalar>(b: &Body, motion: &Spatial<S>, rate: &Spatial<S>) -> Spatial<S> {
    let (w, v) = motion;
    let (ia_n, ia_f) = inertia_times(b, rate);
    let (iv_n, iv_f) = inertia_times(b, motion);
    (add(&ia_n, &add(&cross(w, &iv_n), &cross(v, &iv_f))), add(&ia_f, &cross(w, &iv_f)))
}

/// The body's spatial inertia at its origin, on (ω, v): its columns are
/// [`inertia_times`] of the unit motions.
fn spatial_inertia<S: Scalar>(b: &Body) -> [[S; 6]; 6] {
    let columns: [[S; 6]; 6] = core::array::from_fn(|c| {
        let unit: [S; 6] = core::array::from_fn(|k| S::from(if k == c { 1.0 } else { 0.0 }));
        let (n, f) = inertia_times(b, &([unit[0], unit[1], unit[2]], [unit[3], unit[4], unit[5]]));
        [n[0], n[1], n[2], f[0], f[1], f[2]]
    });
    core::array::from_fn(|r| core::array::from_fn(|c| columns[c][r]))
}

/// A child's force (n, f) at its origin, expressed in its parent's frame at the parent's
/// origin: f_p = R f, n_p = R n + p × f_p. The transpose of the motion map.
fn force_to_parent<S: Scalar>(force: &[S; 6], r: &[S; 9], p: &Vec3<S>) -> [S; 6] {
    let f_p = times(r, &[force[3], force[4], force[5]]);
    let n_p = add(&times(r, &[force[0], force[1], force[2]]), &cross(p, &f_p));
    [n_p[0], n_p[1], n_p[2], f_p[0], f_p[1], f_p[2]]
}

/// A child's spatial inertia seen from its parent: Xᵀ I X, with X the motion map from the
/// parent's frame to the child's (so that the kinetic energy is the same either way).
fn to_parent_inertia<S: Scalar>(inertia: &[[S; 6]; 6], r: &[S; 9], p: &Vec3<S>) -> [[S; 6]; 6] {
    // Column c of I X is I applied to the child's motion for the parent's unit motion
    // c: a turn about axis k = c (ω = e_k, v = e_k × p) or a slide along k = c − 3, seen
    // in the child's frame (Rᵀ e_k is R's row k); each column is then carried up as a
    // force. Written out, without the unit vectors' products (the same numbers on f64,
    // half the work on intervals).
    let z = zero::<S>();
    let mut out = [[z; 6]; 6];
    for c in 0..6 {
        let k = c % 3;
        let row = [r[3 * k], r[3 * k + 1], r[3 * k + 2]];
        let mut force = [z; 6];
        if c < 3 {
            let v_c = transpose_times(r, &unit_cross(k, p));
            let motion = [row[0], row[1], row[2], v_c[0], v_c[1], v_c[2]];
            for (f, i_row) in force.iter_mut().zip(inertia) {
                *f = dot6(i_row, &motion);
            }
        } else {
            for (f, i_row) in force.iter_mut().zip(inertia) {
                *f = z + i_row[3] * row[0] + i_row[4] * row[1] + i_row[5] * row[2];
            }
        }
        for (row, value) in out.iter_mut().zip(force_to_parent(&force, r, p)) {
            row[c] = value;
        }
    }
    out
}

/// `e_k × p`.
fn unit_cross<S: Scalar>(k: usize, p: &Vec3<S>) -> Vec3<S> {
    let z = zero::<S>();
    match k {
        0 => [z, -p[2], p[1]],
        1 => [p[2], z, -p[0]],
        _ => [-p[1], p[0], z],
    }
}

/// Rotation by `angle` about the unit `axis` (Rodrigues), row by row.
fn axis_rotation<S: Scalar>(axis: &Vec3<S>, angle: S) -> [S; 9] {
    let (s, c) = (angle.sin(), angle.cos());
    let t = S::from(1.0) - c;
    let [x, y, z] = *axis;
    [
        c + x * x * t,
        x * y * t - z * s,
        x * z * t + y * s,
        y * x * t + z * s,
        c + y * y * t,
        y * z * t - x * s,
        z * x * t - y * s,
        z * y * t + x * s,
        c + z * z * t,
    ]
}

fn matmul<S: Scalar>(a: &[S; 9], b: &[S; 9]) -> [S; 9] {
    core::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j]
    })
}

fn times<S: Scalar>(r: &[S; 9], v: &Vec3<S>) -> Vec3<S> {
    core::array::from_fn(|i| r[3 * i] * v[0] + r[3 * i + 1] * v[1] + r[3 * i + 2] * v[2])
}

fn transpose_times<S: Scalar>(r: &[S; 9], v: &Vec3<S>) -> Vec3<S> {
    core::array::from_fn(|i| r[i] * v[0] + r[3 + i] * v[1] + r[6 + i] * v[2])
}

fn cross<S: Scalar>(a: &Vec3<S>, b: &Vec3<S>) -> Vec3<S> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn add<S: Scalar>(a: &Vec3<S>, b: &Vec3<S>) -> Vec3<S> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale<S: Scalar>(k: S, a: &Vec3<S>) -> Vec3<S> {
    [k * a[0], k * a[1], k * a[2]]
}

/// `a · b`, summed in order from 0 (as `Iterator::sum` does on `f64`).
fn dot6<S: Scalar>(a: &[S; 6], b: &[S; 6]) -> S {
    a.iter().zip(b).fold(zero(), |acc, (x, y)| acc + *x * *y)
}

#[cfg(test)]
mod tests {
    use super::{axis_rotation, Body, Joint, Root, Tree};

    const G: f64 = 9.81;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
    }

    fn revolute(axis: [f64; 3], index: usize) -> Joint {
        Joint::Revolute { axis, coordinate: index, velocity: index }
    }

    #[test]
    fn a_double_pendulum_has_its_textbook_equations() {
        // Point masses m1 at l1 and m2 at l1 + l2 below, both joints about y, angles from
        // the downward vertical (q2 relative to the first link).
        let (m1, m2, l1, l2) = (1.5, 0.7, 0.6, 0.4);
        let bodies = [
            Body::ROOT,
            Body { joint: revolute([0.0, 1.0, 0.0], 0), mass: m1, com: [0.0, 0.0, -l1], ..Body::ROOT },
            Body {
                parent: 1,
                origin: [0.0, 0.0, -l1],
                joint: revolute([0.0, 1.0, 0.0], 1),
                mass: m2,
                com: [0.0, 0.0, -l2],
                ..Body::ROOT
            },
        ];
        let tree = Tree { bodies: &bodies, root: Root::Fixed, gravity: [0.0, 0.0, -G] };
        assert_eq!(tree.defect(2, 2), None);
        let (q, qd): ([f64; 2], [f64; 2]) = ([0.4, -1.1], [0.8, -0.5]);
        let (c2, s2) = (q[1].cos(), q[1].sin());
        let m = tree.mass_matrix::<f64, 2>(&q);
        let expected = [
            [(m1 + m2) * l1 * l1 + m2 * l2 * l2 + 2.0 * m2 * l1 * l2 * c2, m2 * l2 * l2 + m2 * l1 * l2 * c2],
            [m2 * l2 * l2 + m2 * l1 * l2 * c2, m2 * l2 * l2],
        ];
        for (row, want) in m.iter().zip(&expected) {
            for (a, b) in row.iter().zip(want) {
                assert!(close(*a, *b), "M {m:?} vs {expected:?}");
            }
        }
        let h = tree.bias(&q, None, &qd);
        let coriolis = [-m2 * l1 * l2 * s2 * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]), m2 * l1 * l2 * s2 * qd[0] * qd[0]];
        let gravity =
            [(m1 + m2) * G * l1 * q[0].sin() + m2 * G * l2 * (q[0] + q[1]).sin(), m2 * G * l2 * (q[0] + q[1]).sin()];
        for k in 0..2 {
            assert!(close(h[k], coriolis[k] + gravity[k]), "bias {h:?}");
        }
    }

    #[test]
    fn a_free_body_obeys_newton_and_euler() {
        // One floating body: M is its spatial inertia (free-flyer order), and its bias is
        // the weight held up plus Euler's gyroscopic moment.
        let (mass, com) = (3.0, [0.1, -0.2, 0.05]);
        let inertia = [0.3, 0.01, -0.02, 0.01, 0.2, 0.03, -0.02, 0.03, 0.25];
        let bodies = [Body { mass, com, inertia, ..Body::ROOT }];
        let tree = Tree { bodies: &bodies, root: Root::Floating, gravity: [0.0, 0.0, -G] };
        let m = tree.mass_matrix::<f64, 6>(&[]);
        let cc = com.iter().map(|c| c * c).sum::<f64>();
        let skew = [[0.0, -com[2], com[1]], [com[2], 0.0, -com[0]], [-com[1], com[0], 0.0]];
        for i in 0..3 {
            for j in 0..3 {
                let unit = if i == j { 1.0 } else { 0.0 };
                assert!(close(m[i][j], mass * unit));
                assert!(close(m[i][3 + j], -mass * skew[i][j]), "M_v,w {m:?}");
                assert!(close(m[3 + i][j], mass * skew[i][j]));
                let parallel_axis = mass * (cc * unit - com[i] * com[j]);
                assert!(close(m[3 + i][3 + j], inertia[3 * i + j] + parallel_axis), "M_w,w {m:?}");
            }
        }
        // Turned 90° about x (its z axis along the world's -y): the weight, seen from it.
        let turned = axis_rotation(&[1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2);
        let held = tree.bias(&[], Some(&turned), &[0.0; 6]);
        let up_in_body = [0.0, mass * G, 0.0]; // Rᵀ (0, 0, m g) with R = Rx(90°)
        let moment = [
            com[1] * up_in_body[2] - com[2] * up_in_body[1],
            com[2] * up_in_body[0] - com[0] * up_in_body[2],
            com[0] * up_in_body[1] - com[1] * up_in_body[0],
        ];
        for k in 0..3 {
            assert!(close(held[k], up_in_body[k]), "force {held:?}");
            assert!(close(held[3 + k], moment[k]), "moment {held:?}");
        }
        // No gravity, centre of mass at the origin: f = m ω × v, n = ω × (I ω).
        let centred = [Body { mass, inertia, ..Body::ROOT }];
        let free = Tree { bodies: &centred, root: Root::Floating, gravity: [0.0; 3] };
        let (v, w) = ([0.3, -0.7, 1.1], [0.9, 0.4, -0.6]);
        let h = free.bias(&[], None, &[v[0], v[1], v[2], w[0], w[1], w[2]]);
        let iw: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| inertia[3 * i + j] * w[j]).sum());
        let f = [w[1] * v[2] - w[2] * v[1], w[2] * v[0] - w[0] * v[2], w[0] * v[1] - w[1] * v[0]].map(|x| mass * x);
        let n = [w[1] * iw[2] - w[2] * iw[1], w[2] * iw[0] - w[0] * iw[2], w[0] * iw[1] - w[1] * iw[0]];
        for k in 0..3 {
            assert!(close(h[k], f[k]) && close(h[3 + k], n[k]), "{h:?} vs {f:?} {n:?}");
        }
    }

    /// A floating trunk with two branches (revolute and prismatic joints, placements
    /// turned, a fixed body between): every inertial and axis set.
    fn branching() -> [Body; 6] {
        let turned = axis_rotation(&[0.6, 0.0, 0.8], 0.7);
        let inertial =
            |k: f64| (1.0 + k, [0.05 * k, -0.03, 0.1], [0.2 + k, 0.01, 0.0, 0.01, 0.15, 0.02, 0.0, 0.02, 0.1]);
        let body = |parent, origin, joint, k| {
            let (mass, com, inertia) = inertial(k);
            Body { parent, rotation: turned, origin, joint, mass, com, inertia }
        };
        [
            Body {
                mass: 5.0,
                com: [0.0, 0.0, 0.02],
                inertia: [0.5, 0.0, 0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 0.3],
                ..Body::ROOT
            },
            body(0, [0.3, 0.1, 0.0], revolute([0.0, 0.0, 1.0], 0).with_velocity(6), 0.1),
            body(1, [0.0, 0.0, -0.25], revolute([1.0, 0.0, 0.0], 1).with_velocity(7), 0.2),
            body(2, [0.1, 0.0, -0.2], Joint::Fixed, 0.3),
            body(0, [-0.3, 0.0, 0.05], Joint::Prismatic { axis: [0.0, 0.6, 0.8], coordinate: 2, velocity: 8 }, 0.4),
            body(4, [0.0, 0.2, 0.0], revolute([0.0, 1.0, 0.0], 3).with_velocity(9), 0.5),
        ]
    }

    impl Joint {
        fn with_velocity(self, index: usize) -> Joint {
            match self {
                Joint::Revolute { axis, coordinate, .. } => Joint::Revolute { axis, coordinate, velocity: index },
                other => other,
            }
        }
    }

    #[test]
    fn the_mass_matrix_is_what_newton_euler_gives_for_unit_accelerations() {
        // Two algorithms: the composite-rigid-body M against Newton–Euler's forces for
        // each unit acceleration (no velocity, no gravity), and M symmetric and positive.
        let bodies = branching();
        let tree = Tree { bodies: &bodies, root: Root::Floating, gravity: [0.0; 3] };
        assert_eq!(tree.defect(4, 10), None);
        let q = [0.3, -0.8, 0.12, 1.4];
        let m = tree.mass_matrix::<f64, 10>(&q);
        for j in 0..10 {
            let mut a = [0.0; 10];
            a[j] = 1.0;
            let column = tree.inverse_dynamics(&q, None, &[0.0; 10], &a);
            for i in 0..10 {
                assert!(close(m[i][j], column[i]), "M[{i}][{j}] = {} vs Newton-Euler {}", m[i][j], column[i]);
                assert!(close(m[i][j], m[j][i]));
            }
        }
        // Positive: the kinetic energy of a few velocities.
        for v in
            [[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.3, -0.2, 0.5, 1.0, -1.0, 0.4, 2.0, -1.5, 0.7, 0.9]]
        {
            let energy: f64 = (0..10).map(|i| (0..10).map(|j| v[i] * m[i][j] * v[j]).sum::<f64>()).sum();
            assert!(energy > 0.0);
        }
        // And τ = M a + bias for any acceleration, with gravity and velocity on.
        let heavy = Tree { gravity: [0.0, 0.0, -G], ..tree };
        let turned = axis_rotation(&[0.0, 0.6, 0.8], 0.4);
        let v = [0.3, -0.2, 0.5, 1.0, -1.0, 0.4, 2.0, -1.5, 0.7, 0.9];
        let a = [0.1, 0.2, -0.3, 0.4, -0.5, 0.6, -0.7, 0.8, -0.9, 1.0];
        let tau = heavy.inverse_dynamics(&q, Some(&turned), &v, &a);
        let bias = heavy.bias(&q, Some(&turned), &v);
        for i in 0..10 {
            let ma: f64 = (0..10).map(|j| m[i][j] * a[j]).sum();
            assert!(close(tau[i], ma + bias[i]), "tau {tau:?}");
        }
    }

    #[test]
    fn a_bad_tree_or_state_gives_nan_never_a_panic() {
        let good = branching();
        let tree = Tree { bodies: &good, root: Root::Floating, gravity: [0.0, 0.0, -G] };
        // Too few coordinates or velocities: named, and NaN out.
        assert!(tree.defect(3, 10).is_some() && tree.defect(4, 9).is_some());
        assert!(tree.mass_matrix::<f64, 10>(&[0.0; 3]).iter().flatten().all(|v| v.is_nan()));
        assert!(tree.bias::<f64, 9>(&[0.0; 4], None, &[0.0; 9]).iter().all(|v| v.is_nan()));
        // A non-finite state: non-finite out, and the next call is fine.
        let nan = tree.bias::<f64, 10>(&[f64::NAN, 0.0, 0.0, 0.0], None, &[0.0; 10]);
        assert!(nan.iter().any(|v| !v.is_finite()));
        assert!(tree.bias::<f64, 10>(&[0.0; 4], None, &[0.0; 10]).iter().all(|v| v.is_finite()));
        // A parent after its child, a non-finite inertial, a joint on the root.
        let mut bodies = branching();
        bodies[2].parent = 4;
        assert!(Tree { bodies: &bodies, ..tree }.defect(4, 10).is_some());
        bodies[2].parent = 1;
        bodies[3].inertia[4] = f64::INFINITY;
        assert!(Tree { bodies: &bodies, ..tree }.defect(4, 10).is_some());
        bodies[3].inertia[4] = 0.1;
        bodies[0].joint = revolute([0.0, 0.0, 1.0], 0);
        assert!(Tree { bodies: &bodies, ..tree }.defect(4, 10).is_some());
        assert!(Tree { bodies: &[], ..tree }.defect(0, 6).is_some());
    }
}
