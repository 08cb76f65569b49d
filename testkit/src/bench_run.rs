//! Whether a bench binary was started to measure (`cargo bench`) or to check that it runs
//! (`cargo test --benches`, CI's smoke run).
//!
//! Cargo passes `--bench` to a bench binary only under `cargo bench`; criterion reads the
//! same argument to run each benchmark once when it is missing. The benches' own tables
//! (interleaved rounds, repeated walks) follow the same rule: all their repetitions when
//! measuring, one when checked, which still runs every assertion they make.

/// True when the process was started by `cargo bench` (its arguments hold `--bench`).
pub fn measuring() -> bool {
    measuring_with(std::env::args())
}

/// [`measuring`] for the arguments `args`.
///
/// ```
/// use cbfgen_testkit::bench_run::measuring_with;
/// let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>().into_iter();
/// assert!(measuring_with(args(&["bench-binary", "--bench"])));
/// assert!(measuring_with(args(&["bench-binary", "--rounds", "3", "--bench", "filter"])));
/// assert!(!measuring_with(args(&["bench-binary"])));
/// assert!(!measuring_with(args(&["bench-binary", "--benchmark"])));
/// ```
pub fn measuring_with(mut args: impl Iterator<Item = String>) -> bool {
    args.any(|a| a == "--bench")
}

/// `timed` repetitions when measuring, one otherwise.
pub fn repetitions(timed: usize) -> usize {
    if measuring() {
        timed
    } else {
        1
    }
}
