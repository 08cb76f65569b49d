//! A plant for the whole-body controller that shares none of its decisions: the
//! generated rigid-body model driven by torques alone, the stance feet held by rigid
//! contacts. Each step solves
//!
//! ```text
//! [ M  −Jᵀ ] [ν̇]   [ Sᵀτ − b ]
//! [ J   0  ] [f ] = [ −J̇ν     ]
//! ```
//!
//! for the accelerations and the contact forces (a swing foot's slot holds `f = 0`), then
//! takes a semi-implicit Euler step (`R ← R exp([ω dt]×)`). Rigid contacts do not check
//! that a normal force pushes rather than pulls: [`Step::forces`] says, and a caller that
//! needs unilateral contact, impacts or friction uses MuJoCo. Allocation-free.

use cbfgen::nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

use crate::wbc::{FEET, JOINTS};
use crate::wbc_generated::{self as gen, NU, NX};

const KKT: usize = NU + 3 * FEET;

/// What one step found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The generalized accelerations.
    pub accelerations: [f64; NU],
    /// The contact force at each foot, world \[N\] (zero for a swing foot).
    pub forces: [[f64; 3]; FEET],
}

/// Accelerations and stance forces at state `x` under torques `tau`, or `None` when the
/// contact system is singular (stance feet whose Jacobians are dependent).
pub fn accelerations(x: &[f64; NX], tau: &[f64; JOINTS], stance: [bool; FEET]) -> Option<Step> {
    let (mass, bias) = gen::dynamics(x);
    let (_, jacobians, drifts) = gen::contacts(x);
    let mut kkt = SMatrix::<f64, KKT, KKT>::zeros();
    let mut rhs = SVector::<f64, KKT>::zeros();
    for r in 0..NU {
        for c in 0..NU {
            kkt[(r, c)] = mass[r][c];
        }
        rhs[r] = -bias[r] + if r >= 6 { tau[r - 6] } else { 0.0 };
    }
    for foot in 0..FEET {
        for axis in 0..3 {
            let row = NU + 3 * foot + axis;
            if stance[foot] {
                for c in 0..NU {
                    let j = jacobians[3 * foot + axis][c];
                    kkt[(row, c)] = j;
                    kkt[(c, row)] = -j;
                }
                rhs[row] = -drifts[foot][axis];
            } else {
                kkt[(row, row)] = 1.0;
            }
        }
    }
    let solution = kkt.lu().solve(&rhs)?;
    if solution.iter().any(|v| !v.is_finite()) {
        return None;
    }
    Some(Step {
        accelerations: std::array::from_fn(|i| solution[i]),
        forces: std::array::from_fn(|f| std::array::from_fn(|a| solution[NU + 3 * f + a])),
    })
}

/// One semi-implicit Euler step of `dt` \[s\] with accelerations `accel`.
pub fn integrate(x: &mut [f64; NX], accel: &[f64; NU], dt: f64) {
    for (v, a) in x[24..].iter_mut().zip(accel) {
        *v += dt * a;
    }
    let rotation = Matrix3::from_row_slice(&x[3..12]);
    let v = Vector3::new(x[24], x[25], x[26]);
    let w = Vector3::new(x[27], x[28], x[29]);
    let p = Vector3::new(x[0], x[1], x[2]) + dt * rotation * v;
    let next = rotation * Rotation3::new(dt * w).matrix();
    x[..3].copy_from_slice(p.as_slice());
    for r in 0..3 {
        for c in 0..3 {
            x[3 + 3 * r + c] = next[(r, c)];
        }
    }
    for j in 0..JOINTS {
        x[12 + j] += dt * x[30 + j];
    }
}
