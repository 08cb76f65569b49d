//! The run-time door (`cbfgen::dynamic`) against the typed API it wraps: parameters
//! written as hand-flattened numbers against the typed helpers (`Environment`,
//! `EdgeCuboid::kernel_args`); a `DynFilter` against the typed `Tachyon3Filter` along one
//! closed loop, bit for bit; drift and input matrix against the generated dynamics; typed
//! errors that leave parameters and filter as they were (a twin filter that never saw an
//! error is the truth); optional and capacity semantics against the rows they switch and
//! `h` computed by hand; a registry of the built-in system crates against the spec files on disk.

use cbfgen::dynamic::{CapacityCount, DynBarriers, DynParams, DynSystem, Registry};
use cbfgen::filter::Output;
use cbfgen::param_domain::{Domain, Found};
use cbfgen::system::{ControlAffine, InstanceKind};
use cbfgen::{CbfError, OrientedBox};
use cbfgen_double_integrator as di;
use cbfgen_tachyon3::catalog::Tachyon3FilterExt;
use cbfgen_tachyon3::catalog::{self, EdgeCuboid, Environment, HalfPlane, StabilityBound, Tachyon3Filter};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::{self, State, BODY_X, NU, NX, TOE_BLOCK};
use nalgebra::{Rotation3, Vector3};

const DT: f64 = 1e-3;
const FLOORS: [f64; 6] = [0.0, -0.01, -0.02, 0.0, -0.005, -0.03];
const SWING: [bool; 6] = [true, false, true, false, false, false];

/// Every built-in system, as a binary that links their crates lists them.
static SYSTEMS: Registry = Registry::new(&[
    cbfgen_anymal::generated::SYSTEM,
    di::SYSTEM,
    cbfgen_panda::generated::SYSTEM,
    cbfgen_panda_spheres::generated::SYSTEM,
    gen::SYSTEM,
]);

fn tachyon3() -> &'static dyn DynSystem {
    SYSTEMS.get("tachyon3").expect("tachyon3 is built in")
}

fn count(family: usize, member: usize, count: usize) -> CapacityCount {
    CapacityCount { family, member, count }
}

/// Tachyon 3's families with parameters, looked up by name: foot_height, stability,
/// body_edge, toe_edge, foothold.
fn fam(sys: &dyn DynSystem) -> Result<[usize; 5], CbfError> {
    let names = ["foot_height", "stability", "body_edge", "toe_edge", "foothold"];
    let f: Vec<usize> = names.into_iter().map(|n| sys.family_index(n)).collect::<Result<_, _>>()?;
    assert_eq!(f, [1, 2, 3, 4, 5], "the spec's order");
    Ok([f[0], f[1], f[2], f[3], f[4]])
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn assert_err<T>(got: Result<T, CbfError>, want: CbfError) {
    assert_eq!(got.err(), Some(want));
}

/// An edge cuboid's 15 numbers written out by hand: centre, rotation row by row, half extents.
fn edge_numbers(b: &OrientedBox) -> Vec<f64> {
    let (c, r, h) = (b.center(), b.rotation().matrix(), b.half_extents());
    let row = |i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]];
    [[c.x, c.y, c.z], row(0), row(1), row(2), [h.x, h.y, h.z]].concat()
}

/// The typed environment, the same through the run-time door, and the latter's capacity.
type Scene = (Environment, Box<dyn DynParams>, Vec<CapacityCount>);

