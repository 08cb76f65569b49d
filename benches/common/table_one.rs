//! Table I's queries, each over the same 1024 random box pairs: the SSAT variants, the
//! exact SAT, parry3d's GJK and cuboid distances, and the LP (the growth distance solved
//! by Clarabel, setup included). Shared by the criterion bench
//! (`benches/ssat.rs`) and the interleaved harness (`benches/table_one.rs`).

use cbfgen::ssat::{self, SmoothAbs, SmoothMax, SmoothParams};
use cbfgen::{sat, OrientedBox};
use cbfgen_testkit::boxes::random_pairs;
use cbfgen_testkit::lp_boxes;
use parry3d_f64::math::{Pose, Rot3, Vec3};
use parry3d_f64::query::details::{distance_cuboid_cuboid, distance_support_map_support_map};
use parry3d_f64::shape::Cuboid;
use std::hint::black_box;

/// Box pairs per query pass.
pub const PAIRS: usize = 1024;

fn parry_pose(b: &OrientedBox) -> Pose {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(b.rotation());
    let c = b.center();
    Pose::from_parts(Vec3::new(c.x, c.y, c.z), Rot3::from_xyzw(q.i, q.j, q.k, q.w))
}

fn parry_cuboid(b: &OrientedBox) -> Cuboid {
    let h = b.half_extents();
    Cuboid::new(Vec3::new(h.x, h.y, h.z))
}

/// One query over every pair; returns a sum so nothing is optimised away.
pub type Pass = Box<dyn Fn() -> f64>;

/// `(name, the function timed, one pass over the pairs)` for every row of Table I, in the
/// table's order.
pub fn queries() -> Vec<(String, &'static str, Pass)> {
    let pairs = random_pairs(7, PAIRS, 1.0);
    let mut out: Vec<(String, &'static str, Pass)> = Vec::new();
    let variants = [
        ("lse_xtanh", SmoothMax::Lse, SmoothAbs::XTanh),
        ("lse_sqrt", SmoothMax::Lse, SmoothAbs::Sqrt),
        ("boltzmann_xtanh", SmoothMax::Boltzmann, SmoothAbs::XTanh),
    ];
    for (name, max, abs) in variants {
        let p = SmoothParams::default().with_variant(max, abs);
        let pp = pairs.clone();
        out.push((
            format!("evaluate/{name}"),
            "cbfgen::ssat::ssat",
            Box::new(move || pp.iter().map(|(a, b)| ssat::ssat(black_box(a), black_box(b), &p)).sum()),
        ));
        let pp = pairs.clone();
        out.push((
            format!("evaluate+grad+hess/{name}"),
            "cbfgen::ssat::ssat_with_derivatives",
            Box::new(move || {
                pp.iter()
                    .map(|(a, b)| ssat::ssat_with_derivatives(black_box(a), black_box(b), &p).hessian[(0, 0)])
                    .sum()
            }),
        ));
    }
    let pp = pairs.clone();
    out.push((
        "exact_sat".into(),
        "cbfgen::sat::separation",
        Box::new(move || pp.iter().map(|(a, b)| sat::separation(black_box(a), black_box(b))).sum()),
    ));
    let parry: Vec<_> =
        pairs.iter().map(|(a, b)| (parry_pose(a).inv_mul(&parry_pose(b)), parry_cuboid(a), parry_cuboid(b))).collect();
    let pp = parry.clone();
    out.push((
        "parry3d_gjk_distance".into(),
        "parry3d_f64::query::details::distance_support_map_support_map",
        Box::new(move || {
            pp.iter().map(|(pos12, ca, cb)| distance_support_map_support_map(black_box(pos12), ca, cb)).sum()
        }),
    ));
    out.push((
        "parry3d_cuboid_distance".into(),
        "parry3d_f64::query::details::distance_cuboid_cuboid",
        Box::new(move || parry.iter().map(|(pos12, ca, cb)| distance_cuboid_cuboid(black_box(pos12), ca, cb)).sum()),
    ));
    // An LP per query, built and solved afresh as an optimisation-based CBF would: the
    // settings, the 12×4 constraint matrix, `DefaultSolver::new` and `solve` are all timed.
    out.push((
        "lp_growth_distance".into(),
        "cbfgen_testkit::lp_boxes::growth_distance (clarabel DefaultSolver::new + solve)",
        Box::new(move || {
            pairs
                .iter()
                .map(|(a, b)| {
                    lp_boxes::growth_distance(black_box(a), black_box(b), lp_boxes::settings()).unwrap_or(f64::NAN)
                })
                .sum()
        }),
    ));
    out
}
