//! The stepping stones: the field against the trot it was laid for (every foothold on a
//! stone, each hind foot on its front foot's stones, the walk ending on the last ones),
//! its seeded displacements, its refusals; the rows away from the gait (a fixed pitch the
//! footholds drift against); and seed 004's proposed controller walking short fields of
//! both on the rigid-contact plant with no misstep, judged against the stones, where the
//! MPC baseline missteps away from the gait.

use cbfgen_anymal::stones::{SteppingStones, Stone, StoneField, StoneLayout};
use cbfgen_anymal::walk::{walk, Controller, FootholdBarrier, WalkRecord, WalkSettings};

const FRONT_OF: [usize; 4] = [0, 1, 0, 1]; // LH behind LF, RH behind RF

fn field(strides: usize, seed: u64) -> SteppingStones {
    SteppingStones::new(&StoneField { strides, seed, ..StoneField::default() }).unwrap()
}

#[test]
fn every_foothold_of_the_walk_is_on_a_stone_and_hind_feet_reuse_the_front_feet_stones() {
    let field = field(6, 3);
    let trot = *field.trot();
    let times: Vec<f64> = (0..((field.end() + 4.0 * trot.swing) / 0.01) as usize).map(|k| k as f64 * 0.01).collect();
    let footholds: Vec<Vec<[f64; 3]>> =
        (0..4).map(|foot| times.iter().map(|&t| trot.foothold_for(foot, t)).collect()).collect();
    let mut used = vec![false; field.stones().len()];
    for (foot, list) in footholds.iter().enumerate() {
        for (p, t) in list.iter().zip(&times) {
            // On a stone, well inside, and on one whose top is within the displacement
            // of the ground.
            let k = (0..used.len())
                .find(|&k| field.stones()[k].distance(p[0], p[1]) == 0.0)
                .unwrap_or_else(|| panic!("foot {foot} at t = {t}: {p:?} is off every stone"));
            used[k] = true;
            let stone = field.stones()[k];
            let inside = stone.half - (p[0] - stone.top[0]).abs().max((p[1] - stone.top[1]).abs());
            assert!(inside >= 0.07 - 0.03 - 0.015 - 1e-9, "foot {foot} at t = {t}: {inside} m inside");
            assert!(stone.top[2].abs() <= 0.02 + 1e-12);
            // Once a hind foot is past its front foot's start, it steps where the front
            // foot did (the speed is d / 7T).
            if foot >= 2 && p[0] > footholds[FRONT_OF[foot]][0][0] + 0.06 {
                let reused = footholds[FRONT_OF[foot]].iter().any(|q| (q[0] - p[0]).hypot(q[1] - p[1]) < 0.005);
                assert!(reused, "hind foot {foot} at t = {t}: {p:?} is no front foothold");
            }
        }
    }
    assert!(used.iter().all(|u| *u), "a stone no foothold uses");
}

#[test]
fn the_walk_stops_on_its_last_stones() {
    let field = field(4, 1);
    let trot = *field.trot();
    let end = field.end();
    let last: Vec<[f64; 3]> = (0..4).map(|foot| trot.foothold_for(foot, end)).collect();
    for k in 0..40 {
        let t = end + 0.05 * k as f64;
        let reference = trot.reference(t);
        assert_eq!(reference.trunk_velocity, [0.0; 3]);
        for (foot, p) in last.iter().enumerate() {
            let q = trot.foothold_for(foot, t);
            assert!((0..3).all(|i| (q[i] - p[i]).abs() < 1e-12), "foot {foot} moved on after the end: {q:?}, {p:?}");
        }
    }
    // The trunk walked its duration at its speed, and stopped over its feet.
    let stopped = trot.reference(end).trunk_position;
    assert!((stopped[0] - trot.trunk[0] - trot.velocity[0] * trot.duration).abs() < 1e-12);
    let mean_x = last.iter().map(|p| p[0]).sum::<f64>() / 4.0;
    let home_mean = trot.home.iter().map(|p| p[0]).sum::<f64>() / 4.0;
    assert!((mean_x - home_mean - (stopped[0] - trot.trunk[0])).abs() <= trot.velocity[0] * trot.swing + 1e-9);
}