/// One scene built twice, through the typed helpers and through hand-flattened numbers: room
/// for 2 edges (one pushed), LF swinging with 2 foothold half-planes and RF with 1 (axis
/// normals, so `HalfPlane::new` stores them exactly), floors, and MF's lower stability bound.
fn scene(edge: &OrientedBox) -> Result<Scene, CbfError> {
    let mut env = Environment::new(catalog::Capacity::edges(2, [2, 0, 1, 0, 0, 0]))?;
    env.push_edge(EdgeCuboid::from_box(edge))?;
    env.set_foothold(0, &[HalfPlane::new([1.0, 0.0], 0.2)?, HalfPlane::new([0.0, -1.0], 0.5)?])?;
    env.set_foothold(2, &[HalfPlane::new([-1.0, 0.0], 0.8)?])?;
    env.set_floors(FLOORS);
    env.set_swing(SWING);
    env.stability[1][0] = Some(StabilityBound { a: 1.0, b: 0.3 });

    let sys = tachyon3();
    let [feet, stab, body, toe, hold] = fam(sys)?;
    let counts = vec![count(body, 0, 2), count(toe, 0, 2), count(hold, 0, 2), count(hold, 2, 1)];
    let mut p = sys.params(&counts)?;
    p.push(body, 0, &edge_numbers(edge))?;
    p.push(toe, 0, &edge_numbers(edge))?;
    p.push(hold, 0, &[1.0, 0.0, 0.2])?;
    p.push(hold, 0, &[0.0, -1.0, 0.5])?;
    p.push(hold, 2, &[-1.0, 0.0, 0.8])?;
    for (leg, z) in FLOORS.into_iter().enumerate() {
        p.set(feet, leg, 0, &[z])?;
    }
    for leg in (0..6).filter(|&leg| !SWING[leg]) {
        p.store_mut(hold, leg)?.set_enabled(false)?;
    }
    p.set(stab, 1, 0, &[1.0, 0.3])?;
    Ok((env, p, counts))
}

/// Instance `instance` of `family`/`member` as `get` returns it: `None` for an empty slot.
fn get(p: &dyn DynParams, family: usize, member: usize, instance: usize) -> Result<Option<Vec<f64>>, CbfError> {
    let store = p.store(family, member)?;
    let mut out = vec![f64::NAN; store.width()];
    Ok(store.get(instance, &mut out)?.then_some(out))
}

#[test]
fn hand_flattened_parameters_equal_the_typed_environment() -> Result<(), CbfError> {
    let edge = OrientedBox::new(
        Vector3::new(0.9, 0.1, 0.08),
        Rotation3::from_euler_angles(0.3, -0.2, 0.5),
        Vector3::new(0.03, 0.8, 0.05),
    )?;
    let r = edge.rotation().matrix();
    // R = Rz(0.5) Ry(−0.2) Rx(0.3) is far from symmetric (a transposed layout would show),
    // and r[(row, column)]: the first column is (cos ψ cos θ, sin ψ cos θ, −sin θ).
    assert!((r[(0, 1)] - r[(1, 0)]).abs() > 0.5 && (r[(0, 2)] - r[(2, 0)]).abs() > 0.1);
    assert!((r[(1, 0)] - 0.5f64.sin() * 0.2f64.cos()).abs() < 1e-15 && (r[(2, 0)] - 0.2f64.sin()).abs() < 1e-15);

    let (env, p, _) = scene(&edge)?;
    assert_eq!(p.system(), "tachyon3");
    assert_eq!(p.downcast_ref::<gen::Params>().expect("tachyon3's parameters"), &env);

    let [feet, stab, body, toe, hold] = fam(tachyon3())?;
    let numbers = edge_numbers(&edge);
    let expected: [(usize, usize, usize, Option<Vec<f64>>); 9] = [
        (body, 0, 0, Some(numbers.clone())),
        (body, 0, 1, None),
        (toe, 0, 0, Some(numbers)),
        (hold, 0, 0, Some(vec![1.0, 0.0, 0.2])),
        (hold, 0, 1, Some(vec![0.0, -1.0, 0.5])),
        (hold, 2, 0, Some(vec![-1.0, 0.0, 0.8])),
        (stab, 1, 0, Some(vec![1.0, 0.3])),
        (stab, 1, 1, None),
        (stab, 0, 0, None),
    ];
    for (family, member, instance, want) in expected {
        assert_eq!(get(p.as_ref(), family, member, instance)?, want, "{family}/{member}/{instance}");
    }
    for (leg, (z, swing)) in FLOORS.into_iter().zip(SWING).enumerate() {
        assert_eq!(get(p.as_ref(), feet, leg, 0)?, Some(vec![z]));
        assert_eq!(p.store(hold, leg)?.is_enabled(), swing);
    }
    // MF has no foothold room: its slot 0 does not exist.
    assert_err(get(p.as_ref(), hold, 1, 0), CbfError::NoSuchIndex { what: "instance", index: 0, len: 0 });

    // The flat layout (Python, the type-erased layer): rotation at 3..12, row by row.
    let shapes: [(&str, &[usize]); 3] = [("center", &[3]), ("rotation", &[3, 3]), ("half", &[3])];
    assert_eq!(tachyon3().families()[body].params, shapes);
    let (center, rotation, half) = env.edges()[0].kernel_args();
    let flat = get(p.as_ref(), body, 0, 0)?.expect("pushed");
    let rows = rotation.transpose(); // nalgebra stores columns: the transpose's storage is R row by row
    assert_eq!((&flat[0..3], &flat[3..12], &flat[12..15]), (center.as_slice(), rows.as_slice(), half.as_slice()));
    Ok(())
}

