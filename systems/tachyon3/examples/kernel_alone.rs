//! A generated kernel on its own, without the filter: the body–edge SSAT row of Tachyon 3
//! (`generated::tachyon3::body_edge`) for the body over a stair nosing. It returns `h`
//! and its Lie derivatives along the drift, and `L_g L_f h` on the inputs it depends on.
//! The example checks them against the exact SAT separation and a finite difference.
//!
//! ```text
//! cargo run --release -p cbfgen-tachyon3 --example kernel_alone
//! ```

use cbfgen::nalgebra::Vector3;
use cbfgen::{sat, OrientedBox};
use cbfgen_tachyon3::generated::{self as gen, drift, BODY_EDGE_INPUT_COLUMNS, INPUT_NAMES};
use cbfgen_tachyon3::model::{body_box, standard_posture};

fn main() -> Result<(), cbfgen::CbfError> {
    // The body in its standard posture, rolling forward at 0.3 m/s, pitched nose-up by
    // 0.05 rad, its front face 10 cm short of a nosing 20 cm up.
    let mut x = standard_posture();
    x[4] = 0.3;
    x[8] = -0.05;
    let nosing = OrientedBox::axis_aligned(Vector3::new(0.625, 0.0, 0.175), Vector3::new(0.025, 1.0, 0.025))?;
    let rotation = *nosing.rotation().matrix();
    let (lie, lg_lf) = gen::body_edge(&x, nosing.center(), &rotation, nosing.half_extents());
    let [h, lf_h, lf2_h] = lie[0];
    println!("h = {h:.5}   L_f h = {lf_h:.5} /s   L_f² h = {lf2_h:.5} /s²");
    for (column, value) in BODY_EDGE_INPUT_COLUMNS.iter().zip(lg_lf[0]) {
        println!("  L_g L_f h on {:>10}: {value:+.5}", INPUT_NAMES[*column]);
    }

    // h less its certified margin never exceeds the exact separation of separated boxes.
    let separation = sat::separation(&body_box(&x)?, &nosing);
    println!("exact SAT separation {separation:.5} m; smooth h {h:.5}");
    assert!(separation > 0.0 && h <= separation + 1e-9);

    // L_f h is the rate of h along the drift: a central difference agrees.
    let step = 1e-6;
    let along = |s: f64| {
        let f = drift(&x);
        let moved: [f64; gen::NX] = std::array::from_fn(|i| x[i] + s * f[i]);
        gen::body_edge(&moved, nosing.center(), &rotation, nosing.half_extents()).0[0][0]
    };
    let numeric = (along(step) - along(-step)) / (2.0 * step);
    println!("L_f h {lf_h:.7}, central difference {numeric:.7}");
    assert!((numeric - lf_h).abs() < 1e-6 * lf_h.abs().max(1.0));
    Ok(())
}
