//! One filter update of ANYmal C from a fresh process (standing, every foot on a square
//! foothold, a swinging nominal): the last step of the edit loop `scripts/cbf edit-loop
//! anymal` times (edit the spec, rebuild, run this). Prints the update's wall time.

use cbfgen::filter::EcbfFilter;
use cbfgen_anymal::generated::{self as gen, Barriers, NU, NX};
use cbfgen_anymal::{square_footholds, swinging_nominal};
use std::time::Instant;

fn main() {
    let start = Instant::now();
    let mut x = [0.0; NX];
    x[..NU].copy_from_slice(&gen::STANDING);
    let result = square_footholds(&x, 0.05, 0.0).and_then(|params| {
        let mut filter = EcbfFilter::new(Barriers::new(params.capacity())?, gen::default_settings())?;
        let u_ref = swinging_nominal(0.1, &x, 0.6, 1.0);
        filter.update(&x, &u_ref, &params).map(|out| out.u)
    });
    match result {
        Ok(_) => println!("first update: {:.3} ms after start", start.elapsed().as_secs_f64() * 1e3),
        Err(e) => {
            eprintln!("the first update failed: {e}");
            std::process::exit(1);
        }
    }
}