/// The report with its timings zeroed (the only fields two runs may not share).
fn untimed(r: Output<&[f64]>) -> Output<Vec<u64>> {
    Output { eval_time: Default::default(), solve_time: Default::default(), cpu_time: None, ..r.map_input(|u| bits(u)) }
}

/// Tachyon 3 at 1 m/s with a slightly yawed step edge 6 cm ahead of the mid toe, nominal
/// accelerating into it: the toe–edge rows bind within the first cycles.
fn approach() -> Result<(State, [f64; NU], Scene), CbfError> {
    let edge = OrientedBox::new(
        Vector3::new(0.8, 0.0, 0.06),
        Rotation3::from_euler_angles(0.0, 0.0, 0.05),
        Vector3::new(0.02, 1.0, 0.02),
    )?;
    let scene = scene(&edge)?;
    let mut x = model::standard_posture();
    x[gen::state::V] = 1.0;
    let mut u_ref = [0.0; NU];
    u_ref[gen::input::A] = 2.0;
    Ok((x, u_ref, scene))
}

fn step(x: &mut State, u: &[f64]) {
    let u: [f64; NU] = u.try_into().expect("nu inputs");
    let dx = model::xdot(x, &u);
    for (xi, d) in x.iter_mut().zip(dx) {
        *xi += DT * d;
    }
}

#[test]
fn a_dyn_filter_is_bit_identical_to_the_typed_filter_along_a_closed_loop() -> Result<(), CbfError> {
    let (mut x, u_ref, (env, p, counts)) = approach()?;
    let sys = tachyon3();
    assert_eq!(sys.default_settings(), cbfgen::dynamic::DynSettings::from(catalog::default_settings()));
    let mut typed = Tachyon3Filter::with_capacity(env.capacity(), catalog::default_settings())?;
    let mut erased = sys.filter(&counts, &sys.default_settings())?;
    assert_eq!(erased.settings(), sys.default_settings());
    let mut bent = 0;
    for k in 0..50 {
        let out = *typed.update(&x, &u_ref, &env)?;
        erased.update(k as f64 * DT, &x, &u_ref, p.as_ref())?;
        assert_eq!(untimed(erased.output()), untimed(out.map_input(|u| u.as_slice())), "cycle {k}");
        assert_eq!((erased.active(), bits(erased.delta())), (typed.active(), bits(typed.delta())));
        assert_eq!(erased.layout(), cbfgen::system::BarrierSet::layout(typed.barriers()));
        for (i, row) in typed.rows().iter().enumerate() {
            let view = erased.row(i).expect("same row count");
            assert_eq!((bits(view.lie), bits(view.lg), view.active), (bits(&row.lie), bits(&row.lg), row.active));
        }
        assert!(erased.row(typed.rows().len()).is_none());
        bent += usize::from(out.u[gen::input::A] < u_ref[gen::input::A] - 0.1);
        step(&mut x, &out.u);
    }
    assert!(bent > 10, "the edge should bend the nominal input ({bent} cycles did)");
    Ok(())
}

