//! Systems loaded at run time from a plugin: a shared library built from a spec, reached
//! through a stable, versioned C ABI behind the type-erased layer ([`crate::dynamic`]).
//!
//! **Why a C ABI.** A plugin is compiled by another cargo invocation than the program that
//! loads it (the Python module, a tool), so nothing Rust leaves unspecified may cross:
//! trait-object vtables, `repr(Rust)` layouts, `TypeId`s and the allocator are all free to
//! differ between the two builds. What crosses here is `extern "C"` functions and
//! `#[repr(C)]` plain data ([`PluginV1`]); each side keeps its own objects behind opaque
//! handles, frees what it allocated, and never unwinds into the other (every entry point
//! catches panics and reports them as errors). The loader checks [`ABI_VERSION`] and the
//! core version the plugin was built against before it calls anything else.
//!
//! **Both sides are here.** A plugin crate is the generated module and one line:
//! ```ignore
//! cbfgen::include_system!("pvtol");
//! cbfgen::export_plugin!(SYSTEM);
//! ```
//! built as a `cdylib`. [`load`] opens it and returns a `&'static dyn DynSystem` that every
//! generic piece accepts: its parameters, rows and filter run in the plugin (monomorphised
//! there for its sizes, exactly as a linked system's are), the loader's side only moves
//! numbers. A loaded library is never unloaded (its statics back the system for the rest
//! of the process).
//!
//! **Also C's interface.** A system's C library exports the same table
//! ([`crate::export_c!`]), and `capi/include/cbfgen/abi.h` is generated from this module
//! by cbindgen (docs/embedding.md). So the table assumes nothing of its caller: every
//! buffer travels with its length and is checked, a null handle or buffer is an error
//! ([`ErrorCode::NullPointer`]), every error carries an [`ErrorCode`] beside its message,
//! and a field or signature changed here is a new [`ABI_VERSION`] and a regenerated
//! header (a test compares them).

mod convert;
mod export;
mod load;

pub use export::{table, Exported};
pub use load::load;

use std::ffi::c_void;

use crate::qp::{Backend, QpStatus, Solver};
use crate::system::MAX_RELATIVE_DEGREE;

/// The version of [`PluginV1`]'s layout and meaning; a loader refuses any other.
/// Version 2 added the kernel table ([`DescriptionC::kernels`], [`PluginV1::kernel_call`]);
/// version 3 the dense solve's work budget ([`SolverC::dense_max_work`]) and each update's
/// counted work ([`ReportC::work`]); version 4 the filter's stated worst case and this
/// machine's calibration ([`PluginV1::filter_worst_case`], [`PluginV1::filter_calibrate`]);
/// version 5 the certificate's interval operations in both ([`WorstCaseC::interval_ops`],
/// `Calibration::ns_per_interval_op`); version 6 made the table safe to call from C
/// (`cbfgen.h`): every buffer travels with its length and is checked, a null handle or
/// buffer is an error ([`ErrorCode::NullPointer`]), and every error carries its
/// [`ErrorCode`]. The table keeps the name it was born with.
pub const ABI_VERSION: u32 = 6;

/// The symbol a plugin exports: `extern "C" fn() -> *const PluginV1`. A system's C library
/// ([`crate::export_c!`]) exports `cbfgen_<name>_plugin_v1` instead, so that several can
/// be linked into one program.
pub const ENTRY_POINT: &str = "cbfgen_plugin_v1";

/// Room for an error message crossing the boundary (longer ones are cut at a character).
pub const ERROR_CAPACITY: usize = 1024;

/// An opaque object of the plugin's (parameters, rows or a filter).
pub type Handle = *mut c_void;

/// A UTF-8 string owned by the plugin (static for as long as it is loaded).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct StrC {
    /// First byte.
    pub ptr: *const u8,
    /// Length in bytes.
    pub len: usize,
}

impl StrC {
    /// `s`, borrowed.
    pub fn new(s: &'static str) -> Self {
        Self { ptr: s.as_ptr(), len: s.len() }
    }
}

