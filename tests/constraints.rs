//! The generated constraint rows against numerical Lie derivatives and hand-built cases.

mod common;

use cbfgen::generated::tachyon3 as gen;
use cbfgen::model::{self, State, BODY_PITCH, BODY_X, BODY_Z, NU, NX, TOE_BLOCK};
use common::{random_rotation, random_vector, rng};
use nalgebra::Rotation3;
use rand::Rng;

/// One kernel's rows at a state: per row [h, L_f h, L_f² h] and the dense L_g L_f h.
type Rows = Vec<([f64; 3], [f64; NU])>;
type RowFn = Box<dyn Fn(&State) -> Rows>;

fn dense<const C: usize>(lg: &[f64; C], columns: &[usize]) -> [f64; NU] {
    let mut out = [0.0; NU];
    for (&c, &v) in columns.iter().zip(lg) {
        out[c] = v;
    }
    out
}

fn rows_of<const R: usize, const C: usize>(out: ([[f64; 3]; R], [[f64; C]; R]), columns: &[usize]) -> Rows {
    (0..R).map(|i| (out.0[i], dense(&out.1[i], columns))).collect()
}

fn random_state(r: &mut impl Rng) -> State {
    let mut x = model::standard_posture();
    x[0] = r.random_range(-2.0..2.0);
    x[1] = r.random_range(-2.0..2.0);
    x[2] = r.random_range(-0.2..0.2);
    x[3] = r.random_range(-3.0..3.0);
    x[4] = r.random_range(-1.0..1.0);
    x[5] = r.random_range(-0.5..0.5);
    x[BODY_X] = r.random_range(-0.1..0.1);
    x[BODY_Z] = r.random_range(0.2..0.5);
    x[BODY_PITCH] = r.random_range(-0.3..0.3);
    for k in 9..12 {
        x[k] = r.random_range(-0.5..0.5);
    }
    for leg in 0..6 {
        let t = TOE_BLOCK + 4 * leg;
        x[t] = x[BODY_X] + model::HIP_POSITIONS[leg][0] + r.random_range(-0.3..0.3);
        x[t + 1] = r.random_range(-0.05..0.15); // below the hips, so the legs point down
        x[t + 2] = r.random_range(-0.5..0.5);
        x[t + 3] = r.random_range(-0.5..0.5);
    }
    x
}

/// An edge cuboid near the robot in the kernels' argument layout: centre, row-major
/// rotation (yaw-only half of the time, like stair edges), half extents.
fn random_edge(r: &mut impl Rng) -> ([f64; 3], [f64; 9], [f64; 3]) {
    let rot = if r.random_bool(0.5) {
        Rotation3::from_euler_angles(0.0, 0.0, r.random_range(-3.0..3.0))
    } else {
        random_rotation(r)
    };
    let (c, h, m) = (random_vector(r, -1.5, 1.5), random_vector(r, 0.02, 0.5), rot.matrix());
    ([c.x, c.y, c.z], std::array::from_fn(|k| m[(k / 3, k % 3)]), [h.x, h.y, h.z])
}

/// Every row kernel of the model with freshly drawn runtime parameters.
fn kernels_with_random_params(r: &mut impl Rng) -> Vec<(String, RowFn)> {
    let mut out: Vec<(String, RowFn)> = Vec::new();
    let (ca, ra, ha) = random_edge(r);
    out.push(("body_edge_ssat".into(),
              Box::new(move |x| rows_of(gen::body_edge_ssat(x, &ca, &ra, &ha), &gen::BODY_EDGE_SSAT_INPUT_COLUMNS))));
    let normal = {
        let a: f64 = r.random_range(-3.2..3.2);
        [a.cos(), a.sin()]
    };
    let offset = r.random_range(-1.0..1.0);
    let floor = r.random_range(-0.2..0.2);
    let (sa, sb) = (if r.random_bool(0.5) { 1.0 } else { -1.0 }, r.random_range(-0.5..0.5));
    for leg in 0..6 {
        let name = gen::LEG_NAMES[leg];
        out.push((format!("joint_limits[{name}]"),
                  Box::new(move |x| rows_of(gen::JOINT_LIMITS[leg](x), &gen::JOINT_LIMITS_INPUT_COLUMNS[leg]))));
        out.push((format!("toe_edge[{name}]"),
                  Box::new(move |x| rows_of(gen::TOE_EDGE[leg](x, &ca, &ra, &ha), &gen::TOE_EDGE_INPUT_COLUMNS[leg]))));
        out.push((format!("foothold[{name}]"),
                  Box::new(move |x| rows_of(gen::FOOTHOLD[leg](x, &normal, offset), &gen::FOOTHOLD_INPUT_COLUMNS[leg]))));
        out.push((format!("foot_height[{name}]"),
                  Box::new(move |x| rows_of(gen::FOOT_HEIGHT[leg](x, floor), &gen::FOOT_HEIGHT_INPUT_COLUMNS[leg]))));
        out.push((format!("stability[{name}]"),
                  Box::new(move |x| rows_of(gen::STABILITY[leg](x, sa, sb), &gen::STABILITY_INPUT_COLUMNS[leg]))));
    }
    out
}