#[test]
fn a_seed_lays_the_same_field_and_its_displacements_span_their_bounds() {
    let (a, b, c) = (field(40, 11), field(40, 11), field(40, 12));
    assert_eq!(a.stones(), b.stones());
    assert_ne!(a.stones(), c.stones());
    // Against the undisplaced field (all bounds zero): within ±bound, and reaching most of it.
    let nominal =
        SteppingStones::new(&StoneField { strides: 40, seed: 11, displacement: [0.0; 3], ..StoneField::default() })
            .unwrap();
    let bounds = StoneField::default().displacement;
    let mut largest = [0.0_f64; 3];
    assert_eq!(a.stones().len(), nominal.stones().len());
    for (k, (s, n)) in a.stones().iter().zip(nominal.stones()).enumerate() {
        for axis in 0..3 {
            let d = s.top[axis] - n.top[axis];
            assert!(d.abs() <= bounds[axis] + 1e-12, "stone {k} axis {axis}: {d}");
            if k < 4 {
                assert_eq!(d, 0.0, "a starting stone moved");
            }
            largest[axis] = largest[axis].max(d.abs());
        }
    }
    for axis in 0..3 {
        assert!(largest[axis] > 0.9 * bounds[axis], "axis {axis}: at most {}", largest[axis]);
    }
}

#[test]
fn meaningless_fields_are_refused() {
    let ok = StoneField::default();
    for bad in [
        StoneField { strides: 0, ..ok },
        StoneField { swings_between: 6, ..ok },
        StoneField { swing: 0.0, ..ok },
        StoneField { swing: f64::NAN, ..ok },
        StoneField { size: -0.14, ..ok },
        StoneField { displacement: [0.05, 0.0, 0.0], ..ok },
        StoneField { displacement: [0.0, f64::INFINITY, 0.0], ..ok },
        StoneField { lift: -0.1, ..ok },
        StoneField { layout: StoneLayout::Rows { pitch: 0.15 }, ..StoneField::rows() },
        StoneField { layout: StoneLayout::Rows { pitch: f64::NAN }, ..StoneField::rows() },
        StoneField { layout: StoneLayout::Rows { pitch: 5.0 }, ..StoneField::rows() },
    ] {
        assert!(SteppingStones::new(&bad).is_err(), "{bad:?} was accepted");
    }
}

/// Seed 004's proposed controller (CBF in the MPC and in the whole-body QP) over three
/// strides of displaced stones, with eq. 25 on either set (the shrinking one at its γ of
/// 30 /s, the default; the region at 5 /s): every landing on a stone, at least a centimetre
/// inside it (the regions' margin is 2 cm) and level with its top, the trunk where the walk
/// ends, no fall.
#[test]
fn the_proposed_controller_walks_a_short_field_without_a_misstep() {
    let field = field(3, 5);
    for (barrier, gamma) in [(FootholdBarrier::Region, 5.0), (FootholdBarrier::Shrinking, 30.0)] {
        let settings = WalkSettings { barrier, gamma, ..WalkSettings::default() };
        let record = walk(&field, Controller::CbfInBoth, &settings).unwrap();
        assert_eq!(record.fell, None);
        // Three strides and the steps onto the last stones: each foot lands every 2T after
        // its first swing until the end.
        assert!(record.landings.len() >= 4 * 3, "{} landings", record.landings.len());
        for landing in &record.landings {
            assert_eq!(landing.misstep, 0.0, "{barrier:?}: {landing:?}");
            assert!(landing.height.abs() <= 0.01, "{barrier:?}: {landing:?}");
            let stone =
                field.stones().iter().find(|s| s.distance(landing.position[0], landing.position[1]) == 0.0).unwrap();
            let inside =
                stone.half - (landing.position[0] - stone.top[0]).abs().max((landing.position[1] - stone.top[1]).abs());
            assert!(inside >= 0.01, "{barrier:?}: {landing:?} is {inside} m inside its stone");
        }
        let trot = field.trot();
        let walked = trot.velocity[0] * trot.duration;
        assert!((record.travelled - walked).abs() <= 0.05, "walked {} of {walked} m", record.travelled);
        assert!(record.mpc_failures.0 * 10 <= record.mpc_failures.1, "{:?}", record.mpc_failures);
    }
}

