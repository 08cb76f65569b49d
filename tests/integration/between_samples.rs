//! The sampled-data certificate's contract through the filter, on a barrier set written by
//! hand (which has no interval form): it says so instead of certifying, leaves the answer
//! as it is, and its settings have a documented domain.

use cbfgen::filter::between_samples::{
    enclose_flow, enclose_window, EnclosureOps, Why, Window, MAX_FIELD_CALLS, MAX_PIECES, MAX_ROUNDS,
};
use cbfgen::filter::{BetweenSamples, EcbfFilter, FilterSettings, InputSource, SampledData};
use cbfgen::interval::Interval;
use cbfgen::system::{BarrierSet, ClassK, FamilyInfo, FamilyKind, FamilyParams, InstanceKind, Poles, Row, RowLayout};

/// A cart behind a wall at `p = 1`: `h = 1 − p`, relative degree 2 in the acceleration.
struct Wall([Row<1>; 1]);

const FAMILIES: [FamilyInfo; 1] = [FamilyInfo {
    name: "wall",
    kind: FamilyKind::Barrier,
    relative_degree: 2,
    row_names: &["wall"],
    members: &[],
    instances: InstanceKind::Fixed,
    count: 1,
    params: &[],
    defaults: FamilyParams {
        poles: Poles::from_array([10.0, 10.0]),
        priority: 0,
        activation: f64::INFINITY,
        class_k: ClassK::LINEAR,
    },
}];
const LAYOUT: [RowLayout; 1] = [RowLayout { family: 0, member: 0, instance: 0, row: 0, columns: &[0] }];

impl BarrierSet<1> for Wall {
    type State = [f64; 2];
    type Params = ();
    fn families(&self) -> &[FamilyInfo] {
        &FAMILIES
    }
    fn layout(&self) -> &[RowLayout] {
        &LAYOUT
    }
    fn rows(&self) -> &[Row<1>] {
        &self.0
    }
    fn evaluate(&mut self, _t: f64, x: &[f64; 2], _: &()) -> Result<(), cbfgen::CbfError> {
        self.0[0].store(&[1.0 - x[0], -x[1], 0.0], &[-1.0], &[0]);
        Ok(())
    }
}

fn filter(sampled: Option<SampledData>) -> EcbfFilter<Wall, 1> {
    let mut settings = FilterSettings::defaults(&FAMILIES, [-5.0], [5.0]);
    settings.sampled_data = sampled;
    EcbfFilter::new(Wall([Row::ZERO]), settings).unwrap()
}

#[test]
fn a_barrier_set_without_an_interval_form_is_reported_not_certified_and_its_answer_kept() {
    let mut plain = filter(None);
    let mut asked = filter(Some(SampledData::every_family(1e-3)));
    for x in [[0.9, 0.5], [0.5, 0.0], [0.99, 0.2]] {
        let off = *plain.update(&x, &[3.0], &()).unwrap();
        let on = *asked.update(&x, &[3.0], &()).unwrap();
        assert_eq!(off.between_samples, BetweenSamples::Off);
        assert_eq!(on.source, InputSource::Qp);
        // One solve, no margin: the same bits as without the certificate.
        assert_eq!(on.u[0].to_bits(), off.u[0].to_bits(), "at {x:?}");
        assert_eq!(asked.margins(), &[0.0]);
        match on.between_samples {
            BetweenSamples::Uncertified { rows: 1, worst: None, why: Why::NoIntervalForm } => {}
            other => panic!("at {x:?}: {other:?}"),
        }
    }
}

#[test]
fn an_exempt_family_is_not_asked_for_and_the_update_is_certified() {
    let sampled = SampledData { exempt: vec![0], ..SampledData::every_family(1e-3) };
    let out = *filter(Some(sampled)).update(&[0.9, 0.5], &[3.0], &()).unwrap();
    assert_eq!(out.between_samples, BetweenSamples::Certified { rounds: 1 });
}

#[test]
fn sampled_data_settings_outside_their_domain_are_typed_errors() {
    let bad = [
        SampledData::every_family(0.0),
        SampledData::every_family(f64::NAN),
        SampledData::every_family(2.0),
        SampledData { max_rounds: 0, ..SampledData::every_family(1e-3) },
        SampledData { max_rounds: MAX_ROUNDS + 1, ..SampledData::every_family(1e-3) },
        SampledData { exempt: vec![1], ..SampledData::every_family(1e-3) },
    ];
    for sampled in bad {
        let mut settings = FilterSettings::defaults(&FAMILIES, [-5.0], [5.0]);
        settings.sampled_data = Some(sampled.clone());
        assert!(EcbfFilter::new(Wall([Row::ZERO]), settings).is_err(), "{sampled:?} accepted");
    }
}

