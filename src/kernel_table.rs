//! `KERNELS`, the table in which every generated module lists its kernels behind one
//! uniform signature ([`KernelEntry`](crate::system::KernelEntry)), written by
//! [`kernel_table!`](crate::kernel_table!) from one line per kernel: how arguments are read
//! from one flat slice and results written to another is stated here once, not in every
//! generated file.
//!
//! The flat layout is the symbolic stage's (`Kernel.evaluate`): every input in argument
//! order, every output in return order, matrices row by row, symmetric matrices by their
//! upper triangle. The readers and writers panic on a slice of the wrong length: a tool's
//! bug (the table serves the SymEngine cross-check and Python's `call_kernel`), never a
//! control-path one.
//!
//! ```
//! fn scaled(x: &[f64; 2], k: f64) -> ([f64; 2], [[f64; 2]; 2]) {
//!     ([k * x[0], k * x[1]], [[k, 0.0], [0.0, k]])
//! }
//! cbfgen::kernel_table! {
//!     /// The kernels of this example.
//!     scaled(x: array[2], k: scalar[]) -> (y: array[2], dy: symmetric[2]);
//! }
//! let entry = &KERNELS[0];
//! assert_eq!((entry.name, entry.inputs, entry.outputs), ("scaled", &[("x", 2), ("k", 1)][..], &[("y", 2), ("dy", 3)][..]));
//! let mut out = [0.0; 5];
//! (entry.call)(&[1.0, 2.0, 3.0], &mut out);
//! assert_eq!(out, [3.0, 6.0, 3.0, 0.0, 3.0]);
//! ```

use nalgebra::{SMatrix, SVector, Scalar};

/// The next `n` numbers of `flat` at `*at`, and `*at` past them.
fn take<'a, T>(flat: &'a [T], at: &mut usize, n: usize) -> &'a [T] {
    *at += n;
    &flat[*at - n..*at]
}

/// Writes `values` at `*at`, and moves `*at` past them.
fn put<T: Copy>(values: &[T], flat: &mut [T], at: &mut usize) {
    flat[*at..*at + values.len()].copy_from_slice(values);
    *at += values.len();
}

/// The argument at `*at`: one number.
pub fn scalar<T: Copy>(flat: &[T], at: &mut usize) -> T {
    take(flat, at, 1)[0]
}

/// The argument at `*at`: `N` numbers, as the array a kernel takes by reference.
pub fn array<'a, T, const N: usize>(flat: &'a [T], at: &mut usize) -> &'a [T; N] {
    take(flat, at, N).try_into().expect("a slice of N numbers")
}

/// The argument at `*at`: a parameter's vector of `N` numbers.
pub fn vector<T: Scalar, const N: usize>(flat: &[T], at: &mut usize) -> SVector<T, N> {
    SVector::from_row_slice(take(flat, at, N))
}

/// The argument at `*at`: a parameter's `R` × `C` matrix, row by row.
pub fn matrix<T: Scalar, const R: usize, const C: usize>(flat: &[T], at: &mut usize) -> SMatrix<T, R, C> {
    SMatrix::from_row_slice(take(flat, at, R * C))
}

/// Writes a scalar result at `*at`.
pub fn put_scalar<T: Copy>(value: T, flat: &mut [T], at: &mut usize) {
    put(&[value], flat, at);
}

/// Writes a vector result at `*at`.
pub fn put_array<T: Copy, const N: usize>(value: &[T; N], flat: &mut [T], at: &mut usize) {
    put(value, flat, at);
}

/// Writes a matrix result at `*at`, row by row.
pub fn put_matrix<T: Copy, const R: usize, const C: usize>(value: &[[T; C]; R], flat: &mut [T], at: &mut usize) {
    put(value.as_flattened(), flat, at);
}

/// Writes a symmetric matrix result at `*at`: its upper triangle, row by row.
pub fn put_symmetric<T: Copy, const N: usize>(value: &[[T; N]; N], flat: &mut [T], at: &mut usize) {
    for (r, row) in value.iter().enumerate() {
        put(&row[r..], flat, at);
    }
}

