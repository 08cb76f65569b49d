//! Operation counts: what one evaluation of a generated kernel costs, stated by the
//! generator and checked by running the kernel.
//!
//! A generated kernel is straight-line code: it performs the same operations whatever its
//! inputs, so its cost is a number the generator can state when it prints the kernel. Each
//! line of a module's [`kernel_table!`](crate::kernel_table!) carries that count
//! ([`OpCount`], in [`KernelEntry::ops`](crate::system::KernelEntry::ops)); the counts are
//! what a worst-case bound on an update's row evaluation is built from.
//!
//! [`Counted`] is the independent check: a [`Scalar`] that is `f64` and counts every
//! operation it performs. Running a kernel on it counts what the compiled code does, which
//! must be what the generator stated ([`check_stated`]).
//!
//! ```
//! use cbfgen::ops::{Counted, OpCount};
//! use cbfgen::scalar::Scalar;
//!
//! fn h<S: Scalar>(q: S, qd: S) -> S {
//!     S::from(2.0) * q - qd.sin()
//! }
//! let (value, ops) = Counted::measure(|| h(Counted(1.0), Counted(0.5)));
//! assert_eq!(value.0, 2.0 - 0.5f64.sin());
//! assert_eq!(ops, OpCount { add: 1, mul: 1, elementary: 1, ..OpCount::ZERO });
//! ```

use core::cell::Cell;
use core::ops::{Add, Div, Mul, Neg, Sub};

use crate::scalar::Scalar;

/// Floating-point operations by kind: what a kernel performs once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct OpCount {
    /// Additions and subtractions.
    pub add: u64,
    /// Negations (a sign flip).
    pub neg: u64,
    /// Multiplications, squares included.
    pub mul: u64,
    /// Divisions.
    pub div: u64,
    /// Square roots.
    pub sqrt: u64,
    /// Calls of a libm function: `exp`, `ln`, the trigonometric and hyperbolic functions
    /// and their inverses, `atan2`, `powf`.
    pub elementary: u64,
    /// Elements of the batched [`crate::lanes`] calls (`exp`, `tanh`, `ln` in SIMD lanes).
    pub lanes: u64,
    /// `max` and `abs`.
    pub compare: u64,
}

impl OpCount {
    /// No operation.
    pub const ZERO: Self = Self { add: 0, neg: 0, mul: 0, div: 0, sqrt: 0, elementary: 0, lanes: 0, compare: 0 };

    /// From the counts in field order: what a [`kernel_table!`](crate::kernel_table!) line's
    /// `ops [..]` holds.
    pub const fn new(counts: [u64; 8]) -> Self {
        let [add, neg, mul, div, sqrt, elementary, lanes, compare] = counts;
        Self { add, neg, mul, div, sqrt, elementary, lanes, compare }
    }

    /// The counts in field order.
    pub const fn to_array(self) -> [u64; 8] {
        [self.add, self.neg, self.mul, self.div, self.sqrt, self.elementary, self.lanes, self.compare]
    }

    /// Every operation, whatever its kind.
    pub const fn total(self) -> u64 {
        let [a, b, c, d, e, f, g, h] = self.to_array();
        a + b + c + d + e + f + g + h
    }

    /// Both counts together (saturating: a bound never wraps to a small number).
    pub const fn plus(self, other: Self) -> Self {
        let (a, b) = (self.to_array(), other.to_array());
        let mut out = [0; 8];
        let mut k = 0;
        while k < 8 {
            out[k] = a[k].saturating_add(b[k]);
            k += 1;
        }
        Self::new(out)
    }

    /// `n` times the count (saturating).
    pub const fn times(self, n: u64) -> Self {
        let a = self.to_array();
        let mut out = [0; 8];
        let mut k = 0;
        while k < 8 {
            out[k] = a[k].saturating_mul(n);
            k += 1;
        }
        Self::new(out)
    }

    /// This count plus, for each `(state, instance, slots)`, what a barrier set performs
    /// in a kernel cut in two for one member of a capacity family: the `state` part once
    /// when the member has a slot, the `instance` part once per slot (saturating). What a
    /// generated [`BarrierSet::evaluation_ops`](crate::system::BarrierSet::evaluation_ops)
    /// sums its run-time capacities with.
    pub const fn plus_slots(self, members: &[(Self, Self, usize)]) -> Self {
        let mut sum = self;
        let mut k = 0;
        while k < members.len() {
            let (state, instance, slots) = members[k];
            if slots > 0 {
                sum = sum.plus(state).plus(instance.times(slots as u64));
            }
            k += 1;
        }
        sum
    }
}

impl Add for OpCount {
    type Output = Self;
    fn add(self, rhs: Self) -> Self {
        self.plus(rhs)
    }
}

