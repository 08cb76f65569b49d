//! ANYmal C's control paths allocate nothing: 5 s of the swinging legs on square
//! footholds (joint limits, velocity limits, 20 foothold rows, 30 self-collision pairs),
//! with a NaN state rejected now and then; and 5 s of the whole-body controller trotting in
//! place on square footholds (its three levels, the foothold CBF), a NaN state rejected
//! now and then; and 2 s of the kino-dynamic MPC's iterations and the references it hands
//! the whole-body controller. Counted for Rust's global allocator and for the
//! C `malloc` family OSQP calls; no test harness (`harness = false`), so `main` runs the
//! one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;

use cbfgen::filter::{EcbfFilter, InputSource};
use cbfgen_anymal::gait::{footholds_around, standing_on_the_ground, Trot};
use cbfgen_anymal::generated::{self as gen, Barriers, NU, NX};
use cbfgen_anymal::mpc::{self, KinodynamicMpc, MpcSettings, Region};
use cbfgen_anymal::plant;
use cbfgen_anymal::stones::{SteppingStones, StoneField};
use cbfgen_anymal::walk::{Controller, LayeredController, WalkSettings};
use cbfgen_anymal::wbc::{WbcSettings, WholeBodyController};
use cbfgen_anymal::wbc_generated as wbc;
use cbfgen_anymal::{square_footholds, swinging_nominal};

fn main() {
    the_filter_allocates_nothing();
    the_whole_body_controller_allocates_nothing();
    the_mpc_allocates_nothing();
    the_layered_controller_allocates_nothing();
}

fn the_layered_controller_allocates_nothing() {
    for threaded in [false, true] {
        let stones = SteppingStones::new(&StoneField { strides: 2, ..StoneField::default() }).expect("stones");
        let settings = WalkSettings { threaded, ..WalkSettings::default() };
        let mut layers =
            LayeredController::new(*stones.trot(), stones.terrain().clone(), Controller::CbfInBoth, &settings)
                .expect("controller");
        let mut x = standing_on_the_ground();
        let dt = settings.cycle();
        let (cycles, mut planned, mut rejected) = (200, 0usize, 0usize);
        // Threaded: the MPC thread's solves run while this counts, and are counted too.
        let (_, rust, c) = alloc_count::counting(|| {
            for k in 0..cycles {
                let t = k as f64 * dt;
                if k % 50 == 7 {
                    let mut nan = x;
                    nan[0] = f64::NAN;
                    rejected += usize::from(layers.update(t, &nan).is_err());
                }
                let cycle = layers.update(t, &x).expect("in the domain");
                planned += usize::from(cycle.planned);
                for _ in 0..settings.steps_per_cycle {
                    let step = plant::accelerations(&x, &cycle.out.torques, cycle.reference.stance).expect("regular");
                    plant::integrate(&mut x, &step.accelerations, settings.plant_step);
                }
                if threaded {
                    // Let the thread solve now and then (this loop outruns real time).
                    std::thread::sleep(std::time::Duration::from_micros(500));
                }
            }
        });
        assert_eq!((rust, c), (0, 0), "threaded {threaded}: allocations during {cycles} cycles: Rust {rust}, C {c}");
        if !threaded {
            assert_eq!(planned, cycles);
        }
        assert_eq!(rejected, cycles / 50);
        drop(layers);
    }
    println!("the_layered_controller_allocates_nothing ... ok");
}

fn the_mpc_allocates_nothing() {
    // Both solvers: the interior-point method (the default) and OSQP.
    for settings in [MpcSettings::default(), MpcSettings::default().with_admm()] {
        the_mpc_allocates_nothing_with(settings);
    }
    println!("the_mpc_allocates_nothing ... ok");
}