fn dynamics_agree<S: ControlAffine<N, M>, const N: usize, const M: usize>(
    sys: &dyn DynSystem,
    x: &[f64; N],
    u: &[f64; M],
    xdot: fn(&[f64; N], &[f64; M]) -> [f64; N],
) -> Result<(), CbfError> {
    assert_eq!((sys.name(), sys.nx(), sys.nu()), (S::NAME, N, M));
    let (mut f, mut g) = (vec![0.0; N], vec![0.0; N * M]);
    sys.drift(x, &mut f)?;
    sys.input_matrix(x, &mut g)?;
    assert_eq!(bits(&f), bits(&S::drift(x)));
    let typed = S::input_matrix(x);
    let mut dx = f.clone();
    for i in 0..N {
        for j in 0..M {
            assert_eq!(g[i * M + j].to_bits(), typed[i][j].to_bits(), "g[{i}][{j}]");
            dx[i] += g[i * M + j] * u[j];
        }
    }
    assert_eq!(dx, xdot(x, u));
    assert_err(sys.drift(&x[1..], &mut f), CbfError::LengthMismatch { what: "state", expected: N, got: N - 1 });
    assert_err(
        sys.input_matrix(x, &mut g[1..]),
        CbfError::LengthMismatch { what: "input matrix output", expected: N * M, got: N * M - 1 },
    );
    Ok(())
}

#[test]
fn drift_and_input_matrix_equal_the_generated_dynamics() -> Result<(), CbfError> {
    for k in 0..4 {
        let mut x = model::standard_posture();
        for (i, v) in x.iter_mut().enumerate() {
            *v += 0.3 * ((7 * i + 3 * k) as f64).sin() * f64::from(k > 0);
        }
        let u: [f64; NU] = std::array::from_fn(|j| ((j + k) as f64).cos());
        dynamics_agree::<gen::Tachyon3, NX, NU>(tachyon3(), &x, &u, gen::xdot)?;
    }
    let planar = SYSTEMS.get("double_integrator").expect("built in");
    for (x, u) in [([0.3, -1.2], [0.7]), ([-2.0, 0.5], [-3.0]), ([0.0, 0.0], [0.0])] {
        dynamics_agree::<di::DoubleIntegrator, { di::NX }, { di::NU }>(planar, &x, &u, di::xdot)?;
    }
    Ok(())
}

