//! What the sampled-data certificate buys and costs on the double integrator pressed onto
//! its moving boundary `0.1 sin(ω t)` for 3 s: each input held 1 ms (zero-order hold), the
//! plant's exact solution checked at Δt/100 in between. Without the certificate every row
//! is met at every sample and `h` still dips below 0 between them; with it, `h ≥ 0` at
//! every fine step, for a margin of micrometres. Then the filter's stated worst case per
//! update beside the most an update took, with the certificate off (in counts and in time)
//! and on (in counts: its enclosures state no time yet).
//!
//! ```sh
//! cargo run --release -p cbfgen-double-integrator --example between_samples
//! ```

use cbfgen::cpu_time::median_p99_max;
use cbfgen::filter::SampledData;
use cbfgen_double_integrator::pressed::{run, PERIOD, UPDATES};

fn main() -> Result<(), cbfgen::CbfError> {
    println!(
        "{:>4} {:>6} {:>12} | {:>14} {:>12} {:>9} {:>6} | CPU µs per update, median: off / on",
        "ω", "delay", "least h off", "least h on", "max margin", "certified", "extra"
    );
    let mut bounds = Vec::new();
    for omega in [5.0, 20.0] {
        for delay in [false, true] {
            let off = run(omega, None, delay, true)?;
            let sampled = SampledData { input_delay: delay, ..SampledData::every_family(PERIOD) };
            let mut on = run(omega, Some(sampled), delay, true)?;
            let mut off_cpu = off.cpu_us;
            println!(
                "{omega:>4} {delay:>6} {:>9.2} µm | {:>11.2} µm {:>9.3} {:>5}/{} {:>6} | {:.2} / {:.2}",
                off.min_h * 1e6,
                on.min_h * 1e6,
                on.max_margin,
                on.certified,
                UPDATES,
                on.extra_solves,
                median_p99_max(&mut off_cpu)[0],
                median_p99_max(&mut on.cpu_us)[0],
            );
            assert!(on.min_h >= 0.0 && on.certified == UPDATES && on.not_met + off.not_met == 0);
            bounds.extend([("off", off.bound), ("on", on.bound)].map(|(k, b)| (omega, delay, k, b)));
        }
    }
    println!("(margin in the row's units, m/s²; extra: QP solves beyond one, over the run)");
    println!("\nworst case per update, stated / most measured:");
    for (omega, delay, certificate, bound) in bounds {
        let Some(b) = bound else { continue };
        let (w, m) = (b.worst_case, b.most);
        let time = b.micros().map_or_else(|| "not stated".to_string(), |us| format!("{us:.1} µs"));
        println!(
            "ω {omega:>4}, delay {delay:>5}, certificate {certificate:>3}: {} / {} QP solves, {} / {} dense-solver trips; in time {time}, most {:.1} µs",
            w.qp_solves,
            m.qp_solves,
            w.dense_trips,
            m.dense_trips,
            b.max_cpu.as_secs_f64() * 1e6
        );
        assert_eq!(b.beyond_counts, 0, "an update beyond its stated worst case");
    }
    Ok(())
}
