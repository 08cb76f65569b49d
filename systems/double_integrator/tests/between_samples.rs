//! The double integrator above its moving boundary `A sin(ω t) + c`, each input held for a
//! whole 1 ms period (zero-order hold) and the plant integrated exactly at Δt/100 in
//! between: without the sampled-data certificate `h` dips below 0 between the samples
//! although every row is met at every sample; with it, `h ≥ 0` at every fine step, and the
//! certificate's enclosures hold every value the row takes on the way.

use cbfgen::filter::between_samples::{RowEnclosure, Window};
use cbfgen::filter::{BetweenSamples, SampledData};
use cbfgen::interval::Interval;
use cbfgen::system::BarrierSet;
use cbfgen_double_integrator::pressed::{self, PERIOD, UPDATES};
use cbfgen_double_integrator::{default_settings, sine_barrier, Barriers, Capacity, Filter, Params};

fn params(omega: f64) -> Params {
    pressed::params(omega).unwrap()
}

/// A run of the shared closed loop, every input the QP's and every row met at the sample.
fn run(omega: f64, sampled: Option<SampledData>, delay: bool) -> pressed::Run {
    let r = pressed::run(omega, sampled, delay, false).unwrap();
    assert_eq!(r.not_met, 0, "ω = {omega}: every update's input is the QP's, every row met");
    r
}

#[test]
fn without_the_certificate_the_held_input_dips_below_the_boundary() {
    // The dips the certificate is for: measured, not assumed.
    for (omega, dip) in [(5.0, -1e-5), (20.0, -1e-4)] {
        let r = run(omega, None, false);
        assert!(r.min_h < dip, "ω = {omega}: least h {} (expected a dip below {dip})", r.min_h);
        assert_eq!(r.certified, 0);
    }
    assert!(run(5.0, None, true).min_h < -1e-5, "with a period of delay");
}

#[test]
fn with_the_certificate_h_stays_non_negative_at_every_fine_step() {
    for omega in [5.0, 20.0] {
        let r = run(omega, Some(SampledData::every_family(PERIOD)), false);
        assert!(r.min_h >= 0.0, "ω = {omega}: least h {}", r.min_h);
        assert_eq!(r.certified, UPDATES, "ω = {omega}: every update certified");
        assert!(r.max_margin > 0.0, "ω = {omega}: the boundary's motion needs a margin");
        // What it costs: h kept a little further from the boundary, not a different motion.
        assert!(r.min_h < 0.01, "ω = {omega}: least h {} (the filter still presses down)", r.min_h);
    }
}

#[test]
fn with_a_period_of_delay_the_certificate_covers_the_late_input() {
    let sampled = SampledData { input_delay: true, ..SampledData::every_family(PERIOD) };
    for omega in [5.0, 20.0] {
        let r = run(omega, Some(sampled.clone()), true);
        assert!(r.min_h >= 0.0, "ω = {omega}: least h {}", r.min_h);
        assert_eq!(r.certified, UPDATES, "ω = {omega}");
    }
}

/// A small deterministic generator (splitmix64), uniform in `[lo, hi)`.
struct Draw(u64);