fn the_mpc_allocates_nothing_with(settings: MpcSettings) {
    let trot = Trot::from_standing(0.3, 0.08, [0.3, 0.0]);
    let mut mpc = KinodynamicMpc::new(settings).expect("mpc");
    let mut x = mpc::standing();
    let region = |_: usize, _: f64| Region::GROUND;
    let (dt, iterations) = (0.04, 50);
    let (mut solved, mut rejected) = (0usize, 0usize);
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..iterations {
            let t = k as f64 * dt;
            solved += usize::from(mpc.solve(t, &x, &trot, &region).expect("in the domain").updated);
            if k % 10 == 0 {
                let mut nan = x;
                nan[4] = f64::NAN;
                rejected += usize::from(mpc.solve(t, &nan, &trot, &region).is_err());
            }
            let reference = mpc.whole_body_reference(t, &trot).expect("a plan");
            assert!(reference.stance.iter().any(|s| *s));
            let (_, u) = mpc.plan_at(t).expect("a plan");
            x = mpc::integrate(&x, &u, dt);
        }
    });
    let method = settings.method;
    assert_eq!((rust, c), (0, 0), "{method:?}: allocations during {iterations} iterations: Rust {rust}, C {c}");
    assert_eq!(solved, iterations, "{method:?}");
    assert_eq!(rejected, iterations / 10);
}

fn the_whole_body_controller_allocates_nothing() {
    let mut x = standing_on_the_ground();
    let home = wbc::contacts(&x).0;
    let params = footholds_around(&home, 0.03).expect("footholds");
    let gait = Trot::in_place(0.3, 0.08, 0.1, home, [x[0], x[1], x[2]]);
    // (The counters were shown to count by the filter's check, in this process.)
    let mut controller = WholeBodyController::new(params.capacity(), WbcSettings::default()).expect("controller");
    let dt = 2.5e-3;
    let (mut solved, mut rejected) = (0usize, 0usize);
    let cycles = 2000;
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..cycles {
            let t = k as f64 * dt;
            let reference = gait.reference(t);
            let out = controller.update(t, &x, &reference, &params, dt).expect("in the domain");
            solved += usize::from(out.solved);
            if k % 100 == 0 {
                let mut nan = x;
                nan[14] = f64::NAN;
                rejected += usize::from(controller.update(t, &nan, &reference, &params, dt).is_err());
            }
            // The model's own motion (the accelerations it planned), enough to move the rows.
            plant::integrate(&mut x, &out.accelerations, dt);
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during {cycles} cycles: Rust {rust}, C {c}");
    assert_eq!(solved, cycles);
    assert_eq!(rejected, cycles / 100);
    println!("the_whole_body_controller_allocates_nothing ... ok");
}

fn the_filter_allocates_nothing() {
    let mut x = [0.0; NX];
    x[..NU].copy_from_slice(&gen::STANDING);
    let params = square_footholds(&x, 0.05, 0.0).expect("footholds");
    let new_filter =
        || EcbfFilter::new(Barriers::new(params.capacity()).unwrap(), gen::default_settings()).expect("filter");
    let mut filter = new_filter();
    alloc_count::assert_counters_work(new_filter);
    let dt = 1e-3;
    let (mut solved, mut rejected) = (0usize, 0usize);
    let cycles = 5000;
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..cycles {
            let u_ref = swinging_nominal(k as f64 * dt, &x, 0.6, 1.5);
            let out = *filter.update(&x, &u_ref, &params).expect("in the domain");
            solved += usize::from(out.source == InputSource::Qp);
            if k % 100 == 0 {
                let mut nan = x;
                nan[9] = f64::NAN;
                rejected += usize::from(filter.update(&nan, &u_ref, &params).is_err());
            }
            for i in 0..NU {
                x[i] += dt * x[NU + i] + 0.5 * dt * dt * out.u[i];
                x[NU + i] += dt * out.u[i];
            }
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during {cycles} cycles: Rust {rust}, C {c}");
    assert_eq!(solved, cycles);
    assert_eq!(rejected, cycles / 100);
    println!("the_anymal_filter_allocates_nothing ... ok");
}