impl core::fmt::Display for OpCount {
    /// `1234 operations (560 add, 12 neg, 600 mul, 3 div, 4 sqrt, 20 libm, 8 lanes, 27 compare)`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{} operations ({} add, {} neg, {} mul, {} div, {} sqrt, {} libm, {} lanes, {} compare)",
            self.total(),
            self.add,
            self.neg,
            self.mul,
            self.div,
            self.sqrt,
            self.elementary,
            self.lanes,
            self.compare
        )
    }
}

thread_local! {
    static COUNT: Cell<OpCount> = const { Cell::new(OpCount::ZERO) };
}

/// Add to this thread's count.
fn tally(f: impl FnOnce(&mut OpCount)) {
    COUNT.with(|c| {
        let mut n = c.get();
        f(&mut n);
        c.set(n);
    });
}

/// An `f64` that counts, on its thread, every operation performed on it: the instrumented
/// count a kernel's stated [`OpCount`] is checked against. Not for the control path (each
/// operation touches a thread-local).
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Counted(pub f64);

impl Counted {
    /// Run `f` and return its result with the operations performed on `Counted` values in
    /// it (on this thread; nested measurements each see their own).
    pub fn measure<R>(f: impl FnOnce() -> R) -> (R, OpCount) {
        let before = COUNT.with(|c| c.replace(OpCount::ZERO));
        let r = f();
        let counted = COUNT.with(|c| c.replace(before));
        (r, counted)
    }
}

impl From<f64> for Counted {
    /// A constant: no operation.
    fn from(x: f64) -> Self {
        Self(x)
    }
}

macro_rules! counted_binary {
    ($trait:ident, $method:ident, $field:ident) => {
        impl $trait for Counted {
            type Output = Self;
            fn $method(self, rhs: Self) -> Self {
                tally(|n| n.$field += 1);
                Self(self.0.$method(rhs.0))
            }
        }
    };
}
counted_binary!(Add, add, add);
counted_binary!(Sub, sub, add);
counted_binary!(Mul, mul, mul);
counted_binary!(Div, div, div);

impl Neg for Counted {
    type Output = Self;
    fn neg(self) -> Self {
        tally(|n| n.neg += 1);
        Self(-self.0)
    }
}

macro_rules! counted_unary {
    ($($method:ident => $field:ident),* $(,)?) => {
        $(fn $method(self) -> Self {
            tally(|n| n.$field += 1);
            Self(Scalar::$method(self.0))
        })*
    };
}

macro_rules! counted_lanes {
    ($($method:ident),* $(,)?) => {
        $(fn $method<const N: usize>(x: [Self; N]) -> [Self; N] {
            tally(|n| n.lanes += N as u64);
            f64::$method(x.map(|v| v.0)).map(Self)
        })*
    };
}

impl Scalar for Counted {
    counted_unary! {
        sqr => mul, sqrt => sqrt, exp => elementary, ln => elementary, abs => compare,
        sin => elementary, cos => elementary, tan => elementary, asin => elementary,
        acos => elementary, atan => elementary, sinh => elementary, cosh => elementary,
        tanh => elementary, exp_lane => lanes, tanh_lane => lanes, ln_lane => lanes,
    }
    counted_lanes!(exp_lanes, tanh_lanes, ln_lanes);

    fn atan2(self, x: Self) -> Self {
        tally(|n| n.elementary += 1);
        Self(self.0.atan2(x.0))
    }
    fn powf(self, e: Self) -> Self {
        tally(|n| n.elementary += 1);
        Self(self.0.powf(e.0))
    }
    fn max(self, other: Self) -> Self {
        tally(|n| n.compare += 1);
        Self(self.0.max(other.0))
    }
}

/// A kernel whose count a generated module states, to be checked ([`check_stated`]).
pub struct StatedKernel {
    /// The kernel's name.
    pub name: &'static str,
    /// What the generator stated.
    pub stated: OpCount,
}

/// A stated count that differs from what the kernel performed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CountMismatch {
    /// The kernel.
    pub name: &'static str,
    /// The generator's count.
    pub stated: OpCount,
    /// What running it on [`Counted`] counted.
    pub counted: OpCount,
}

/// Arguments [`check_stated`] reads kernels' inputs from (more than any kernel takes).
const CHECK_INPUTS: usize = 1 << 14;