impl Draw {
    fn next(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        lo + (hi - lo) * ((z >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// `flow` on intervals: an enclosure of the exact state after `tau` (itself an interval).
fn flow_enclosure(x: [Interval; 2], u: Interval, tau: Interval) -> [Interval; 2] {
    [x[0] + x[1] * tau + Interval::point(0.5) * u * tau * tau, x[1] + u * tau]
}

#[test]
fn the_enclosure_holds_every_value_the_row_takes_over_the_period() {
    // Random states, inputs, boundaries, periods and delays: at 1 000 instants of the
    // window, the exact h, L_f h, L_f² h, L_g L_f h and ψ = a·u + b on the exact trajectory
    // (each enclosed to ~1e-12 by the same kernel on point intervals, the trajectory's
    // closed form on intervals) lie in the certificate's enclosure over the whole window:
    // the margin it implies is never below the true deviation.
    let barriers = Barriers::new(Capacity {}).unwrap();
    let gains = default_settings().families[0].gains();
    let mut draw = Draw(62);
    for case in 0..2000 {
        let (omega, amplitude) = (draw.next(0.0, 50.0), draw.next(0.0, 0.5));
        let mut p = params(omega);
        p.sine_barrier[0].amplitude = amplitude;
        let x = [draw.next(-2.0, 2.0), draw.next(-5.0, 5.0)];
        let (t, u) = (draw.next(0.0, 100.0), draw.next(-1000.0, 1000.0));
        let period = 10f64.powf(draw.next(-5.0, -1.0));
        let before = (case % 2 == 1).then(|| draw.next(-1000.0, 1000.0));
        let window = Window { t, period, before: before.map(|b| [Interval::point(b)]), u: [u] };
        let mut e = [RowEnclosure::ZERO];
        barriers.enclose(&window, &x, &p, &[true], &mut e).unwrap_or_else(|err| panic!("case {case}: {err:?}"));
        let psi = gains.condition_enclosure(&e[0], &[u]);
        // The window: [t, t + Δt] under u, or [t + Δt, t + 2Δt] under u after Δt of `before`.
        let (i, pt) = (Interval::point, Interval::point(period));
        let (start, x0) = match before {
            None => (i(t), x.map(i)),
            Some(b) => (i(t) + pt, flow_enclosure(x.map(i), i(b), pt)),
        };
        let meets = |a: Interval, b: Interval| a.lo <= b.hi && b.lo <= a.hi;
        for j in 0..=1000 {
            let tau = pt * i(j as f64 / 1000.0);
            let y = flow_enclosure(x0, i(u), tau);
            let (lie, lg) = sine_barrier(&y, start + tau, i(amplitude), i(omega), i(0.0));
            assert!(lie[0][1].width() < 1e-9, "case {case}: the truth is known to {}", lie[0][1].width());
            for (d, v) in lie[0].iter().enumerate() {
                assert!(meets(e[0].lie[d], *v), "case {case}: L_f^{d} h = {v} outside {}", e[0].lie[d]);
            }
            assert!(meets(e[0].lg[0], lg[0][0]), "case {case}");
            let mut full = [i(0.0); cbfgen::system::MAX_RELATIVE_DEGREE + 1];
            full[..3].copy_from_slice(&lie[0]);
            let value = lg[0][0] * i(u) + gains.bound_enclosure(&full);
            assert!(meets(psi, value), "case {case}: ψ = {value} outside {psi}");
        }
    }
}

#[test]
fn enclosing_into_slices_of_another_length_is_a_typed_error() {
    use cbfgen::filter::between_samples::NotEnclosed;
    let barriers = Barriers::new(Capacity {}).unwrap();
    let window = Window { t: 0.0, period: PERIOD, before: None, u: [0.0] };
    let mut e = [RowEnclosure::ZERO; 2];
    for (wanted, out) in [(&[true, true][..], 1), (&[][..], 1), (&[true][..], 2), (&[true][..], 0)] {
        let got = barriers.enclose(&window, &[0.2, 0.0], &params(5.0), wanted, &mut e[..out]);
        assert_eq!(got, Err(NotEnclosed::LengthMismatch), "{} wanted, {out} out", wanted.len());
    }
}

#[test]
fn an_update_the_margins_could_not_certify_says_so() {
    // Pressed onto the boundary with one solve allowed: the row is tight at the sample, the
    // boundary moves within the period, and nothing may raise the margin — the update
    // reports the row, its deficit and why, instead of claiming the period.
    let mut settings = default_settings();
    settings.sampled_data = Some(SampledData { max_rounds: 1, ..SampledData::every_family(PERIOD) });
    let mut filter = Filter::new(Barriers::new(Capacity {}).unwrap(), settings).unwrap();
    let o = *filter.update_at(0.0, &[0.2, -2.0], &[-100.0], &params(20.0)).unwrap();
    match o.between_samples {
        BetweenSamples::Uncertified { rows: 1, worst: Some((0, deficit)), why } => {
            assert_eq!(why, cbfgen::filter::between_samples::Why::Deficit);
            assert!(deficit > 0.0 && deficit.is_finite());
            assert_eq!(filter.deficits()[0], deficit);
        }
        other => panic!("expected the one row uncertified: {other:?}"),
    }
}

#[test]
fn every_kernel_performs_the_operations_its_table_states() {
    // The certificate's kernels are the filter's: their cost, counted by running them on
    // numbers that count (cbfgen::ops::Counted), is what the generator stated.
    let checked = cbfgen::ops::check_stated(cbfgen_double_integrator::run_counted_kernels::<cbfgen::ops::Counted>)
        .unwrap_or_else(|m| panic!("{m:#?}"));
    assert_eq!(checked, cbfgen_double_integrator::KERNELS.len());
}

#[test]
fn evaluation_ops_is_what_evaluate_performs_in_its_kernels() {
    // The operations of the kernels evaluate calls, counted as they run on numbers that
    // count (cbfgen::ops::Counted) with evaluate's own time, state and parameters: the
    // state's part once, the instance's part once per instance the layout has. Each row
    // they compute is the one evaluate stored, so the calls are evaluate's.
    use cbfgen::ops::{Counted, OpCount};
    use cbfgen_double_integrator::{family, sine_barrier_instance, sine_barrier_state, SINE_BARRIER_ROW_NAMES};
    let mut barriers = Barriers::new(Capacity {}).unwrap();
    let stated = barriers.evaluation_ops().expect("the sine barrier states its count");
    let instances = barriers.layout().iter().filter(|l| l.family == family::SINE_BARRIER && l.row == 0).count();
    assert_eq!(instances * SINE_BARRIER_ROW_NAMES.len(), barriers.layout().len());
    for (t, x, omega) in [(0.3, [0.2, -2.0], 20.0), (1.7, [-0.4, 0.5], 5.0)] {
        let p = params(omega);
        barriers.evaluate(t, &x, &p).unwrap();
        let (part, mut counted) = Counted::measure(|| sine_barrier_state(&x.map(Counted), Counted(t)));
        for (row, q) in barriers.rows().iter().zip(&p.sine_barrier[..instances]) {
            let ((lie, lg), ops) = Counted::measure(|| {
                sine_barrier_instance(&part, Counted(q.amplitude), Counted(q.omega), Counted(q.offset))
            });
            counted = counted + ops;
            assert_eq!(row.lie[..3], lie[0].map(|v| v.0));
            assert_eq!(row.lg, lg[0].map(|v| v.0));
        }
        assert_eq!(stated, counted, "stated {stated}, counted {counted}");
        assert_ne!(counted, OpCount::ZERO);
    }
}

#[test]
fn a_certified_update_states_its_enclosures_in_operations_and_in_time() {
    // The enclosure's count: the field from the drift and input-matrix kernels' stated
    // counts and the product g·u (2 states × 1 input), the row's from the sine barrier's
    // stated count (one instance), each checked on counting numbers above. A certified
    // run's updates never pass the stated worst case in counts, and with the certificate
    // the bound has a time: every part states its count and the calibration times the
    // interval kernels.
    use cbfgen::ops::OpCount;
    let stated = |name: &str| cbfgen_double_integrator::KERNELS.iter().find(|k| k.name == name).unwrap().ops.unwrap();
    let barriers = Barriers::new(Capacity {}).unwrap();
    let e = barriers.enclosure_ops().expect("a generated set states its enclosure");
    assert_eq!(e.field, stated("drift") + stated("input_matrix") + OpCount { add: 2, mul: 2, ..OpCount::ZERO });
    assert_eq!((e.states, e.rows), (2, stated("sine_barrier")));
    for delay in [false, true] {
        let sampled = SampledData { input_delay: delay, ..SampledData::every_family(PERIOD) };
        let r = pressed::run(5.0, Some(sampled), delay, true).unwrap();
        let b = r.bound.expect("the run keeps its bound");
        let w = b.worst_case;
        assert_eq!(b.beyond_counts, 0, "{b}");
        let rounds = u64::from(w.enclosures);
        assert!(w.interval_ops.unwrap().total() >= rounds * e.window(delay).total(), "{b}");
        assert!(b.calibration.ns_per_interval_op > 0.0 && b.micros().is_some(), "{b}");
        println!("delay {delay}:\n{b}");
    }
}
