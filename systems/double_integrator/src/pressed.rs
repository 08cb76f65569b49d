//! The closed loop the sampled-data certificate is measured on: the double integrator
//! pressed onto its moving boundary `0.1 sin(ω t)` for 3 s (nominal −100 m/s², limits
//! ±1000, from `h = 0.2`, at rest: inside the ECBF's safe set), each input held for a
//! whole 1 ms period, and the plant's exact solution checked at Δt/100 in between. Shared
//! by `examples/between_samples.rs` and `tests/between_samples.rs`.

use crate::{default_settings, Barriers, Capacity, Filter, Params, SineBarrierParams};
use cbfgen::filter::{BetweenSamples, BoundCheck, InputSource, SampledData};

/// The control period \[s\].
pub const PERIOD: f64 = 1e-3;
/// Exact-solution checks per period.
pub const FINE: usize = 100;
/// The boundary's amplitude \[m\].
pub const AMPLITUDE: f64 = 0.1;
/// Updates in a run (3 s).
pub const UPDATES: usize = 3000;

/// The boundary's parameters at `omega` \[rad/s\].
///
/// # Errors
/// None for this system (its capacity is fixed); kept for the generated API's shape.
pub fn params(omega: f64) -> Result<Params, cbfgen::CbfError> {
    let mut p = Params::new(Capacity {})?;
    p.sine_barrier[0] = SineBarrierParams { amplitude: AMPLITUDE, omega, offset: 0.0 };
    Ok(p)
}

/// `q, q'` after `tau` seconds of `u` from `x`: the exact solution.
pub fn flow(x: [f64; 2], u: f64, tau: f64) -> [f64; 2] {
    [x[0] + x[1] * tau + 0.5 * u * tau * tau, x[1] + u * tau]
}

/// What one run measured.
#[derive(Debug, Clone, Default)]
pub struct Run {
    /// The least `h` over every fine step \[m\].
    pub min_h: f64,
    /// Updates certified.
    pub certified: usize,
    /// QP solves beyond one per update, over the certified updates.
    pub extra_solves: usize,
    /// The largest margin the row was given \[m/s²\].
    pub max_margin: f64,
    /// Updates whose input was not the QP's verified answer, or whose rows were not met
    /// at the sample.
    pub not_met: usize,
    /// Each update's CPU time \[µs\], where the settings measured it.
    pub cpu_us: Vec<f64>,
    /// The filter's stated worst case per update (calibrated on this machine before the
    /// run) beside the most an update took.
    pub bound: Option<BoundCheck>,
}

/// One 3 s run at `omega`, the certificate as `sampled` says; with `delay`, the plant
/// holds the previous update's input during each period (the first: 0).
///
/// # Errors
/// Settings the filter refuses, or a state it rejects.
pub fn run(
    omega: f64,
    sampled: Option<SampledData>,
    delay: bool,
    measure_cpu_time: bool,
) -> Result<Run, cbfgen::CbfError> {
    let mut settings = default_settings();
    (settings.input_min, settings.input_max) = ([-1000.0], [1000.0]);
    settings.sampled_data = sampled;
    settings.measure_cpu_time = measure_cpu_time;
    let mut filter = Filter::new(Barriers::new(Capacity {})?, settings)?;
    let p = params(omega)?;
    let (mut x, mut held) = ([0.2, 0.0], 0.0);
    let mut bound = BoundCheck::new(filter.worst_case(), filter.calibrate(0.0, &x, &p)?);
    let mut out = Run { min_h: f64::INFINITY, ..Run::default() };
    for k in 0..UPDATES {
        let t = k as f64 * PERIOD;
        let o = *filter.update_at(t, &x, &[-100.0], &p)?;
        bound.record(&o);
        out.not_met += usize::from(o.source != InputSource::Qp || !o.safety.is_met());
        if let BetweenSamples::Certified { rounds } = o.between_samples {
            out.certified += 1;
            out.extra_solves += (rounds - 1) as usize;
        }
        out.max_margin = out.max_margin.max(filter.margins()[0]);
        out.cpu_us.extend(o.cpu_time.map(|d| d.as_secs_f64() * 1e6));
        let u = if delay { std::mem::replace(&mut held, o.u[0]) } else { o.u[0] };
        for j in 1..=FINE {
            let tau = PERIOD * j as f64 / FINE as f64;
            out.min_h = out.min_h.min(flow(x, u, tau)[0] - AMPLITUDE * (omega * (t + tau)).sin());
        }
        x = flow(x, u, PERIOD);
    }
    out.bound = Some(bound);
    Ok(out)
}
