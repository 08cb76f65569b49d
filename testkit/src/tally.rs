//! How one side path of a no-allocation test went: what every run must do, and what the
//! runs did. Shared by the `no_alloc*` binaries. Recording an
//! outcome does not allocate (it runs inside the count).

use std::fmt::Debug;

/// The runs of one side path against its expected outcome.
pub struct Tally<O> {
    pub name: &'static str,
    pub expect: O,
    /// An outcome some runs may have instead, and the fraction of runs that must still
    /// take `expect` (a path that can legitimately finish once it has made progress over
    /// earlier runs, such as a solve continuing from where it stopped).
    pub also: Option<(O, f64)>,
    pub runs: usize,
    pub taken: usize,
    pub also_taken: usize,
    /// The first outcome that was neither, for the failure message.
    pub first_miss: Option<O>,
}

impl<O: Copy + PartialEq + Debug> Tally<O> {
    pub fn new(name: &'static str, expect: O) -> Self {
        Self { name, expect, also: None, runs: 0, taken: 0, also_taken: 0, first_miss: None }
    }

    /// As [`Tally::new`], with `also` allowed in up to `1 − min_fraction` of the runs.
    pub fn allowing(name: &'static str, expect: O, also: O, min_fraction: f64) -> Self {
        Self { also: Some((also, min_fraction)), ..Self::new(name, expect) }
    }

    /// Count one run's outcome.
    pub fn record(&mut self, outcome: O) {
        self.runs += 1;
        if outcome == self.expect {
            self.taken += 1;
        } else if self.also.is_some_and(|(also, _)| outcome == also) {
            self.also_taken += 1;
        } else {
            self.first_miss.get_or_insert(outcome);
        }
    }

    /// One line for the test's output, names padded to `width`.
    pub fn print(&self, width: usize) {
        println!("  {:<width$} {:>4} runs, {:>4} as expected ({:?})", self.name, self.runs, self.taken, self.expect);
    }

    /// The path ran `runs` times and every run did what it must.
    pub fn assert_every_run_taken(&self, runs: usize) {
        let min_fraction = self.also.map_or(1.0, |(_, f)| f);
        assert!(
            self.runs == runs
                && self.taken + self.also_taken == self.runs
                && self.taken as f64 >= min_fraction * self.runs as f64,
            "{}: {} of {} runs as expected, {} as allowed (of {runs} planned); first other outcome {:?}, expected {:?} ({:?})",
            self.name,
            self.taken,
            self.runs,
            self.also_taken,
            self.first_miss,
            self.expect,
            self.also
        );
    }
}