/// Run every kernel `run` offers on [`Counted`] numbers and compare what each performed
/// with what its module stated; `run` is a module's `run_counted_kernels` (written by
/// [`kernel_table!`](crate::kernel_table!)), such as
/// `check_stated(my_system::run_counted_kernels::<Counted>)`. Returns how many kernels
/// were checked, or every mismatch. The arguments are distinct numbers in `[0.25, 1.25)`:
/// counts do not depend on values (straight-line code), and a kernel that divides by zero
/// or takes a root of a negative number there counts all the same.
///
/// # Errors
/// The kernels whose count differs from the stated one.
pub fn check_stated(
    run: impl FnOnce(&[Counted], &mut dyn FnMut(StatedKernel, &dyn Fn())),
) -> Result<usize, Vec<CountMismatch>> {
    let input: Vec<Counted> =
        (0..CHECK_INPUTS).map(|k| Counted(0.25 + (k as f64 * 0.618_033_988_75).fract())).collect();
    let mut mismatches = Vec::new();
    let mut checked = 0;
    run(&input, &mut |kernel: StatedKernel, call: &dyn Fn()| {
        let ((), counted) = Counted::measure(call);
        checked += 1;
        if counted != kernel.stated {
            mismatches.push(CountMismatch { name: kernel.name, stated: kernel.stated, counted });
        }
    });
    if mismatches.is_empty() {
        Ok(checked)
    } else {
        Err(mismatches)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_operation_counts_in_its_kind_and_computes_as_f64() {
        let (x, y) = (Counted(0.7), Counted(1.9));
        let (v, n) = Counted::measure(|| {
            let a = x + y - x * y / y; // 2 add, 1 mul, 1 div
            let b = -a.sqr().sqrt(); // 1 neg, 1 mul, 1 sqrt
            let c = b.exp().atan2(a).max(b.abs()); // 2 libm, 2 compare
            let [d, e] = Counted::tanh_lanes([a, c]); // 2 lanes
            d + e.ln_lane() // 1 add, 1 lane
        });
        assert_eq!(n, OpCount { add: 3, neg: 1, mul: 2, div: 1, sqrt: 1, elementary: 2, lanes: 3, compare: 2 });
        let a = 0.7 + 1.9 - 0.7 * 1.9 / 1.9;
        let b = -(a * a).sqrt();
        let c = b.exp().atan2(a).max(b.abs());
        let [d, e] = crate::lanes::tanh([a, c]);
        assert_eq!(v.0, d + crate::lanes::ln1(e));
        assert_eq!(n.total(), 15);
        assert_eq!(n.plus(n), n.times(2));
        assert_eq!(OpCount::new(n.to_array()), n);
    }

    #[test]
    fn slots_add_the_state_part_once_per_filled_member_and_the_instance_part_per_slot() {
        let (base, state, instance) = ([1, 0, 0, 0, 0, 0, 0, 2], [3, 1, 4, 1, 5, 9, 2, 6], [2, 7, 1, 8, 2, 8, 1, 8]);
        let (s, i) = (OpCount::new(state), OpCount::new(instance));
        let sum = OpCount::new(base).plus_slots(&[(s, i, 3), (s, i, 0), (i, s, 1)]);
        let by_hand: [u64; 8] = core::array::from_fn(|k| base[k] + state[k] + 3 * instance[k] + instance[k] + state[k]);
        assert_eq!(sum, OpCount::new(by_hand));
        assert_eq!(OpCount::new(base).plus_slots(&[]), OpCount::new(base));
        let huge = OpCount::new([u64::MAX / 2; 8]);
        assert_eq!(
            huge.plus_slots(&[(OpCount::ZERO, OpCount::new([1; 8]), usize::MAX)]),
            OpCount::new([u64::MAX; 8]),
            "saturates"
        );
    }

    #[test]
    fn measurements_nest_and_constants_are_free() {
        let (inner, outer) = Counted::measure(|| {
            let _ = Counted(1.0) + Counted::from(2.0);
            let ((), inner) = Counted::measure(|| {
                let _ = Counted(1.0) * Counted(2.0);
            });
            inner
        });
        assert_eq!(inner, OpCount { mul: 1, ..OpCount::ZERO });
        assert_eq!(outer, OpCount { add: 1, ..OpCount::ZERO });
    }

    #[test]
    fn a_stated_count_is_checked_against_the_run() {
        fn kernel<S: Scalar>(x: S) -> S {
            x * x + S::from(1.0)
        }
        let run = |stated: OpCount| {
            check_stated(|input, each| {
                each(StatedKernel { name: "kernel", stated }, &|| {
                    let _ = kernel(input[0]);
                })
            })
        };
        assert_eq!(run(OpCount { add: 1, mul: 1, ..OpCount::ZERO }), Ok(1));
        let wrong = run(OpCount { add: 1, ..OpCount::ZERO }).unwrap_err();
        assert_eq!(wrong[0].counted, OpCount { add: 1, mul: 1, ..OpCount::ZERO });
    }
}