/// What went wrong in a call ([`ErrorC::code`]): the [`CbfError`](crate::error::CbfError)
/// variant of the same name, or one of the boundary's own.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(missing_docs)] // CbfError's variants, documented there
pub enum ErrorCode {
    /// No error.
    Ok = 0,
    NonFinite = 1,
    NotPositive = 2,
    CapacityExceeded = 3,
    TooLarge = 4,
    Thread = 5,
    CapacityMismatch = 6,
    Plugin = 7,
    OutOfRange = 8,
    LengthMismatch = 9,
    BadRowPattern = 10,
    NonFiniteRow = 11,
    SolverSetup = 12,
    QpFailed = 13,
    NoSuchIndex = 14,
    UnknownName = 15,
    Unsupported = 16,
    Malformed = 17,
    SystemMismatch = 18,
    NotARotation = 19,
    NotPositiveDefinite = 20,
    ParamOutOfDomain = 21,
    /// A handle or buffer was a null pointer.
    NullPointer = 100,
    /// The call panicked (a bug in cbfgen: please report it); the objects it was given may
    /// be left mid-update and are best freed.
    Panic = 101,
    /// The table's version is not the header's (`cbfgen_check`).
    AbiMismatch = 102,
}

impl ErrorCode {
    /// The code of `e`.
    pub fn of(e: &crate::error::CbfError) -> Self {
        use crate::error::CbfError as E;
        match e {
            E::NonFinite { .. } => Self::NonFinite,
            E::NotPositive { .. } => Self::NotPositive,
            E::CapacityExceeded { .. } => Self::CapacityExceeded,
            E::TooLarge { .. } => Self::TooLarge,
            E::Thread { .. } => Self::Thread,
            E::CapacityMismatch => Self::CapacityMismatch,
            E::Plugin { .. } => Self::Plugin,
            E::OutOfRange { .. } => Self::OutOfRange,
            E::LengthMismatch { .. } => Self::LengthMismatch,
            E::BadRowPattern { .. } => Self::BadRowPattern,
            E::NonFiniteRow { .. } => Self::NonFiniteRow,
            E::SolverSetup { .. } => Self::SolverSetup,
            E::QpFailed { .. } => Self::QpFailed,
            E::NoSuchIndex { .. } => Self::NoSuchIndex,
            E::UnknownName { .. } => Self::UnknownName,
            E::Unsupported { .. } => Self::Unsupported,
            E::Malformed { .. } => Self::Malformed,
            E::SystemMismatch { .. } => Self::SystemMismatch,
            E::NotARotation { .. } => Self::NotARotation,
            E::NotPositiveDefinite { .. } => Self::NotPositiveDefinite,
            E::ParamOutOfDomain { .. } => Self::ParamOutOfDomain,
        }
    }
}

/// An error written by the plugin into the caller's buffer: its code and its message.
#[repr(C)]
pub struct ErrorC {
    /// What went wrong ([`ErrorCode`]; 0 when nothing did).
    pub code: u32,
    /// Bytes of `text` used.
    pub len: usize,
    /// The message, UTF-8, not NUL-terminated (`len` bytes; C readers print `%.*s`).
    pub text: [u8; ERROR_CAPACITY],
}

impl ErrorC {
    /// No error.
    pub fn new() -> Self {
        Self { code: ErrorCode::Ok as u32, len: 0, text: [0; ERROR_CAPACITY] }
    }
}

impl Default for ErrorC {
    fn default() -> Self {
        Self::new()
    }
}

/// A parameter domain ([`crate::param_domain::Domain`]): `kind` 0 real, 1 positive, 2
/// non-negative, 3 interval `[a, b]`, 4 unit vector (tolerance `a`), 5 rotation (tolerance
/// `a`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct DomainC {
    /// Which domain.
    pub kind: u8,
    /// Its first number, if it has one.
    pub a: f64,
    /// Its second number, if it has one.
    pub b: f64,
}

/// One run-time parameter of a family: name, shape and domain.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ParamC {
    /// Its name.
    pub name: StrC,
    /// Its shape (`[]`, `[n]`, `[r, c]`).
    pub shape: *const usize,
    /// Entries of `shape`.
    pub rank: usize,
    /// Its domain.
    pub domain: DomainC,
}