#[test]
fn the_flow_enclosure_holds_a_pendulum_and_gives_up_on_a_blow_up() {
    // θ'' = −sin θ from (θ, ω) = (1, 0) for 0.5 s: the enclosure holds the solution (RK4 at
    // 1e-4 s, far finer than the box) at every step.
    let reach = enclose_flow(&[Interval::point(1.0), Interval::point(0.0)], 0.5, |x| {
        use cbfgen::scalar::Scalar;
        Some([x[1], -x[0].sin()])
    })
    .expect("a pendulum's half second is enclosed");
    let b = reach.states;
    let f = |y: &[f64; 2]| Ok::<_, std::convert::Infallible>([y[1], -y[0].sin()]);
    let mut y = [1.0, 0.0];
    for _ in 0..5000 {
        let Ok(next) = cbfgen::system::rk4_step(f, &y, 1e-4);
        y = next;
        assert!(b[0].contains(y[0]) && b[1].contains(y[1]), "{y:?} outside {b:?}");
        // Its velocity, (ω, −sin θ), is in the field's enclosure.
        assert!(reach.field[0].contains(y[1]) && reach.field[1].contains(-y[0].sin()));
    }
    // And the end state is in the end's enclosure.
    assert!(reach.end[0].contains(y[0]) && reach.end[1].contains(y[1]), "{y:?} outside {:?}", reach.end);
    // ẋ = x² from 1 leaves every box before t = 1 (it blows up there): no enclosure.
    assert!(enclose_flow(&[Interval::point(1.0)], 1.5, |x| Some([x[0] * x[0]])).is_none());
}

#[test]
fn an_enclosure_never_evaluates_the_field_more_often_than_its_stated_bound() {
    // The worst case of an enclosure counts MAX_PIECES flows of MAX_FIELD_CALLS field
    // evaluations each (twice with a delayed input). Fields from gentle to too fast for any
    // piece, held and delayed: the evaluations counted never pass it, and the fast ones
    // halve the period (more flows than one) or give up.
    use std::cell::Cell;
    let mut most = 0;
    let mut halved = false;
    for rate in [0.1, 10.0, 300.0, 3e3, 3e4, 3e5, 3e6] {
        for delayed in [false, true] {
            let calls = Cell::new(0u32);
            let window =
                Window { t: 0.0, period: 1e-3, before: delayed.then_some([Interval::new(-1.0, 1.0)]), u: [0.5] };
            // q̇ = v, v̇ = rate² (sin q − q) + u: a stiff, non-linear flow at high rates.
            let field = |b: &[Interval; 2], u: &[Interval; 1]| {
                use cbfgen::scalar::Scalar;
                calls.set(calls.get() + 1);
                let k = Interval::point(rate * rate);
                Some([b[1] * Interval::point(rate), k * (b[0].sin() - b[0]) + u[0]])
            };
            let enclosed = enclose_window(&window, &[0.3, -0.2], field).is_ok();
            let bound = MAX_PIECES * MAX_FIELD_CALLS * if delayed { 2 } else { 1 };
            assert!(calls.get() <= bound, "rate {rate}, delayed {delayed}: {} calls, bound {bound}", calls.get());
            most = most.max(calls.get());
            halved |= enclosed && calls.get() > (1 + u32::from(delayed)) * MAX_FIELD_CALLS;
        }
    }
    assert!(halved, "no field was fast enough to need more than one piece (most {most} calls)");
    // The count itself: each flow's calls, per-state steps and end, then the rows.
    let e = EnclosureOps {
        field: cbfgen::ops::OpCount { mul: 3, ..Default::default() },
        states: 2,
        refine: cbfgen::ops::OpCount { add: 5, ..Default::default() },
        rows: cbfgen::ops::OpCount { div: 7, ..Default::default() },
    };
    let per_flow = u64::from(MAX_FIELD_CALLS) * (3 + 2 * (5 + 3 + 9)) + 2 * (1 + 1 + 4);
    assert_eq!(e.window(false).total(), u64::from(MAX_PIECES) * per_flow + 5 + 7);
    assert_eq!(e.window(true).total(), 2 * u64::from(MAX_PIECES) * per_flow + 5 + 7);
}
