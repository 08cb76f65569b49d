//! Tachyon 3's rows on intervals: every family's kernel (the composed body–edge SSAT and
//! the toe–edge sphere–box rows included) run on the certificate's enclosure of a window,
//! against the same rows in f64 along the continuous model (RK4 at Δt/50) under the held
//! input, at states of a drive into the hardware stairs and random inputs in the box.

use cbfgen::filter::between_samples::{RowEnclosure, Window};
use cbfgen::interval::Interval;
use cbfgen::system::BarrierSet;
use cbfgen_tachyon3::approach::Approach;
use cbfgen_tachyon3::catalog::{Capacity, Catalog};
use cbfgen_tachyon3::model::{held_step, INPUT_LIMITS, NU};
use cbfgen_tachyon3::terrain::Stairs;

#[test]
fn every_row_on_intervals_holds_its_f64_values_along_the_held_input() {
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut drive = Approach::new(capacity, Stairs::HARDWARE, 0.3, 0.4).unwrap();
    let (mut enclosing, mut checking) = (Catalog::new(capacity).unwrap(), Catalog::new(capacity).unwrap());
    let mut seed = 0x62_u64;
    let mut draw = || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let (period, fine) = (1e-3, 50);
    let mut checked = [0usize; 7];
    let families = enclosing.families().len();
    for step in 0..3000 {
        let u_drive = drive.nominal_input().map(|v| v.clamp(-3.0, 3.0));
        if step % 60 == 0 {
            let x = drive.x;
            let t = drive.time();
            // An input anywhere in the box: the rows must hold wherever the QP puts it.
            let u: [f64; NU] = std::array::from_fn(|j| INPUT_LIMITS[j] * (2.0 * draw() - 1.0));
            BarrierSet::evaluate(&mut enclosing, t, &x, &drive.env).unwrap();
            let wanted: Vec<bool> = enclosing.rows().iter().map(|r| r.active).collect();
            let mut e = vec![RowEnclosure::ZERO; wanted.len()];
            let window = Window { t, period, before: None, u };
            enclosing.enclose(&window, &x, &drive.env, &wanted, &mut e).unwrap();
            let mut y = x;
            for j in 1..=fine {
                y = held_step(&y, &u, period / fine as f64);
                BarrierSet::evaluate(&mut checking, t + period * j as f64 / fine as f64, &y, &drive.env).unwrap();
                for (i, (row, enc)) in checking.rows().iter().zip(&e).enumerate() {
                    if !wanted[i] {
                        continue;
                    }
                    let family = enclosing.layout()[i].family;
                    let degree = enclosing.families()[family].relative_degree;
                    // The f64 rows and the RK4 path carry their own rounding: 1e-9 of the
                    // value's size is theirs, anything more is the enclosure's.
                    let inside = |v: f64, b: Interval| {
                        let slack = 1e-9 * (1.0 + v.abs());
                        b.lo - slack <= v && v <= b.hi + slack
                    };
                    for d in 0..=degree {
                        assert!(
                            inside(row.lie[d], enc.lie[d]),
                            "step {step}, row {i} (family {family}), L_f^{d} h = {} outside {}",
                            row.lie[d],
                            enc.lie[d]
                        );
                    }
                    for (k, (&a, &b)) in row.lg.iter().zip(&enc.lg).enumerate() {
                        assert!(inside(a, b), "step {step}, row {i}, L_g L_f h[{k}] = {a} outside {b}");
                    }
                    checked[family.min(6)] += 1;
                }
            }
        }
        drive.advance(&u_drive, 1e-3);
    }
    // Every barrier family took part in some window (the toe and body rows near the
    // stairs); the seventh is the foothold pull, a Lyapunov family the drive never guides.
    assert_eq!(families, 7);
    assert_eq!(enclosing.families()[6].kind, cbfgen::system::FamilyKind::Lyapunov);
    assert!(checked[..6].iter().all(|&c| c > 0), "rows checked per family: {checked:?}");
}