/// [`crate::system::FamilyParams`]; the class-K function travels by name.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FamilyParamsC {
    /// The poles, `n_poles` of them.
    pub poles: [f64; MAX_RELATIVE_DEGREE],
    /// How many poles.
    pub n_poles: usize,
    /// The priority tier.
    pub priority: u8,
    /// The activation threshold.
    pub activation: f64,
    /// [`crate::system::ClassK::name`].
    pub class_k: StrC,
}

/// [`crate::system::FamilyInfo`].
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FamilyC {
    /// Its name.
    pub name: StrC,
    /// 0 barrier, 1 Lyapunov.
    pub kind: u8,
    /// Its relative degree.
    pub relative_degree: usize,
    /// Its rows' names.
    pub row_names: *const StrC,
    /// How many rows an instance has.
    pub n_row_names: usize,
    /// Its members (indexed families).
    pub members: *const StrC,
    /// How many members.
    pub n_members: usize,
    /// 0 fixed, 1 optional, 2 capacity.
    pub instances: u8,
    /// Instances per member, or the largest capacity.
    pub count: usize,
    /// Its run-time parameters.
    pub params: *const ParamC,
    /// How many.
    pub n_params: usize,
    /// The spec's defaults.
    pub defaults: FamilyParamsC,
}

/// A kernel's input or output: its name and how many numbers it holds.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct SlotC {
    /// Its name.
    pub name: StrC,
    /// Numbers it holds.
    pub len: usize,
}

/// [`crate::system::KernelSignature`].
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct KernelC {
    /// The kernel's name.
    pub name: StrC,
    /// Its inputs, in argument order.
    pub inputs: *const SlotC,
    /// How many.
    pub n_inputs: usize,
    /// Its outputs, in return order.
    pub outputs: *const SlotC,
    /// How many.
    pub n_outputs: usize,
}

/// Everything static about the plugin's system.
#[repr(C)]
#[derive(Debug)]
pub struct DescriptionC {
    /// The spec's name.
    pub name: StrC,
    /// The spec's description.
    pub doc: StrC,
    /// Number of states.
    pub nx: usize,
    /// Number of inputs.
    pub nu: usize,
    /// `nx` state names.
    pub state_names: *const StrC,
    /// `nu` input names.
    pub input_names: *const StrC,
    /// `nu` lower input limits.
    pub input_min: *const f64,
    /// `nu` upper input limits.
    pub input_max: *const f64,
    /// The families.
    pub families: *const FamilyC,
    /// How many.
    pub n_families: usize,
    /// The generated kernels, in the module's order.
    pub kernels: *const KernelC,
    /// How many.
    pub n_kernels: usize,
}

/// [`SolverSettings`](crate::qp::SolverSettings) field by field (`time_limit_ns` < 0: none).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(missing_docs)] // the fields are SolverSettings', documented there
pub struct SolverC {
    pub backend: u8,
    pub dense_max_steps: u32,
    pub dense_max_work: u64,
    pub eps_abs: f64,
    pub eps_rel: f64,
    pub max_iter: u32,
    pub rho: f64,
    pub sigma: f64,
    pub alpha: f64,
    pub adaptive_rho: bool,
    pub adaptive_rho_interval: u32,
    pub check_termination: u32,
    pub time_limit_ns: i64,
    pub polish: bool,
    pub scaling: u32,
}

/// [`DynSettings`](crate::dynamic::DynSettings), in buffers the caller owns (one entry per
/// family, one per input; their lengths are checked).
#[repr(C)]
#[derive(Debug)]
pub struct SettingsC {
    /// Entries of `families`: the system's family count.
    pub n_families: usize,
    /// Entries of each per-input buffer: the system's input count.
    pub n_inputs: usize,
    /// Per family.
    pub families: *mut FamilyParamsC,
    /// Per input: weights.
    pub input_weights: *mut f64,
    /// Per input: lower limits.
    pub input_min: *mut f64,
    /// Per input: upper limits.
    pub input_max: *mut f64,
    /// The solver's settings.
    pub solver: SolverC,
    /// Read the thread's CPU clock.
    pub measure_cpu_time: bool,
    /// Skip far rows.
    pub cull_far_rows: bool,
}

/// [`RowLayout`](crate::system::RowLayout); `columns` static in the plugin.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(missing_docs)] // RowLayout's fields
pub struct RowLayoutC {
    pub family: usize,
    pub member: usize,
    pub instance: usize,
    pub row: usize,
    pub columns: *const usize,
    pub n_columns: usize,
}

