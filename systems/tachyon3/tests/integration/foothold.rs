//! Foothold polygons and the foothold pull (section IV-D): the polygon's half-planes and
//! nearest point against vertex geometry computed here, and a swing toe started outside
//! its foothold brought in by the CLF before touchdown, in closed loop with the filter.

use cbfgen::error::CbfError;
use cbfgen_tachyon3::catalog::{self, Capacity, Environment};
use cbfgen_tachyon3::foothold::{depth, nearest_inside, polygon_half_planes, ToeGuide};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::{self, State, NU};
use cbfgen_tachyon3::sim::foothold_swing::{swing_into_footholds, swing_time, FootholdSwing, OutsideRule, INSET};
use cbfgen_tachyon3::sim::DT;

/// Small deterministic generator (xorshift), so the cases are the same every run.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A random convex polygon: points on an ellipse at sorted random angles, rotated.
fn random_polygon(rng: &mut Rng) -> Vec<[f64; 2]> {
    let n = 3 + (rng.uniform(0.0, 7.0) as usize);
    let mut angles: Vec<f64> = (0..n).map(|_| rng.uniform(0.0, std::f64::consts::TAU)).collect();
    angles.sort_by(f64::total_cmp);
    let (a, b, c) = (rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0), [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0)]);
    let spin = rng.uniform(0.0, 3.0);
    angles
        .iter()
        .map(|t| {
            let (x, y) = (a * t.cos(), b * t.sin());
            [c[0] + x * spin.cos() - y * spin.sin(), c[1] + x * spin.sin() + y * spin.cos()]
        })
        .collect()
}

/// The distance from `p` to the polygon's boundary, segment by segment from its vertices.
fn distance_to_boundary(vertices: &[[f64; 2]], p: [f64; 2]) -> f64 {
    (0..vertices.len())
        .map(|i| {
            let (a, b) = (vertices[i], vertices[(i + 1) % vertices.len()]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1])).clamp(0.0, 1.0);
            (a[0] + t * d[0] - p[0]).hypot(a[1] + t * d[1] - p[1])
        })
        .fold(f64::INFINITY, f64::min)
}

/// Inside by the winding of the vertices (every cross product on the polygon's side).
fn inside_by_vertices(vertices: &[[f64; 2]], p: [f64; 2]) -> bool {
    let n = vertices.len();
    let cross = |i: usize| {
        let (a, b) = (vertices[i], vertices[(i + 1) % n]);
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    };
    (0..n).all(|i| cross(i) >= 0.0) || (0..n).all(|i| cross(i) <= 0.0)
}

#[test]
fn polygon_half_planes_and_nearest_point_agree_with_the_vertices() -> Result<(), CbfError> {
    let mut rng = Rng(0x5eed_f00d);
    let mut outside_cases = 0;
    for _ in 0..300 {
        let mut poly = random_polygon(&mut rng);
        if rng.uniform(0.0, 1.0) < 0.5 {
            poly.reverse(); // either winding is the same polygon
        }
        let planes = polygon_half_planes(&poly, 0.0)?;
        assert_eq!(planes.len(), poly.len());
        for _ in 0..20 {
            let p = [rng.uniform(-4.0, 4.0), rng.uniform(-4.0, 4.0)];
            let d = depth(&planes, p);
            assert_eq!(d >= 0.0, inside_by_vertices(&poly, p), "inside test at {p:?}");
            let q = nearest_inside(&planes, p, 0.0).expect("a polygon is not empty");
            if d >= 0.0 {
                assert_eq!(q, p);
            } else {
                outside_cases += 1;
                // Outside, the nearest point is on the boundary at the boundary's distance,
                // and the most violated edge's excess never exceeds that distance.
                let truth = distance_to_boundary(&poly, p);
                let got = (q[0] - p[0]).hypot(q[1] - p[1]);
                assert!((got - truth).abs() < 1e-9, "distance {got} vs {truth} at {p:?}");
                assert!(depth(&planes, q) > -1e-9 && -d <= truth + 1e-12);
            }
        }
    }
    assert!(outside_cases > 1000, "only {outside_cases} points fell outside");
    Ok(())
}

#[test]
fn an_inset_polygon_keeps_its_distance_from_every_side() -> Result<(), CbfError> {
    // A 1 x 0.5 trapezoid; inset 0.1: hand-computed, the bottom edge y = 0 moves to y = 0.1.
    let poly = [[0.0, 0.0], [1.0, 0.0], [0.75, 0.5], [0.25, 0.5]];
    let planes = polygon_half_planes(&poly, 0.1)?;
    assert!((depth(&planes, [0.5, 0.1])).abs() < 1e-12);
    assert!((depth(&planes, [0.5, 0.4])).abs() < 1e-12);
    // Below the bottom edge the nearest point of the inset polygon is straight up, and
    // with a further 2 cm margin 2 cm further in.
    let q = nearest_inside(&planes, [0.5, -0.3], 0.02).expect("room");
    assert!((q[0] - 0.5).abs() < 1e-12 && (q[1] - 0.12).abs() < 1e-12, "{q:?}");
    // Every point of the inset polygon keeps 0.1 from the polygon's boundary.
    let mut rng = Rng(7);
    for _ in 0..2000 {
        let p = [rng.uniform(0.0, 1.0), rng.uniform(0.0, 0.5)];
        if depth(&planes, p) >= 0.0 {
            assert!(distance_to_boundary(&poly, p) >= 0.1 - 1e-12);
        }
    }
    Ok(())
}

