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

use nalgebra::{SMatrix, SVector};

/// The next `n` numbers of `flat` at `*at`, and `*at` past them.
fn take<'a>(flat: &'a [f64], at: &mut usize, n: usize) -> &'a [f64] {
    *at += n;
    &flat[*at - n..*at]
}

/// Writes `values` at `*at`, and moves `*at` past them.
fn put(values: &[f64], flat: &mut [f64], at: &mut usize) {
    flat[*at..*at + values.len()].copy_from_slice(values);
    *at += values.len();
}

/// The argument at `*at`: one number.
pub fn scalar(flat: &[f64], at: &mut usize) -> f64 {
    take(flat, at, 1)[0]
}

/// The argument at `*at`: `N` numbers, as the array a kernel takes by reference.
pub fn array<'a, const N: usize>(flat: &'a [f64], at: &mut usize) -> &'a [f64; N] {
    take(flat, at, N).try_into().expect("a slice of N numbers")
}

/// The argument at `*at`: a parameter's vector of `N` numbers.
pub fn vector<const N: usize>(flat: &[f64], at: &mut usize) -> SVector<f64, N> {
    SVector::from_row_slice(take(flat, at, N))
}

/// The argument at `*at`: a parameter's `R` × `C` matrix, row by row.
pub fn matrix<const R: usize, const C: usize>(flat: &[f64], at: &mut usize) -> SMatrix<f64, R, C> {
    SMatrix::from_row_slice(take(flat, at, R * C))
}

/// Writes a scalar result at `*at`.
pub fn put_scalar(value: f64, flat: &mut [f64], at: &mut usize) {
    put(&[value], flat, at);
}

/// Writes a vector result at `*at`.
pub fn put_array<const N: usize>(value: &[f64; N], flat: &mut [f64], at: &mut usize) {
    put(value, flat, at);
}

/// Writes a matrix result at `*at`, row by row.
pub fn put_matrix<const R: usize, const C: usize>(value: &[[f64; C]; R], flat: &mut [f64], at: &mut usize) {
    put(value.as_flattened(), flat, at);
}

/// Writes a symmetric matrix result at `*at`: its upper triangle, row by row.
pub fn put_symmetric<const N: usize>(value: &[[f64; N]; N], flat: &mut [f64], at: &mut usize) {
    for (r, row) in value.iter().enumerate() {
        put(&row[r..], flat, at);
    }
}

/// `pub const KERNELS: &[KernelEntry]` for the kernels listed, one per line:
/// `name(arg: kind[dims], ...) -> (result: kind[dims], ...);`. An argument is `scalar[]`,
/// `array[N]` (a `&[f64; N]`), `vector[N]` or `matrix[R, C]` (a parameter's `&SVector` or
/// `&SMatrix`); a result is `scalar[]`, `array[N]`, `matrix[R, C]` or `symmetric[N]` (an
/// `[[f64; N]; N]` listed by its upper triangle). A kernel with one result returns it
/// alone, with several a tuple. Doc comments before the first line go on `KERNELS`. See
/// the [module](mod@crate::kernel_table).
#[macro_export]
macro_rules! kernel_table {
    ($(#[$meta:meta])* $($name:ident ($($arg:ident : $akind:ident [$($adim:literal),*]),*)
        -> ($($out:ident : $okind:ident [$($odim:literal),*]),+);)*) => {
        $(#[$meta])*
        pub const KERNELS: &[$crate::system::KernelEntry] = &[$(
            $crate::system::KernelEntry {
                name: stringify!($name),
                inputs: &[$((stringify!($arg), $crate::kernel_table!(@len $akind [$($adim),*]))),*],
                outputs: &[$((stringify!($out), $crate::kernel_table!(@len $okind [$($odim),*]))),+],
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
    };
    (@len scalar []) => { 1 };
    (@len array [$n:literal]) => { $n };
    (@len vector [$n:literal]) => { $n };
    (@len matrix [$r:literal, $c:literal]) => { $r * $c };
    (@len symmetric [$n:literal]) => { $n * ($n + 1) / 2 };
    (@read scalar [] $flat:ident $at:ident) => { $crate::kernel_table::scalar($flat, &mut $at) };
    (@read array [$n:literal] $flat:ident $at:ident) => { $crate::kernel_table::array::<$n>($flat, &mut $at) };
    (@read vector [$n:literal] $flat:ident $at:ident) => { &$crate::kernel_table::vector::<$n>($flat, &mut $at) };
    (@read matrix [$r:literal, $c:literal] $flat:ident $at:ident) => {
        &$crate::kernel_table::matrix::<$r, $c>($flat, &mut $at)
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