#[test]
fn refused_updates_name_the_error_and_change_nothing() -> Result<(), CbfError> {
    let sys = tachyon3();
    let [feet, stab, body, _, hold] = fam(sys)?;
    let (mut x, u_ref, (_, mut p, counts)) = approach()?;
    let before = p.clone_box();
    let unchanged = |p: &dyn DynParams| {
        assert_eq!(p.downcast_ref::<gen::Params>(), before.downcast_ref::<gen::Params>());
    };

    // Parameter stores.
    assert_err(p.push(feet, 0, &[0.0]), CbfError::Unsupported { operation: "push", kind: "fixed" });
    assert_err(p.push(stab, 0, &[1.0, 0.0]), CbfError::Unsupported { operation: "push", kind: "optional" });
    assert_err(p.store_mut(feet, 0)?.remove(0), CbfError::Unsupported { operation: "remove", kind: "fixed" });
    assert_err(p.store_mut(feet, 0)?.clear(), CbfError::Unsupported { operation: "clear", kind: "fixed" });
    assert_err(p.store_mut(body, 0)?.remove(0), CbfError::Unsupported { operation: "remove", kind: "capacity" });
    let optional = CbfError::Unsupported { operation: "set_enabled", kind: "optional" };
    assert_err(p.store_mut(stab, 0)?.set_enabled(false), optional);
    let length = |expected, got| CbfError::LengthMismatch { what: "instance parameters", expected, got };
    assert_err(p.set(feet, 0, 0, &[0.0, 1.0]), length(1, 2));
    assert_err(p.push(body, 0, &[0.0; 14]), length(15, 14));
    assert_err(p.store(stab, 1)?.get(0, &mut [0.0; 3]), length(2, 3));
    // stability's b (member mf), and rotation entry (1, 1) of the edge (flat index 7):
    // refused as outside Real, naming family, member, instance and parameter.
    type Case = (usize, usize, usize, &'static str, Option<&'static str>, &'static str, fn(f64) -> Found);
    let cases: [Case; 2] = [
        (stab, 1, 1, "stability", Some("mf"), "b", Found::Value),
        (body, 0, 7, "body_edge", None, "rotation", |value| Found::MatrixEntry { row: 1, col: 1, value }),
    ];
    for (family_index, member_index, k, family, member, param, found) in cases {
        let stored = get(p.as_ref(), family_index, member_index, 0)?;
        let mut values = stored.clone().expect("set in the scene");
        let refusal = |found| CbfError::ParamOutOfDomain {
            family,
            member,
            instance: Some(0),
            param,
            domain: Domain::Real,
            found,
        };
        values[k] = 1e300;
        assert_err(p.set(family_index, member_index, 0, &values), refusal(found(1e300)));
        // NaN compares unequal to itself, so the message says what was found.
        values[k] = f64::NAN;
        let nan = p.set(family_index, member_index, 0, &values).expect_err("NaN refused");
        assert_eq!(nan.to_string(), refusal(found(f64::NAN)).to_string());
        assert!(nan.to_string().ends_with("= NaN"), "{nan}");
        assert_eq!(get(p.as_ref(), family_index, member_index, 0)?, stored);
    }
    let far = p.set(hold, 0, 1, &[1.0, 0.0, -1e300]);
    assert_err(
        far,
        CbfError::ParamOutOfDomain {
            family: "foothold",
            member: Some("lf"),
            instance: Some(1),
            param: "offset",
            domain: Domain::Real,
            found: Found::Value(-1e300),
        },
    );
    let no = |what, index, len| CbfError::NoSuchIndex { what, index, len };
    assert_err(p.set(feet, 0, 1, &[0.0]), no("instance", 1, 1));
    assert_err(p.set(stab, 0, 2, &[1.0, 0.0]), no("instance", 2, 2));
    assert_err(p.set(body, 0, 1, &[0.0; 15]), no("instance", 1, 1)); // 2 slots, 1 pushed
    assert_err(get(p.as_ref(), body, 0, 2), no("instance", 2, 2));
    assert_err(p.set(7, 0, 0, &[0.0]), no("family", 7, 7));
    assert_err(p.set(feet, 6, 0, &[0.0]), no("member", 6, 6));
    assert_err(p.set(body, 1, 0, &[0.0; 15]), no("member", 1, 1));
    let free = CbfError::Unsupported { operation: "parameter access", kind: "parameter-free" };
    assert_err(p.store(sys.family_index("joint_limits")?, 0), free);
    let known = "joint_limits, foot_height, stability, body_edge, toe_edge, foothold, foothold_pull";
    let unknown = CbfError::UnknownName { what: "family", name: "stairs".into(), known: known.into() };
    assert_err(p.family_index("stairs"), unknown.clone());
    assert_err(sys.family_index("stairs"), unknown);
    unchanged(p.as_ref());

    // Capacities.
    let fixed = CbfError::Unsupported { operation: "a capacity", kind: "fixed-count" };
    assert_err(sys.params(&[count(feet, 0, 1)]), fixed.clone());
    assert_err(sys.filter(&[count(feet, 0, 1)], &sys.default_settings()), fixed);
    let large = CbfError::TooLarge { what: "body_edge capacity", value: 1026, max: 1025 };
    assert_err(sys.params(&[count(body, 0, 1026)]), large.clone());
    assert_err(sys.filter(&[count(body, 0, 1026)], &sys.default_settings()), large);
    let large = CbfError::TooLarge { what: "foothold capacity", value: 257, max: 256 };
    assert_err(sys.params(&[count(hold, 3, 257)]), large);
    assert_err(sys.params(&[count(hold, 6, 1)]), no("member", 6, 6));
    assert_err(sys.params(&[count(9, 0, 1)]), no("family", 9, 7));

    // Another system's parameters.
    let planar = SYSTEMS.get("double_integrator").expect("built in");
    let other = planar.params(&[])?;
    let mismatch = CbfError::SystemMismatch { expected: "tachyon3", got: "double_integrator" };
    assert_err(sys.barriers_for(other.as_ref()), mismatch.clone());
    let mut rows = sys.barriers_for(p.as_ref())?;
    assert_err(rows.evaluate(0.0, &x, other.as_ref()), mismatch.clone());
    let short = CbfError::LengthMismatch { what: "state", expected: NX, got: NX - 1 };
    assert_err(rows.evaluate(0.0, &x[1..], p.as_ref()), short.clone());
    assert_err(
        planar.filter(&[], &sys.default_settings()),
        CbfError::LengthMismatch { what: "input_weights", expected: 1, got: NU },
    );

    // Updates: filter `a` sees a refused update before every cycle, twin `b` never does.
    let mut a = sys.filter(&counts, &sys.default_settings())?;
    let mut b = sys.filter(&counts, &sys.default_settings())?;
    let small = sys.params(&[count(body, 0, 1)])?;
    let mut smuggled = p.clone_box();
    smuggled.downcast_mut::<gen::Params>().expect("tachyon3's").stability[0][1] =
        Some(StabilityBound { a: f64::INFINITY, b: 0.0 });
    for k in 0..11 {
        let t = k as f64 * DT;
        let (mut nan_state, mut far_state) = (x, x);
        (nan_state[3], far_state[BODY_X]) = (f64::NAN, 1e6);
        let mut nan_ref = u_ref;
        nan_ref[5] = f64::NAN;
        let refused = match k {
            0 => a.update(t, &x[..NX - 1], &u_ref, p.as_ref()),
            1 => a.update(t, &x, &u_ref[..NU - 1], p.as_ref()),
            2 => a.update(t, &x, &u_ref, other.as_ref()),
            3 => a.update(t, &nan_state, &u_ref, p.as_ref()),
            4 => a.update(t, &far_state, &u_ref, p.as_ref()),
            5 => a.update(t, &x, &nan_ref, p.as_ref()),
            6 => a.update(t, &x, &u_ref, small.as_ref()),
            7 => a.update(t, &x, &u_ref, smuggled.as_ref()),
            8 => a.update(t, &x, &[1e7; NU], p.as_ref()),
            9 => a.update(f64::NAN, &x, &u_ref, p.as_ref()), // no family reads t; still refused
            _ => a.update(t, &[x.as_slice(), &[0.0]].concat(), &u_ref, p.as_ref()),
        };
        let e = refused.expect_err("refused");
        let ok = match k {
            0 => e == short,
            1 => e == CbfError::LengthMismatch { what: "nominal input", expected: NU, got: NU - 1 },
            2 => e == mismatch,
            3 | 5 => matches!(e, CbfError::NonFinite { .. }),
            7 => matches!(
                e,
                CbfError::ParamOutOfDomain {
                    family: "stability",
                    member: Some("lf"),
                    instance: Some(1),
                    param: "a",
                    ..
                }
            ),
            9 => matches!(e, CbfError::NonFinite { what: "time", .. }),
            4 => matches!(e, CbfError::OutOfRange { value: 1e6, .. }),
            6 => e == CbfError::CapacityMismatch,
            8 => matches!(e, CbfError::OutOfRange { value: 1e7, .. }),
            _ => e == CbfError::LengthMismatch { what: "state", expected: NX, got: NX + 1 },
        };
        assert!(ok, "refusal {k}: {e:?}");
        a.update(t, &x, &u_ref, p.as_ref())?;
        b.update(t, &x, &u_ref, p.as_ref())?;
        assert_eq!(untimed(a.output()), untimed(b.output()), "after refusal {k}");
        assert_eq!((a.active(), bits(a.delta())), (b.active(), bits(b.delta())));
        step(&mut x, b.output().u);
    }
    unchanged(p.as_ref());
    Ok(())
}

/// `(instance, h, active)` of every row of `family`/`member`, as last evaluated.
fn rows(b: &dyn DynBarriers, family: usize, member: usize) -> Vec<(usize, f64, bool)> {
    let layout = b.layout().iter().enumerate().filter(|(_, l)| l.family == family && l.member == member);
    layout.map(|(i, l)| b.row(i).map(|r| (l.instance, r.lie[0], r.active)).expect("a row")).collect()
}

#[test]
fn optional_slots_and_capacity_lists_switch_their_rows() -> Result<(), CbfError> {
    let sys = tachyon3();
    let [_, stab, _, _, hold] = fam(sys)?;
    let x = model::standard_posture();
    let mut p = sys.params(&[count(hold, 0, 2)])?;
    let mut b = sys.barriers_for(p.as_ref())?;
    // Stability h = a (x_toe − x_body) + b for LF: lower (1, 0.5) and upper (−1, 0.5).
    let reach = x[TOE_BLOCK] - x[BODY_X];
    for leg in [0, 4] {
        p.set(stab, leg, 0, &[1.0, 0.5])?;
        p.set(stab, leg, 1, &[-1.0, 0.5])?;
    }
    b.evaluate(0.0, &x, p.as_ref())?;
    let lf = rows(b.as_ref(), stab, 0);
    assert_eq!(lf.iter().map(|r| (r.0, r.2)).collect::<Vec<_>>(), [(0, true), (1, true)]);
    assert!((lf[0].1 - (reach + 0.5)).abs() < 1e-12 && (lf[1].1 - (0.5 - reach)).abs() < 1e-12, "{lf:?}");
    assert!(rows(b.as_ref(), stab, 2).iter().all(|r| !r.2));

    p.store_mut(stab, 0)?.remove(0)?;
    assert_eq!((get(p.as_ref(), stab, 0, 0)?, p.store(stab, 0)?.len()), (None, 1));
    b.evaluate(0.0, &x, p.as_ref())?;
    assert_eq!(rows(b.as_ref(), stab, 0).iter().map(|r| r.2).collect::<Vec<_>>(), [false, true]);
    for leg in [0, 4] {
        let store = p.store_mut(stab, leg)?;
        store.clear()?;
        assert_eq!((store.len(), store.slots(), store.is_empty()), (0, 2, true));
        assert_eq!((get(p.as_ref(), stab, leg, 0)?, get(p.as_ref(), stab, leg, 1)?), (None, None));
    }
    b.evaluate(0.0, &x, p.as_ref())?;
    assert!((0..6).all(|leg| rows(b.as_ref(), stab, leg).iter().all(|r| !r.2)));

    // LF foothold, room for 2: h = n · toe_xy + offset in the world frame.
    let toe = gen::world_kinematics(&x).2[0];
    p.push(hold, 0, &[1.0, 0.0, 0.2])?;
    p.push(hold, 0, &[0.0, -1.0, 0.5])?;
    assert_err(p.push(hold, 0, &[1.0, 0.0, 0.0]), CbfError::CapacityExceeded { what: "foothold", capacity: 2 });
    assert_eq!((p.store(hold, 0)?.len(), get(p.as_ref(), hold, 0, 1)?), (2, Some(vec![0.0, -1.0, 0.5])));
    b.evaluate(0.0, &x, p.as_ref())?;
    let lf = rows(b.as_ref(), hold, 0);
    assert!(lf.iter().all(|r| r.2) && lf.len() == 2);
    assert!((lf[0].1 - (toe[0] + 0.2)).abs() < 1e-12 && (lf[1].1 - (0.5 - toe[1])).abs() < 1e-12, "{lf:?}");

    p.store_mut(hold, 0)?.set_enabled(false)?;
    let store = p.store(hold, 0)?;
    assert_eq!((store.len(), store.slots(), store.is_enabled()), (2, 2, false));
    b.evaluate(0.0, &x, p.as_ref())?;
    assert!(rows(b.as_ref(), hold, 0).iter().all(|r| !r.2));
    p.store_mut(hold, 0)?.set_enabled(true)?;
    p.set(hold, 0, 1, &[0.0, 1.0, 0.1])?;
    b.evaluate(0.0, &x, p.as_ref())?;
    let lf = rows(b.as_ref(), hold, 0);
    assert!(lf.iter().all(|r| r.2) && (lf[1].1 - (toe[1] + 0.1)).abs() < 1e-12, "{lf:?}");
    p.store_mut(hold, 0)?.clear()?;
    assert_eq!((p.store(hold, 0)?.len(), get(p.as_ref(), hold, 0, 0)?), (0, None));
    b.evaluate(0.0, &x, p.as_ref())?;
    assert!(rows(b.as_ref(), hold, 0).iter().all(|r| !r.2));
    Ok(())
}

#[test]
fn the_registry_holds_every_spec_with_consistent_sizes_and_widths() -> Result<(), CbfError> {
    // Each crate under systems/ with a spec named after its folder is a generated system.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let mut specs: Vec<String> = std::fs::read_dir(dir)
        .expect("the systems directory")
        .map(|e| e.expect("an entry").file_name().into_string().expect("UTF-8"))
        .filter(|n| std::path::Path::new(dir).join(n).join("spec").join(format!("{n}.py")).is_file())
        .collect();
    specs.sort();
    let names: Vec<&str> = SYSTEMS.names().collect();
    assert_eq!(names, specs, "built-in systems, in name order");
    assert!(matches!(SYSTEMS.get("stairs"), Err(CbfError::UnknownName { .. })));
    for &sys in SYSTEMS.systems() {
        assert_eq!(SYSTEMS.get(sys.name()).map(|s| s.name()), Ok(sys.name()));
        assert_eq!((sys.nx(), sys.nu()), (sys.state_names().len(), sys.input_names().len()), "{}", sys.name());
        assert_eq!((sys.input_min().len(), sys.input_max().len()), (sys.nu(), sys.nu()));
        let p = sys.params(&[])?;
        assert_eq!((p.system(), p.families()), (sys.name(), sys.families()));
        for (i, family) in sys.families().iter().enumerate() {
            let members = family.members.len().max(1);
            for m in 0..members {
                let what = format!("{}.{} member {m}", sys.name(), family.name);
                match p.store(i, m) {
                    Err(e) => {
                        assert!(family.params.is_empty(), "{what}: {e}");
                        assert_eq!(e, CbfError::Unsupported { operation: "parameter access", kind: "parameter-free" });
                    }
                    Ok(store) => {
                        let width: usize = family.params.iter().map(|(_, shape)| shape.iter().product::<usize>()).sum();
                        assert!(width > 0, "{what}");
                        assert_eq!((store.width(), store.kind()), (width, family.instances), "{what}");
                        let slots = if family.instances == InstanceKind::Capacity { 0 } else { family.count };
                        assert_eq!(store.slots(), slots, "{what}");
                        if family.instances == InstanceKind::Capacity {
                            // `count` is the most a member may reserve.
                            let most = sys.params(&[count(i, m, family.count)])?;
                            assert_eq!(most.store(i, m)?.slots(), family.count, "{what}");
                            let over = sys.params(&[count(i, m, family.count + 1)]);
                            assert!(matches!(over, Err(CbfError::TooLarge { .. })), "{what}");
                        }
                    }
                }
            }
            assert_err(p.store(i, members), CbfError::NoSuchIndex { what: "member", index: members, len: members });
        }
    }
    Ok(())
}