/// `pub const KERNELS: &[KernelEntry]` for the kernels listed, one per line:
/// `name(arg: kind[dims], ...) -> (result: kind[dims], ...) ops [8 counts];`, the `ops`
/// part optional: the operations one call performs ([`OpCount::new`](crate::ops::OpCount::new)'s
/// order), which the generator states for each kernel it prints as one straight line;
/// or `ops { CONST_EXPR }`, an [`OpCount`](crate::ops::OpCount) built in a constant
/// expression, for a kernel assembled from others and from the core's functions that state
/// their own counts (a composed row: its poses, its chain, `compose`'s contraction).
/// With counts it also writes `run_counted_kernels`, which calls each counted kernel on
/// [`Counted`](crate::ops::Counted) numbers for [`crate::ops::check_stated`] (generic, so
/// it is compiled only where a test calls it). An argument is `scalar[]`,
/// `array[N]` (a `&[f64; N]`), `vector[N]` or `matrix[R, C]` (a parameter's `&SVector` or
/// `&SMatrix`); a result is `scalar[]`, `array[N]`, `matrix[R, C]` or `symmetric[N]` (an
/// `[[f64; N]; N]` listed by its upper triangle). A kernel with one result returns it
/// alone, with several a tuple. Doc comments before the first line go on `KERNELS`. See
/// the [module](mod@crate::kernel_table).
#[macro_export]
macro_rules! kernel_table {
    ($(#[$meta:meta])* $($name:ident ($($arg:ident : $akind:ident [$($adim:literal),*]),*)
        -> ($($out:ident : $okind:ident [$($odim:literal),*]),+) $(ops $ops:tt)?;)*) => {
        $(#[$meta])*
        pub const KERNELS: &[$crate::system::KernelEntry] = &[$(
            $crate::system::KernelEntry {
                name: stringify!($name),
                inputs: &[$((stringify!($arg), $crate::kernel_table!(@len $akind [$($adim),*]))),*],
                outputs: &[$((stringify!($out), $crate::kernel_table!(@len $okind [$($odim),*]))),+],
                ops: $crate::kernel_table!(@ops $($ops)?),
                call: |input: &[f64], output: &mut [f64]| {
                    let mut at = 0;
                    let result = $name($($crate::kernel_table!(@read $akind [$($adim),*] input at)),*);
                    assert_eq!(at, input.len(), concat!(stringify!($name), ": flat input length"));
                    let mut at = 0;
                    $crate::kernel_table!(@write result output at; $($out : $okind [$($odim),*]),+);
                    assert_eq!(at, output.len(), concat!(stringify!($name), ": flat output length"));
                },
            }
        ),*];

        /// Call every kernel of `KERNELS` whose operations are stated on the numbers `input`
        /// (each reads its arguments from the start of it), handing `each` the kernel's
        /// name and stated count with the call: for `cbfgen::ops::check_stated`.
        /// Generic over the number, so it is compiled only where a test runs it.
        #[allow(dead_code, unused_variables)]
        pub fn run_counted_kernels<S: $crate::scalar::Scalar>(
            input: &[S],
            each: &mut dyn FnMut($crate::ops::StatedKernel, &dyn Fn()),
        ) {
            $($crate::kernel_table!(@counted each input $name ($($akind [$($adim),*]),*) $($ops)?);)*
        }
    };
    (@counted $each:ident $input:ident $name:ident ($($akind:ident [$($adim:literal),*]),*)) => {};
    (@counted $each:ident $input:ident $name:ident ($($akind:ident [$($adim:literal),*]),*) $ops:tt) => {
        $each(
            $crate::ops::StatedKernel { name: stringify!($name), stated: $crate::kernel_table!(@count $ops) },
            &|| {
                let mut at = 0;
                let _ = $name::<S>($($crate::kernel_table!(@read $akind [$($adim),*] $input at)),*);
            },
        );
    };
    (@ops) => { None };
    (@ops $ops:tt) => { Some($crate::kernel_table!(@count $ops)) };
    (@count [$($op:literal),*]) => { $crate::ops::OpCount::new([$($op),*]) };
    (@count {$sum:expr}) => { $sum };
    (@len scalar []) => { 1 };
    (@len array [$n:literal]) => { $n };
    (@len vector [$n:literal]) => { $n };
    (@len matrix [$r:literal, $c:literal]) => { $r * $c };
    (@len symmetric [$n:literal]) => { $n * ($n + 1) / 2 };
    (@read scalar [] $flat:ident $at:ident) => { $crate::kernel_table::scalar($flat, &mut $at) };
    (@read array [$n:literal] $flat:ident $at:ident) => { $crate::kernel_table::array::<_, $n>($flat, &mut $at) };
    (@read vector [$n:literal] $flat:ident $at:ident) => { &$crate::kernel_table::vector::<_, $n>($flat, &mut $at) };
    (@read matrix [$r:literal, $c:literal] $flat:ident $at:ident) => {
        &$crate::kernel_table::matrix::<_, $r, $c>($flat, &mut $at)
    };
    (@write $value:ident $flat:ident $at:ident; $out:ident : $okind:ident [$($odim:literal),*]) => {
        $crate::kernel_table!(@put $okind $value $flat $at)
    };
    (@write $value:ident $flat:ident $at:ident; $($out:ident : $okind:ident [$($odim:literal),*]),+) => {{
        let ($($out,)+) = $value;
        $($crate::kernel_table!(@put $okind $out $flat $at);)+
    }};
    (@put scalar $value:ident $flat:ident $at:ident) => { $crate::kernel_table::put_scalar($value, $flat, &mut $at) };
    (@put array $value:ident $flat:ident $at:ident) => { $crate::kernel_table::put_array(&$value, $flat, &mut $at) };
    (@put matrix $value:ident $flat:ident $at:ident) => { $crate::kernel_table::put_matrix(&$value, $flat, &mut $at) };
    (@put symmetric $value:ident $flat:ident $at:ident) => {
        $crate::kernel_table::put_symmetric(&$value, $flat, &mut $at)
    };
}

/// One [`IntervalKernel`](crate::filter::between_samples::IntervalKernel): a generated
/// kernel run on intervals behind the flat signature, in [`kernel_table!`]'s syntax, with
/// the input columns of its `lg_lf` output in brackets after the name (none for the
/// dynamics). What generated modules list in `INTERVAL_KERNELS`.
///
/// ```
/// use cbfgen::interval::Interval;
/// use cbfgen::scalar::Scalar;
///
/// fn wall<S: Scalar>(x: &[S; 2]) -> ([[S; 3]; 1], [[S; 1]; 1]) {
///     ([[S::from(1.0) - x[0], -x[1], S::from(0.0)]], [[S::from(-1.0)]])
/// }
/// const COLUMNS: [usize; 1] = [0];
/// let kernel = cbfgen::interval_kernel!(wall[COLUMNS](x: array[2]) -> (lie: matrix[1, 3], lg_lf: matrix[1, 1]));
/// let mut out = [Interval::point(0.0); 4];
/// (kernel.call.unwrap())(&[Interval::new(0.5, 0.6), Interval::point(0.2)], &mut out);
/// assert!(out[0].contains(0.45) && out[3].contains(-1.0));
/// ```
#[macro_export]
macro_rules! interval_kernel {
    ($name:ident $([$columns:path])? ($($arg:ident : $akind:ident [$($adim:literal),*]),*)
        -> ($($out:ident : $okind:ident [$($odim:literal),*]),+)) => {
        $crate::filter::between_samples::IntervalKernel {
            name: stringify!($name),
            inputs: &[$((stringify!($arg), $crate::kernel_table!(@len $akind [$($adim),*]))),*],
            outputs: &[$((stringify!($out), $crate::kernel_table!(@len $okind [$($odim),*]))),+],
            columns: $crate::interval_kernel!(@columns $($columns)?),
            call: Some(|input: &[$crate::interval::Interval], output: &mut [$crate::interval::Interval]| {
                let mut at = 0;
                let result = $name::<$crate::interval::Interval>(
                    $($crate::kernel_table!(@read $akind [$($adim),*] input at)),*
                );
                let mut at = 0;
                $crate::kernel_table!(@write result output at; $($out : $okind [$($odim),*]),+);
            }),
        }
    };
    (@columns) => { &[] };
    (@columns $columns:path) => { &$columns };
}