/// One row as last evaluated ([`RowView`](crate::dynamic::RowView)), pointing into the
/// plugin's object (valid until it is next evaluated or freed).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(missing_docs)] // RowView's fields
pub struct RowC {
    /// The row's Lie derivatives `h, L_f h, …`: `MAX_RELATIVE_DEGREE + 1` values.
    pub lie: *const f64,
    pub lg: *const f64,
    pub active: bool,
    pub culled: bool,
}

/// An `Option<Cause>`: `kind` 0 none, 1 no authority, 2 input limit (`index` the input,
/// `limit` 0 min / 1 max), 3 higher priority, 4 same priority (`index` the row), 5
/// unsolved.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
#[allow(missing_docs)]
pub struct CauseC {
    pub kind: u8,
    pub index: usize,
    pub limit: u8,
}

/// A [`Safety`](crate::filter::Safety): `verdict` 0 met, 1 relaxed, 2 unassessed; the worst
/// row when `worst_cause.kind` ≠ 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
#[allow(missing_docs)]
pub struct SafetyC {
    pub verdict: u8,
    pub relaxed_rows: usize,
    pub worst_row: usize,
    pub worst_family: usize,
    pub worst_slack: f64,
    pub worst_relative: f64,
    pub worst_cause: CauseC,
}

/// A filter's last update, written into the caller's buffers (`u`: `nu` entries; `active`,
/// `delta`, `relative`, `causes`: one per row; `relaxation`: one per family; the three
/// lengths are checked, and a null buffer of a nonzero length is an error). Enums as
/// codes: `source` and `status`/`backend` index [`INPUT_SOURCES`], [`QP_STATUSES`],
/// [`BACKENDS`] (−1: none); `nonfinite_row` and `cpu_time_ns` −1: none.
#[repr(C)]
#[derive(Debug)]
#[allow(missing_docs)] // Output's fields
pub struct ReportC {
    /// Entries of `u`: the system's input count.
    pub n_u: usize,
    /// Entries of each per-row buffer: the filter's row count ([`PluginV1::rows_len`]).
    pub n_rows: usize,
    /// Entries of `relaxation`: the system's family count.
    pub n_families: usize,
    pub u: *mut f64,
    pub active: *mut bool,
    pub delta: *mut f64,
    pub relative: *mut f64,
    pub causes: *mut CauseC,
    pub relaxation: *mut crate::filter::FamilyRelaxation,
    pub source: u8,
    pub status: i8,
    pub backend: i8,
    pub dense_steps: u32,
    pub dense_fallback: bool,
    pub elastic_stages: u32,
    pub nonfinite_row: i64,
    pub iterations: u32,
    pub polished: bool,
    pub active_rows: usize,
    pub safety: SafetyC,
    pub convergence: SafetyC,
    pub consecutive_fallbacks: u32,
    pub work: crate::filter::Work,
    pub eval_time_ns: u64,
    pub solve_time_ns: u64,
    pub cpu_time_ns: i64,
}

/// A [`WorstCase`](crate::filter::WorstCase): `row_ops` and `interval_ops` the
/// [`OpCount`](crate::ops::OpCount)'s fields in order, each read only when its `_stated`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
#[allow(missing_docs)]
pub struct WorstCaseC {
    pub qp_solves: u32,
    pub dense_trips: u64,
    pub osqp_iterations: u32,
    pub row_ops_stated: bool,
    pub row_ops: [u64; 8],
    pub enclosures: u32,
    pub interval_ops_stated: bool,
    pub interval_ops: [u64; 8],
}

impl From<crate::filter::WorstCase> for WorstCaseC {
    fn from(w: crate::filter::WorstCase) -> Self {
        Self {
            qp_solves: w.qp_solves,
            dense_trips: w.dense_trips,
            osqp_iterations: w.osqp_iterations,
            row_ops_stated: w.row_ops.is_some(),
            row_ops: w.row_ops.unwrap_or_default().to_array(),
            enclosures: w.enclosures,
            interval_ops_stated: w.interval_ops.is_some(),
            interval_ops: w.interval_ops.unwrap_or_default().to_array(),
        }
    }
}

