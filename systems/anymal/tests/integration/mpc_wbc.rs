//! Both layers of seed 004 on the rigid-contact plant ([`cbfgen_anymal::plant`], 2 kHz):
//! the kino-dynamic MPC every 40 ms on the measured state, the whole-body controller at
//! 400 Hz tracking its plan. A 0.3 m/s trot: the distance the command asks for, no sway
//! of the kind the fixed trot reference alone shows (6.6 cm, tests/wbc.rs), every
//! whole-body cycle solved.

use cbfgen_anymal::gait::{standing_on_the_ground, Trot};
use cbfgen_anymal::mpc::{state_from_whole_body, KinodynamicMpc, MpcSettings, Region};
use cbfgen_anymal::plant;
use cbfgen_anymal::wbc::{WbcSettings, WholeBodyController, FEET};
use cbfgen_anymal::wbc_generated::{Capacity, Params};

const SIM_DT: f64 = 5e-4;
const STEPS_PER_CYCLE: usize = 5;
const CYCLES_PER_PLAN: usize = 16;

#[test]
fn the_mpc_and_the_whole_body_controller_trot_at_the_commanded_speed() {
    let mut x = standing_on_the_ground();
    let trot = Trot::from_standing(0.3, 0.08, [0.3, 0.0]);
    let mut mpc = KinodynamicMpc::new(MpcSettings::default()).unwrap();
    let mut wbc = WholeBodyController::new(Capacity { foot_region: [0; FEET] }, WbcSettings::default()).unwrap();
    let no_footholds = Params::new(Capacity { foot_region: [0; FEET] }).unwrap();
    let dt = SIM_DT * STEPS_PER_CYCLE as f64;
    let seconds = 4.0;
    let (mut sway, mut lowest, mut highest) = (0.0_f64, f64::INFINITY, f64::NEG_INFINITY);
    for cycle in 0..(seconds / dt).round() as usize {
        let t = cycle as f64 * dt;
        if cycle % CYCLES_PER_PLAN == 0 {
            let report = mpc.solve(t, &state_from_whole_body(&x), &trot, &|_, _| Region::GROUND).unwrap();
            assert!(report.updated, "t = {t:.3}: {report:?}");
        }
        let reference = mpc.whole_body_reference(t, &trot).unwrap();
        let out = wbc.update(t, &x, &reference, &no_footholds, dt).unwrap();
        assert!(out.solved, "t = {t:.3}: {:?}", out.levels);
        for _ in 0..STEPS_PER_CYCLE {
            let step = plant::accelerations(&x, &out.torques, reference.stance).expect("regular contacts");
            plant::integrate(&mut x, &step.accelerations, SIM_DT);
        }
        if t > 1.0 {
            sway = sway.max((x[1] - trot.trunk[1]).abs());
            lowest = lowest.min(x[2]);
            highest = highest.max(x[2]);
        }
    }
    // 0.3 m/s from the end of the first still swing (0.3 s): 1.11 m.
    let travelled = x[0] - trot.trunk[0];
    assert!((travelled - 1.11).abs() <= 0.06, "the trunk went {travelled} m");
    // The whole-body plant is not the MPC's rigid body, and the loop shows it: the trunk
    // drifts 4.9 cm to one side although every plan steers it back (the fixed trot
    // reference alone: 6.6 cm), and its height creeps up 4.2 cm over the run. These
    // bounds guard what was measured; closing the gap is open (docs/anymal.md).
    assert!(sway <= 0.06, "the trunk swayed {sway} m sideways");
    assert!(highest - lowest <= 0.05, "the trunk's height varied {lowest}..{highest} m");
}
