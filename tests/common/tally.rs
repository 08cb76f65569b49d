//! How one side path of a no-allocation test went: what every run must do, and what the
//! runs did. Shared by the three `no_alloc*` binaries (included by path). Recording an
//! outcome does not allocate (it runs inside the count).
#![allow(dead_code)]

use std::fmt::Debug;

/// The runs of one side path against its expected outcome.
pub struct Tally<O> {
    pub name: &'static str,
    pub expect: O,
    pub runs: usize,
    pub taken: usize,
    /// The first outcome that was not `expect`, for the failure message.
    pub first_miss: Option<O>,
}

impl<O: Copy + PartialEq + Debug> Tally<O> {
    pub fn new(name: &'static str, expect: O) -> Self {
        Self { name, expect, runs: 0, taken: 0, first_miss: None }
    }

    /// Count one run's outcome.
    pub fn record(&mut self, outcome: O) {
        self.runs += 1;
        if outcome == self.expect {
            self.taken += 1;
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
        assert!(
            self.runs == runs && self.taken == self.runs,
            "{}: {} of {} runs as expected (of {runs} planned); first other outcome {:?}, expected {:?}",
            self.name,
            self.taken,
            self.runs,
            self.first_miss,
            self.expect
        );
    }
}