impl From<WorstCaseC> for crate::filter::WorstCase {
    fn from(w: WorstCaseC) -> Self {
        Self {
            qp_solves: w.qp_solves,
            dense_trips: w.dense_trips,
            osqp_iterations: w.osqp_iterations,
            row_ops: w.row_ops_stated.then(|| crate::ops::OpCount::new(w.row_ops)),
            enclosures: w.enclosures,
            interval_ops: w.interval_ops_stated.then(|| crate::ops::OpCount::new(w.interval_ops)),
        }
    }
}

/// The operations on one family's instances ([`PluginV1::store`]).
#[allow(missing_docs)]
pub mod store_op {
    pub const EXISTS: u32 = 0;
    pub const LEN: u32 = 1;
    pub const SLOTS: u32 = 2;
    pub const IS_ENABLED: u32 = 3;
    pub const GET: u32 = 4;
    pub const SET: u32 = 5;
    pub const PUSH: u32 = 6;
    pub const REMOVE: u32 = 7;
    pub const CLEAR: u32 = 8;
    pub const SET_ENABLED: u32 = 9;
}

/// Which dynamics [`PluginV1::dynamics`] evaluates.
#[allow(missing_docs)]
pub mod dynamics_op {
    pub const DRIFT: u32 = 0;
    pub const INPUT_MATRIX: u32 = 1;
    pub const XDOT: u32 = 2;
}

/// The plugin's table of entry points, of [`ABI_VERSION`]. Every fallible call returns a status
/// (0, or a count ≥ 0) and −1 on error, with the message in `err`; a `Handle` call returns
/// null on error. `rows` arguments say which kind of handle: `false` a barrier set's,
/// `true` a filter's.
#[repr(C)]
#[allow(missing_docs)] // each mirrors the DynSystem method of the same name
pub struct PluginV1 {
    pub abi_version: u32,
    /// The `cbfgen` version the plugin was built against.
    pub core_version: StrC,
    pub describe: unsafe extern "C" fn() -> *const DescriptionC,
    /// A [`dynamics_op`]: `x` `nx` states, `u` `nu` inputs (`XDOT` only; else ignored),
    /// `out` the drift (`nx`), the input matrix (`nx·nu`, row-major) or `ẋ` (`nx`).
    pub dynamics: unsafe extern "C" fn(
        op: u32,
        x: *const f64,
        n_x: usize,
        u: *const f64,
        n_u: usize,
        out: *mut f64,
        n_out: usize,
        err: *mut ErrorC,
    ) -> i32,
    pub params_new:
        unsafe extern "C" fn(counts: *const crate::dynamic::CapacityCount, n: usize, err: *mut ErrorC) -> Handle,
    pub params_clone: unsafe extern "C" fn(params: Handle, err: *mut ErrorC) -> Handle,
    pub params_free: unsafe extern "C" fn(params: Handle),
    /// A [`store_op`] on family `family`, member `member`: `values`/`len` in or out,
    /// `flag` for `SET_ENABLED`; returns the count asked, 1/0 for yes/no, 0 otherwise.
    pub store: unsafe extern "C" fn(
        params: Handle,
        op: u32,
        family: usize,
        member: usize,
        instance: usize,
        values: *mut f64,
        len: usize,
        flag: bool,
        err: *mut ErrorC,
    ) -> i64,
    pub barriers_new: unsafe extern "C" fn(params: Handle, err: *mut ErrorC) -> Handle,
    pub barriers_free: unsafe extern "C" fn(barriers: Handle),
    pub barriers_evaluate: unsafe extern "C" fn(
        barriers: Handle,
        t: f64,
        x: *const f64,
        n_x: usize,
        params: Handle,
        err: *mut ErrorC,
    ) -> i32,
    /// Row count of a barrier set or filter (0 for a null handle).
    pub rows_len: unsafe extern "C" fn(rows: Handle, filter: bool) -> usize,
    pub layout: unsafe extern "C" fn(rows: Handle, filter: bool, i: usize, out: *mut RowLayoutC) -> bool,
    pub row: unsafe extern "C" fn(rows: Handle, filter: bool, i: usize, out: *mut RowC) -> bool,
    pub default_settings: unsafe extern "C" fn(out: *mut SettingsC, err: *mut ErrorC) -> i32,
    pub filter_new: unsafe extern "C" fn(
        counts: *const crate::dynamic::CapacityCount,
        n: usize,
        settings: *const SettingsC,
        err: *mut ErrorC,
    ) -> Handle,
    pub filter_free: unsafe extern "C" fn(filter: Handle),
    /// One update at time `t`, state `x` (`n_x` of them), nominal input `u_ref` (`n_u`):
    /// writes the input to apply into `u` (`n_u_out`, the system's input count) and
    /// returns the safety verdict (0 met, 1 relaxed, 2 unassessed), or −1 with the error
    /// (then `u` is untouched: apply `filter_fallback`). The rest of the update's report
    /// is `filter_report`'s.
    pub filter_update: unsafe extern "C" fn(
        filter: Handle,
        t: f64,
        x: *const f64,
        n_x: usize,
        u_ref: *const f64,
        n_u: usize,
        params: Handle,
        u: *mut f64,
        n_u_out: usize,
        err: *mut ErrorC,
    ) -> i32,
    pub filter_report: unsafe extern "C" fn(filter: Handle, out: *mut ReportC, err: *mut ErrorC) -> i32,
    pub filter_fallback: unsafe extern "C" fn(
        filter: Handle,
        u_ref: *const f64,
        n_u: usize,
        out: *mut f64,
        n_out: usize,
        err: *mut ErrorC,
    ) -> i32,
    pub filter_settings: unsafe extern "C" fn(filter: Handle, out: *mut SettingsC, err: *mut ErrorC) -> i32,
    pub filter_worst_case: unsafe extern "C" fn(filter: Handle, out: *mut WorstCaseC, err: *mut ErrorC) -> i32,
    pub filter_calibrate: unsafe extern "C" fn(
        filter: Handle,
        t: f64,
        x: *const f64,
        n_x: usize,
        params: Handle,
        out: *mut crate::filter::Calibration,
        err: *mut ErrorC,
    ) -> i32,
    /// Kernel `index` of the description's, inputs and outputs flattened (lengths checked).
    pub kernel_call: unsafe extern "C" fn(
        index: usize,
        inputs: *const f64,
        n_inputs: usize,
        outputs: *mut f64,
        n_outputs: usize,
        err: *mut ErrorC,
    ) -> i32,
}