/// The horizontal distance from `(x, y)` to the nearest stone's top square, computed here
/// from the corners (independent of `Stone::distance`).
fn off_every_stone(stones: &[Stone], x: f64, y: f64) -> f64 {
    stones
        .iter()
        .map(|s| {
            let (lo, hi) = ([s.top[0] - s.half, s.top[1] - s.half], [s.top[0] + s.half, s.top[1] + s.half]);
            let dx = (lo[0] - x).max(x - hi[0]).max(0.0);
            let dy = (lo[1] - y).max(y - hi[1]).max(0.0);
            (dx * dx + dy * dy).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn the_rows_lie_a_fixed_pitch_apart_wherever_the_trots_footholds_fall() {
    let field = SteppingStones::new(&StoneField { strides: 20, seed: 2, ..StoneField::rows() }).unwrap();
    let nominal =
        SteppingStones::new(&StoneField { strides: 20, seed: 2, displacement: [0.0; 3], ..StoneField::rows() })
            .unwrap();
    let trot = *field.trot();
    // The robot starts on four undisplaced stones under its feet.
    for (stone, home) in field.stones().iter().zip(trot.home) {
        assert!((stone.top[0] - home[0]).abs() < 1e-12 && (stone.top[1] - home[1]).abs() < 1e-12);
    }
    // Undisplaced, each side's stones are evenly spaced from its hind foot's start, the
    // spacing the requested 0.24 m rounded so the front foot's start is one of them.
    for left in [true, false] {
        let mut xs: Vec<f64> = nominal.stones().iter().filter(|s| (s.top[1] > 0.0) == left).map(|s| s.top[0]).collect();
        xs.sort_by(f64::total_cmp);
        let gaps: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        let pitch = gaps[0];
        assert!((pitch - 0.24).abs() < 0.05, "pitch {pitch}");
        assert!(gaps.iter().all(|g| (g - pitch).abs() < 1e-9), "{gaps:?}");
        // Displaced, within the bounds.
        for (s, n) in field.stones().iter().zip(nominal.stones()) {
            for axis in 0..3 {
                assert!((s.top[axis] - n.top[axis]).abs() <= StoneField::rows().displacement[axis] + 1e-12);
            }
        }
    }
    // Away from the gait: many of the trot's footholds are off every stone (the planner
    // must move them), and every one is within half a gap and a displacement of one.
    let (mut off, mut all) = (0, 0);
    for period in 2..40 {
        for foot in 0..4 {
            let p = trot.foothold_for(foot, (f64::from(period) + 0.5) * trot.swing);
            let d = off_every_stone(field.stones(), p[0], p[1]);
            off += usize::from(d > 0.0);
            all += 1;
            assert!(d <= 0.5 * (0.24 + 0.04 - 0.14) + 0.03 + 1e-9, "foothold {p:?} is {d} m from every stone");
        }
    }
    assert!(off * 4 >= all, "only {off} of {all} footholds off the stones");
}

fn count_missteps(field: &SteppingStones, record: &WalkRecord) -> usize {
    record.landings.iter().filter(|l| off_every_stone(field.stones(), l.position[0], l.position[1]) > 0.0).count()
}

/// Away from the gait, on three strides of rows: the proposed controller (eq. 25 in the MPC
/// and eq. 26 in the whole-body QP, on eq. 24's shrinking set) lands every foot on a stone;
/// the MPC baseline (stance feet constrained, swing feet not) missteps, and both records'
/// missteps are what the stones themselves say.
#[test]
fn away_from_the_gait_the_proposed_controller_makes_no_misstep_and_the_baseline_does() {
    let field = SteppingStones::new(&StoneField { strides: 3, seed: 1, ..StoneField::rows() }).unwrap();
    let settings = WalkSettings::default();
    let proposed = walk(&field, Controller::CbfInBoth, &settings).unwrap();
    let baseline = walk(&field, Controller::Baseline, &settings).unwrap();
    assert_eq!(proposed.fell, None);
    assert!(proposed.landings.len() >= 4 * 3, "{} landings", proposed.landings.len());
    assert_eq!(count_missteps(&field, &proposed), 0, "{:?}", proposed.missteps().collect::<Vec<_>>());
    assert_eq!(proposed.missteps().count(), 0);
    // Eq. 24's barrier values are the region's, raised on swing feet by the growth
    // 0.25 m · (1 − g(s)) with g(s) = s − sin(2πs)/2π the swing's travel at its phase s,
    // computed here.
    let swing = field.trot().swing;
    let mut raised_cycles = 0;
    assert_eq!(proposed.barriers.len(), proposed.shrinking_barriers.len());
    for ((t, h), h24) in proposed.barriers.iter().zip(&proposed.shrinking_barriers) {
        let phase = t.rem_euclid(swing) / swing;
        let travelled = phase - (std::f64::consts::TAU * phase).sin() / std::f64::consts::TAU;
        let growth = settings.shrinking_margin * (1.0 - travelled);
        for foot in 0..4 {
            let raised = h24[foot] - h[foot];
            assert!(raised == 0.0 || (raised - growth).abs() < 1e-9, "t {t}, foot {foot}: {raised} vs {growth}");
            raised_cycles += usize::from(raised > 0.0);
        }
    }
    // Two feet swing at a time after the first still period.
    assert!(raised_cycles * 3 >= proposed.barriers.len(), "{raised_cycles} of {}", proposed.barriers.len());
    let missed = count_missteps(&field, &baseline);
    assert_eq!(baseline.missteps().count(), missed);
    assert!(missed >= 1, "the baseline made no misstep away from the gait");
    eprintln!(
        "baseline: {missed} missteps of {} landings, mean {:.1} mm",
        baseline.landings.len(),
        1e3 * baseline.mean_misstep()
    );
}