fn shifted(x: &State, dir: &State, eps: f64) -> State {
    std::array::from_fn(|k| x[k] + eps * dir[k])
}

/// Column u of g(x) as a state-space direction.
fn g_column(x: &State, u: usize) -> State {
    let mut dir = [0.0; NX];
    for (&(row, col), v) in gen::G_PATTERN.iter().zip(gen::dynamics_g(x)) {
        if col == u {
            dir[row] = v;
        }
    }
    dir
}

/// A central difference of values of magnitude `scale` with step `step` is trusted to
/// 1e-6 relative (truncation) plus its rounding error, ~1e-15 * scale / step.
fn assert_close(numeric: f64, analytic: f64, scale: f64, step: f64, what: &str) {
    let tol = 1e-6 * analytic.abs().max(1.0) + 1e-15 * scale / step;
    assert!((numeric - analytic).abs() <= tol, "{what}: analytic {analytic} vs FD {numeric} (tol {tol:e})");
}

#[test]
fn lie_derivatives_match_finite_differences_along_f_and_g() {
    let mut r = rng(17);
    let eps = 1e-6;
    // L_f h is linear in the velocity states g moves, so a long step along g is exact.
    let eps_g = 1e-3;
    let mut checked = 0usize;
    let mut nonzero_seen: std::collections::HashMap<(String, usize), bool> = Default::default();
    for _ in 0..1000 {
        let x = random_state(&mut r);
        let f = gen::dynamics_f(&x);
        for (name, kernel) in kernels_with_random_params(&mut r) {
            let at = kernel(&x);
            let plus_f = kernel(&shifted(&x, &f, eps));
            let minus_f = kernel(&shifted(&x, &f, -eps));
            for (k, (lie, lg)) in at.iter().enumerate() {
                // L_f h and L_f^2 h: derivatives along f of the kernel's own h and L_f h.
                let lf_fd = (plus_f[k].0[0] - minus_f[k].0[0]) / (2.0 * eps);
                let lf2_fd = (plus_f[k].0[1] - minus_f[k].0[1]) / (2.0 * eps);
                let h_scale = plus_f[k].0[0].abs().max(minus_f[k].0[0].abs());
                let lf_scale = plus_f[k].0[1].abs().max(minus_f[k].0[1].abs());
                assert_close(lf_fd, lie[1], h_scale, eps, &format!("{name} row {k}: L_f h"));
                assert_close(lf2_fd, lie[2], lf_scale, eps, &format!("{name} row {k}: L_f^2 h"));
                for u in 0..NU {
                    let gu = g_column(&x, u);
                    let (p, m) = (kernel(&shifted(&x, &gu, eps_g)), kernel(&shifted(&x, &gu, -eps_g)));
                    // Relative degree 2: h itself does not see the input...
                    assert_eq!(p[k].0[0], m[k].0[0], "{name} row {k}: h depends on input {u}");
                    // ...and L_g L_f h is zero outside the listed columns, right inside them.
                    let lglf_fd = (p[k].0[1] - m[k].0[1]) / (2.0 * eps_g);
                    let scale = p[k].0[1].abs().max(m[k].0[1].abs());
                    assert_close(lglf_fd, lg[u], scale, eps_g, &format!("{name} row {k}: L_g L_f h[{u}]"));
                    if lg[u].abs() > 1e-9 {
                        nonzero_seen.insert((name.clone(), u), true);
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 1000 * 34);
    // Every listed column is structurally non-zero: it was seen non-zero somewhere.
    for leg in 0..6 {
        let n = gen::LEG_NAMES[leg];
        for (family, cols) in [
            ("joint_limits", &gen::JOINT_LIMITS_INPUT_COLUMNS[leg][..]),
            ("toe_edge", &gen::TOE_EDGE_INPUT_COLUMNS[leg][..]),
            ("foothold", &gen::FOOTHOLD_INPUT_COLUMNS[leg][..]),
            ("foot_height", &gen::FOOT_HEIGHT_INPUT_COLUMNS[leg][..]),
            ("stability", &gen::STABILITY_INPUT_COLUMNS[leg][..]),
        ] {
            for &u in cols {
                assert!(nonzero_seen.contains_key(&(format!("{family}[{n}]"), u)), "{family}[{n}] column {u} never non-zero");
            }
        }
    }
    for &u in &gen::BODY_EDGE_SSAT_INPUT_COLUMNS {
        assert!(nonzero_seen.contains_key(&("body_edge_ssat".to_string(), u)), "body_edge_ssat column {u} never non-zero");
    }
}