// The table is plain data and function pointers into code that is itself thread-safe
// (every object behind a handle is `Send`, the parameters `Sync`).
unsafe impl Sync for PluginV1 {}
unsafe impl Send for PluginV1 {}

/// The codes of [`ReportC::source`].
pub const INPUT_SOURCES: [crate::filter::InputSource; 4] = crate::filter::InputSource::ALL;
/// The codes of [`ReportC::status`].
pub const QP_STATUSES: [QpStatus; 9] = [
    QpStatus::Solved,
    QpStatus::SolvedInaccurate,
    QpStatus::MaxIterations,
    QpStatus::TimeLimit,
    QpStatus::PrimalInfeasible,
    QpStatus::DualInfeasible,
    QpStatus::NonConvex,
    QpStatus::SolverFault,
    QpStatus::NonFinite,
];
/// The codes of [`SafetyC::verdict`] and of [`PluginV1::filter_update`]'s return.
pub const VERDICTS: [crate::filter::Verdict; 3] =
    [crate::filter::Verdict::Met, crate::filter::Verdict::Relaxed, crate::filter::Verdict::Unassessed];
/// The codes of [`ReportC::backend`].
pub const BACKENDS: [Backend; 2] = [Backend::Dense, Backend::Osqp];
/// The codes of [`SolverC::backend`].
pub const SOLVERS: [Solver; 3] = Solver::ALL;

/// `value`'s position in `table` (every enum value is in its table).
fn code<T: PartialEq>(table: &[T], value: &T) -> u8 {
    table.iter().position(|v| v == value).unwrap_or(0) as u8
}

/// The value of `code` in `table`, if it is one.
fn decode<T: Copy>(table: &[T], code: i64) -> Option<T> {
    usize::try_from(code).ok().and_then(|i| table.get(i)).copied()
}