#[test]
fn bad_polygons_are_refused() {
    let refused = |v: &[[f64; 2]], inset: f64| polygon_half_planes(v, inset).is_err();
    assert!(refused(&[[0.0, 0.0], [1.0, 0.0]], 0.0), "two vertices");
    assert!(refused(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], 0.0), "no area");
    assert!(refused(&[[0.0, 0.0], [2.0, 0.0], [1.0, 0.3], [1.0, 2.0]], 0.0), "not convex");
    assert!(refused(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]], 0.0), "repeated vertex");
    assert!(refused(&[[0.0, 0.0], [1.0, 0.0], [0.0, f64::NAN]], 0.0), "NaN");
    assert!(refused(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], -0.1), "negative inset");
    assert!(refused(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], 0.5), "inset leaves nothing");
}

#[test]
fn guide_toe_switches_between_the_rows_and_the_pull_and_refuses_bad_input() -> Result<(), CbfError> {
    let mut env = Environment::new(Capacity::PAPER_WORST_CASE)?;
    env.set_swing([true; 6]);
    env.set_foothold(2, &polygon_half_planes(&[[1.0, -1.0], [1.4, -1.0], [1.4, 1.0], [1.0, 1.0]], 0.1)?)?;
    let ToeGuide::Pulled { target, outside } = env.guide_toe(2, [0.9, -0.5], 0.01)? else {
        panic!("the toe is 0.2 m outside");
    };
    assert!((outside - 0.2).abs() < 1e-12 && (target[0] - 1.11).abs() < 1e-12 && (target[1] + 0.5).abs() < 1e-12);
    let pull = env.foothold_pull(2).expect("pull on");
    assert!((pull.direction[0] - 1.0).abs() < 1e-12 && pull.direction[1].abs() < 1e-12);
    assert!(env.swing()[2], "a pulled leg still swings");
    // Bad input leaves the pull as it was.
    assert!(env.guide_toe(2, [f64::NAN, 0.0], 0.01).is_err());
    assert!(env.guide_toe(2, [1e308, -1e308], 0.01).is_err(), "beyond the state's domain");
    assert!(env.guide_toe(2, [0.9, -0.5], -1.0).is_err());
    assert!(env.guide_toe(6, [0.9, -0.5], 0.01).is_err());
    assert!(env.foothold_pull(2).is_some());
    // Two half-planes with nothing in common: nothing to pull towards.
    let (a, b) = (catalog::HalfPlane::new([1.0, 0.0], -2.0)?, catalog::HalfPlane::new([-1.0, 0.0], 1.0)?);
    env.set_foothold(3, &[a, b])?;
    assert!(env.guide_toe(3, [0.0, 0.0], 0.0).is_err());
    // Inside: the rows keep it and the pull goes off; set_swing clears every pull.
    assert_eq!(env.guide_toe(2, [1.2, 0.0], 0.01)?, ToeGuide::Kept);
    assert!(env.foothold_pull(2).is_none());
    env.guide_toe(2, [0.9, -0.5], 0.01)?;
    env.set_swing([true; 6]);
    assert!(env.foothold_pull(2).is_none());
    Ok(())
}

/// Whether `p` is in the polygon `vertices` shrunk by `inset`, from the vertices alone.
fn in_inset(vertices: &[[f64; 2]], inset: f64, p: [f64; 2]) -> bool {
    inside_by_vertices(vertices, p) && distance_to_boundary(vertices, p) >= inset - 1e-6
}

/// When each toe of `run` entered its inset foothold and whether it stayed in, by the
/// vertex geometry above.
fn entered(run: &FootholdSwing) -> [Option<(f64, bool)>; 3] {
    std::array::from_fn(|i| {
        let inside: Vec<bool> = run.toes.iter().map(|t| in_inset(&run.polygons[i], INSET, t[i])).collect();
        let first = inside.iter().position(|&b| b)?;
        Some((run.t[first], inside[first..].iter().all(|&b| b)))
    })
}

/// The largest world x acceleration of a swing toe, by second differences of its path.
fn peak_world_accel(run: &FootholdSwing) -> f64 {
    run.toes
        .windows(3)
        .flat_map(|w| (0..3).map(move |i| ((w[2][i][0] - 2.0 * w[1][i][0] + w[0][i][0]) / (DT * DT)).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn the_foothold_pull_brings_a_swing_toe_from_outside_into_its_foothold_before_touchdown() -> Result<(), CbfError> {
    let swing = swing_time();
    // Toes 8 cm short of their footholds' inset edges, and a nominal that would hold them.
    let pulled = swing_into_footholds(OutsideRule::Pull, 0.08)?;
    for (i, e) in entered(&pulled).iter().enumerate() {
        let (t, stayed) = e.expect("the pulled toe enters its foothold");
        assert!(t < 0.75 * swing, "toe {i} entered at {t} s of the {swing} s swing");
        assert!(stayed, "toe {i} left its foothold after entering it (the rows keep it)");
    }
    // Outside its set a toe is not unsafe: the pull never makes the filter report safety
    // relaxed, and it fits the toe's 10 m/s^2 (about 64 * 0.09 = 5.8 at the start).
    assert_eq!((pulled.safety_relaxed(), pulled.convergence_relaxed()), (0, 0));
    let peak = peak_world_accel(&pulled);
    assert!(peak > 4.0 && peak < 7.0, "peak toe acceleration {peak}");
    // The foothold rows kept on outside the set ask for h'' >= 400 * 0.08 = 32 m/s^2 at
    // the start, beyond what the toe has: they are relaxed, and reported so, while the toe
    // is out, and drive it at the limits of its own and the origin's accelerations (10 + 3).
    let kept = swing_into_footholds(OutsideRule::KeepRows, 0.08)?;
    assert!(kept.safety_relaxed() > 10, "{}", kept.safety_relaxed());
    assert!(entered(&kept).iter().all(Option::is_some));
    let peak = peak_world_accel(&kept);
    assert!(peak > 12.99, "peak toe acceleration {peak}");
    // With the footholds around the toes there is nothing to pull and nothing relaxed.
    let home = swing_into_footholds(OutsideRule::Pull, -0.1)?;
    assert!(entered(&home).iter().all(|e| matches!(e, Some((t, true)) if *t <= DT)), "{:?}", entered(&home));
    assert_eq!((home.safety_relaxed(), home.convergence_relaxed()), (0, 0));
    Ok(())
}

#[test]
fn the_pull_kernel_is_v_of_the_world_toe_and_its_derivatives_match_finite_differences() {
    let mut rng = Rng(99);
    let eps = 1e-6;
    for case in 0..400 {
        // States around the standard posture, moving and turning.
        let mut x = model::standard_posture();
        for v in x.iter_mut() {
            *v += rng.uniform(-0.2, 0.2);
        }
        let leg = case % 6;
        let target = nalgebra_vec([rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)]);
        let a = rng.uniform(-3.2, 3.2);
        let direction = nalgebra_vec([a.cos(), a.sin()]);
        let kernel = |x: &State| gen::FOOTHOLD_PULL[leg](x, &target, &direction);
        // V from the world kinematics, the toe's velocity by a central difference along f.
        let toe = |x: &State| {
            let (_, _, toes) = gen::world_kinematics(x);
            [toes[leg][0], toes[leg][1]]
        };
        let f = gen::drift(&x);
        let along = |x: &State, k: f64| -> State { std::array::from_fn(|i| x[i] + k * f[i]) };
        let (p, pp, pm) = (toe(&x), toe(&along(&x, eps)), toe(&along(&x, -eps)));
        let ahead: Vec<f64> =
            (0..2).map(|k| p[k] + gen::FOOTHOLD_PULL_LEAD * (pp[k] - pm[k]) / (2.0 * eps) - target[k]).collect();
        let z = direction[0] * ahead[0] + direction[1] * ahead[1];
        let ([[h, lf_h]], [lg]) = kernel(&x);
        assert!((-h - z * z / 2.0).abs() < 1e-7 * (1.0 + z * z), "case {case}: V {} vs {}", -h, z * z / 2.0);
        // L_f h along f, and L_g h along each input's column of g.
        let (hp, hm) = (kernel(&along(&x, eps)).0[0][0], kernel(&along(&x, -eps)).0[0][0]);
        assert!((lf_h - (hp - hm) / (2.0 * eps)).abs() < 1e-6 * (1.0 + lf_h.abs()), "case {case}: L_f h");
        for u in 0..NU {
            let mut du = [0.0; NU];
            du[u] = 1.0;
            let g = model::xdot(&x, &du);
            let g: State = std::array::from_fn(|i| g[i] - f[i]);
            let shift = |k: f64| -> State { std::array::from_fn(|i| x[i] + k * g[i]) };
            let (gp, gm) = (kernel(&shift(eps)).0[0][0], kernel(&shift(-eps)).0[0][0]);
            let fd = (gp - gm) / (2.0 * eps);
            let column = gen::FOOTHOLD_PULL_INPUT_COLUMNS[leg].iter().position(|&c| c == u);
            let analytic = column.map_or(0.0, |c| lg[c]);
            assert!((analytic - fd).abs() < 1e-6 * (1.0 + fd.abs()), "case {case}: L_g h[{u}] {analytic} vs {fd}");
        }
    }
}

fn nalgebra_vec(v: [f64; 2]) -> cbfgen::nalgebra::SVector<f64, 2> {
    v.into()
}
