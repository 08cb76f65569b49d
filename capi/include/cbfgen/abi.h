// cbfgen's C ABI: one table of entry points per system (cbfgen_<name>_plugin_v1()).
// Generated from the core's src/plugin/ by cbindgen (capi/src/lib.rs); do not edit:
// `scripts/cbf generate` writes it. Include <cbfgen/cbfgen.h>, which includes this.

#ifndef CBFGEN_ABI_H
#define CBFGEN_ABI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

// The version of [`PluginV1`]'s layout and meaning; a loader refuses any other.
// Version 2 added the kernel table ([`DescriptionC::kernels`], [`PluginV1::kernel_call`]);
// version 3 the dense solve's work budget ([`SolverC::dense_max_work`]) and each update's
// counted work ([`ReportC::work`]); version 4 the filter's stated worst case and this
// machine's calibration ([`PluginV1::filter_worst_case`], [`PluginV1::filter_calibrate`]);
// version 5 the certificate's interval operations in both ([`WorstCaseC::interval_ops`],
// `Calibration::ns_per_interval_op`); version 6 made the table safe to call from C
// (`cbfgen.h`): every buffer travels with its length and is checked, a null handle or
// buffer is an error ([`ErrorCode::NullPointer`]), and every error carries its
// [`ErrorCode`]. The table keeps the name it was born with.
#define CBFGEN_ABI_VERSION 6

// Room for an error message crossing the boundary (longer ones are cut at a character).
#define CBFGEN_ERROR_CAPACITY 1024

#define CBFGEN_STORE_EXISTS 0

#define CBFGEN_STORE_LEN 1

#define CBFGEN_STORE_SLOTS 2

#define CBFGEN_STORE_IS_ENABLED 3

#define CBFGEN_STORE_GET 4

#define CBFGEN_STORE_SET 5

#define CBFGEN_STORE_PUSH 6

#define CBFGEN_STORE_REMOVE 7

#define CBFGEN_STORE_CLEAR 8

#define CBFGEN_STORE_SET_ENABLED 9

#define CBFGEN_DYNAMICS_DRIFT 0

#define CBFGEN_DYNAMICS_INPUT_MATRIX 1

#define CBFGEN_DYNAMICS_XDOT 2

// Highest relative degree a family may have (the symbolic stage stops looking there).
#define CBFGEN_MAX_RELATIVE_DEGREE 4

// What went wrong in a call ([`ErrorC::code`]): the [`CbfError`](crate::error::CbfError)
// variant of the same name, or one of the boundary's own.
enum cbfgen_error_code
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  // No error.
  CBFGEN_ERROR_CODE_OK = 0,
  CBFGEN_ERROR_CODE_NON_FINITE = 1,
  CBFGEN_ERROR_CODE_NOT_POSITIVE = 2,
  CBFGEN_ERROR_CODE_CAPACITY_EXCEEDED = 3,
  CBFGEN_ERROR_CODE_TOO_LARGE = 4,
  CBFGEN_ERROR_CODE_THREAD = 5,
  CBFGEN_ERROR_CODE_CAPACITY_MISMATCH = 6,
  CBFGEN_ERROR_CODE_PLUGIN = 7,
  CBFGEN_ERROR_CODE_OUT_OF_RANGE = 8,
  CBFGEN_ERROR_CODE_LENGTH_MISMATCH = 9,
  CBFGEN_ERROR_CODE_BAD_ROW_PATTERN = 10,
  CBFGEN_ERROR_CODE_NON_FINITE_ROW = 11,
  CBFGEN_ERROR_CODE_SOLVER_SETUP = 12,
  CBFGEN_ERROR_CODE_QP_FAILED = 13,
  CBFGEN_ERROR_CODE_NO_SUCH_INDEX = 14,
  CBFGEN_ERROR_CODE_UNKNOWN_NAME = 15,
  CBFGEN_ERROR_CODE_UNSUPPORTED = 16,
  CBFGEN_ERROR_CODE_MALFORMED = 17,
  CBFGEN_ERROR_CODE_SYSTEM_MISMATCH = 18,
  CBFGEN_ERROR_CODE_NOT_A_ROTATION = 19,
  CBFGEN_ERROR_CODE_NOT_POSITIVE_DEFINITE = 20,
  CBFGEN_ERROR_CODE_PARAM_OUT_OF_DOMAIN = 21,
  // A handle or buffer was a null pointer.
  CBFGEN_ERROR_CODE_NULL_POINTER = 100,
  // The call panicked (a bug in cbfgen: please report it); the objects it was given may
  // be left mid-update and are best freed.
  CBFGEN_ERROR_CODE_PANIC = 101,
  // The table's version is not the header's (`cbfgen_check`).
  CBFGEN_ERROR_CODE_ABI_MISMATCH = 102,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum cbfgen_error_code cbfgen_error_code;
#else
typedef uint32_t cbfgen_error_code;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

// A UTF-8 string owned by the plugin (static for as long as it is loaded).
typedef struct cbfgen_str {
  // First byte.
  const uint8_t *ptr;
  // Length in bytes.
  size_t len;
} cbfgen_str;

// A parameter domain ([`crate::param_domain::Domain`]): `kind` 0 real, 1 positive, 2
// non-negative, 3 interval `[a, b]`, 4 unit vector (tolerance `a`), 5 rotation (tolerance
// `a`).
typedef struct cbfgen_domain {
  // Which domain.
  uint8_t kind;
  // Its first number, if it has one.
  double a;
  // Its second number, if it has one.
  double b;
} cbfgen_domain;

// One run-time parameter of a family: name, shape and domain.
typedef struct cbfgen_param {
  // Its name.
  struct cbfgen_str name;
  // Its shape (`[]`, `[n]`, `[r, c]`).
  const size_t *shape;
  // Entries of `shape`.
  size_t rank;
  // Its domain.
  struct cbfgen_domain domain;
} cbfgen_param;

// [`crate::system::FamilyParams`]; the class-K function travels by name.
typedef struct cbfgen_family_params {
  // The poles, `n_poles` of them.
  double poles[CBFGEN_MAX_RELATIVE_DEGREE];
  // How many poles.
  size_t n_poles;
  // The priority tier.
  uint8_t priority;
  // The activation threshold.
  double activation;
  // [`crate::system::ClassK::name`].
  struct cbfgen_str class_k;
} cbfgen_family_params;

// [`crate::system::FamilyInfo`].
typedef struct cbfgen_family {
  // Its name.
  struct cbfgen_str name;
  // 0 barrier, 1 Lyapunov.
  uint8_t kind;
  // Its relative degree.
  size_t relative_degree;
  // Its rows' names.
  const struct cbfgen_str *row_names;
  // How many rows an instance has.
  size_t n_row_names;
  // Its members (indexed families).
  const struct cbfgen_str *members;
  // How many members.
  size_t n_members;
  // 0 fixed, 1 optional, 2 capacity.
  uint8_t instances;
  // Instances per member, or the largest capacity.
  size_t count;
  // Its run-time parameters.
  const struct cbfgen_param *params;
  // How many.
  size_t n_params;
  // The spec's defaults.
  struct cbfgen_family_params defaults;
} cbfgen_family;

// A kernel's input or output: its name and how many numbers it holds.
typedef struct cbfgen_slot {
  // Its name.
  struct cbfgen_str name;
  // Numbers it holds.
  size_t len;
} cbfgen_slot;

// [`crate::system::KernelSignature`].
typedef struct cbfgen_kernel {
  // The kernel's name.
  struct cbfgen_str name;
  // Its inputs, in argument order.
  const struct cbfgen_slot *inputs;
  // How many.
  size_t n_inputs;
  // Its outputs, in return order.
  const struct cbfgen_slot *outputs;
  // How many.
  size_t n_outputs;
} cbfgen_kernel;

// Everything static about the plugin's system.
typedef struct cbfgen_description {
  // The spec's name.
  struct cbfgen_str name;
  // The spec's description.
  struct cbfgen_str doc;
  // Number of states.
  size_t nx;
  // Number of inputs.
  size_t nu;
  // `nx` state names.
  const struct cbfgen_str *state_names;
  // `nu` input names.
  const struct cbfgen_str *input_names;
  // `nu` lower input limits.
  const double *input_min;
  // `nu` upper input limits.
  const double *input_max;
  // The families.
  const struct cbfgen_family *families;
  // How many.
  size_t n_families;
  // The generated kernels, in the module's order.
  const struct cbfgen_kernel *kernels;
  // How many.
  size_t n_kernels;
} cbfgen_description;

// An error written by the plugin into the caller's buffer: its code and its message.
typedef struct cbfgen_error {
  // What went wrong ([`ErrorCode`]; 0 when nothing did).
  uint32_t code;
  // Bytes of `text` used.
  size_t len;
  // The message, UTF-8, not NUL-terminated (`len` bytes; C readers print `%.*s`).
  uint8_t text[CBFGEN_ERROR_CAPACITY];
} cbfgen_error;

// An opaque object of the plugin's (parameters, rows or a filter).
typedef void *cbfgen_handle;

// The size of one capacity family (one member's, for an indexed family). (`repr(C)`: it
// crosses the plugin ABI as is.)
typedef struct cbfgen_capacity_count {
  // Index into the system's families.
  size_t family;
  // Member of an indexed family; 0 otherwise.
  size_t member;
  // Instance slots to reserve.
  size_t count;
} cbfgen_capacity_count;

// [`RowLayout`](crate::system::RowLayout); `columns` static in the plugin.
typedef struct cbfgen_row_layout {
  size_t family;
  size_t member;
  size_t instance;
  size_t row;
  const size_t *columns;
  size_t n_columns;
} cbfgen_row_layout;

// One row as last evaluated ([`RowView`](crate::dynamic::RowView)), pointing into the
// plugin's object (valid until it is next evaluated or freed).
typedef struct cbfgen_row {
  // The row's Lie derivatives `h, L_f h, …`: `MAX_RELATIVE_DEGREE + 1` values.
  const double *lie;
  const double *lg;
  bool active;
  bool culled;
} cbfgen_row;

// [`SolverSettings`](crate::qp::SolverSettings) field by field (`time_limit_ns` < 0: none).
typedef struct cbfgen_solver {
  uint8_t backend;
  uint32_t dense_max_steps;
  uint64_t dense_max_work;
  double eps_abs;
  double eps_rel;
  uint32_t max_iter;
  double rho;
  double sigma;
  double alpha;
  bool adaptive_rho;
  uint32_t adaptive_rho_interval;
  uint32_t check_termination;
  int64_t time_limit_ns;
  bool polish;
  uint32_t scaling;
} cbfgen_solver;

// [`DynSettings`](crate::dynamic::DynSettings), in buffers the caller owns (one entry per
// family, one per input; their lengths are checked).
typedef struct cbfgen_settings {
  // Entries of `families`: the system's family count.
  size_t n_families;
  // Entries of each per-input buffer: the system's input count.
  size_t n_inputs;
  // Per family.
  struct cbfgen_family_params *families;
  // Per input: weights.
  double *input_weights;
  // Per input: lower limits.
  double *input_min;
  // Per input: upper limits.
  double *input_max;
  // The solver's settings.
  struct cbfgen_solver solver;
  // Read the thread's CPU clock.
  bool measure_cpu_time;
  // Skip far rows.
  bool cull_far_rows;
} cbfgen_settings;

// An `Option<Cause>`: `kind` 0 none, 1 no authority, 2 input limit (`index` the input,
// `limit` 0 min / 1 max), 3 higher priority, 4 same priority (`index` the row), 5
// unsolved.
typedef struct cbfgen_cause {
  uint8_t kind;
  size_t index;
  uint8_t limit;
} cbfgen_cause;

// One family's relaxations in an update. (`repr(C)`: it crosses the plugin ABI as is.)
typedef struct cbfgen_family_relaxation {
  // Its rows relaxed beyond [`MET_TOLERANCE`].
  size_t relaxed_rows;
  // The largest slack among them, in the rows' units (0 when none).
  double max_slack;
  // The largest relative slack among them (0 when none).
  double max_relative;
} cbfgen_family_relaxation;

// A [`Safety`](crate::filter::Safety): `verdict` 0 met, 1 relaxed, 2 unassessed; the worst
// row when `worst_cause.kind` ≠ 0.
typedef struct cbfgen_safety {
  uint8_t verdict;
  size_t relaxed_rows;
  size_t worst_row;
  size_t worst_family;
  double worst_slack;
  double worst_relative;
  struct cbfgen_cause worst_cause;
} cbfgen_safety;

// What one update did, counted as it ran ([`Output::work`](super::Output::work)); laid
// out as C lays it out, for the plugin interface.
typedef struct cbfgen_work {
  // QP solves (1, or more with the sampled-data certificate's rounds; 0 when the rows
  // could not be solved at all).
  uint32_t qp_solves;
  // Dense-solver trips over every solve
  // ([`DualActiveSet::work`](crate::qp::dual_active_set::DualActiveSet::work)).
  uint64_t dense_trips;
  // OSQP iterations over every solve.
  uint32_t osqp_iterations;
} cbfgen_work;

// A filter's last update, written into the caller's buffers (`u`: `nu` entries; `active`,
// `delta`, `relative`, `causes`: one per row; `relaxation`: one per family; the three
// lengths are checked, and a null buffer of a nonzero length is an error). Enums as
// codes: `source` and `status`/`backend` index [`INPUT_SOURCES`], [`QP_STATUSES`],
// [`BACKENDS`] (−1: none); `nonfinite_row` and `cpu_time_ns` −1: none.
typedef struct cbfgen_report {
  // Entries of `u`: the system's input count.
  size_t n_u;
  // Entries of each per-row buffer: the filter's row count ([`PluginV1::rows_len`]).
  size_t n_rows;
  // Entries of `relaxation`: the system's family count.
  size_t n_families;
  double *u;
  bool *active;
  double *delta;
  double *relative;
  struct cbfgen_cause *causes;
  struct cbfgen_family_relaxation *relaxation;
  uint8_t source;
  int8_t status;
  int8_t backend;
  uint32_t dense_steps;
  bool dense_fallback;
  uint32_t elastic_stages;
  int64_t nonfinite_row;
  uint32_t iterations;
  bool polished;
  size_t active_rows;
  struct cbfgen_safety safety;
  struct cbfgen_safety convergence;
  uint32_t consecutive_fallbacks;
  struct cbfgen_work work;
  uint64_t eval_time_ns;
  uint64_t solve_time_ns;
  int64_t cpu_time_ns;
} cbfgen_report;

// A [`WorstCase`](crate::filter::WorstCase): `row_ops` and `interval_ops` the
// [`OpCount`](crate::ops::OpCount)'s fields in order, each read only when its `_stated`.
typedef struct cbfgen_worst_case {
  uint32_t qp_solves;
  uint64_t dense_trips;
  uint32_t osqp_iterations;
  bool row_ops_stated;
  uint64_t row_ops[8];
  uint32_t enclosures;
  bool interval_ops_stated;
  uint64_t interval_ops[8];
} cbfgen_worst_case;

// How fast this machine does each unit of work, measured (the slowest rate seen):
// what [`WorstCase::micros`] multiplies the counts by.
typedef struct cbfgen_calibration {
  // Nanoseconds per dense-solver trip.
  double ns_per_dense_trip;
  // Nanoseconds per OSQP iteration at the filter's size.
  double ns_per_osqp_iteration;
  // Nanoseconds per operation of row evaluation.
  double ns_per_row_op;
  // Nanoseconds per interval operation of the certificate's enclosures (0 when not
  // measured: no certificate, or no stated count to time it by).
  double ns_per_interval_op;
} cbfgen_calibration;

// The plugin's table of entry points, of [`ABI_VERSION`]. Every fallible call returns a status
// (0, or a count ≥ 0) and −1 on error, with the message in `err`; a `Handle` call returns
// null on error. `rows` arguments say which kind of handle: `false` a barrier set's,
// `true` a filter's.
typedef struct cbfgen_plugin_v1 {
  uint32_t abi_version;
  // The `cbfgen` version the plugin was built against.
  struct cbfgen_str core_version;
  const struct cbfgen_description *(*describe)(void);
  // A [`dynamics_op`]: `x` `nx` states, `u` `nu` inputs (`XDOT` only; else ignored),
  // `out` the drift (`nx`), the input matrix (`nx·nu`, row-major) or `ẋ` (`nx`).
  int32_t (*dynamics)(uint32_t op,
                      const double *x,
                      size_t n_x,
                      const double *u,
                      size_t n_u,
                      double *out,
                      size_t n_out,
                      struct cbfgen_error *err);
  cbfgen_handle (*params_new)(const struct cbfgen_capacity_count *counts,
                              size_t n,
                              struct cbfgen_error *err);
  cbfgen_handle (*params_clone)(cbfgen_handle params, struct cbfgen_error *err);
  void (*params_free)(cbfgen_handle params);
  // A [`store_op`] on family `family`, member `member`: `values`/`len` in or out,
  // `flag` for `SET_ENABLED`; returns the count asked, 1/0 for yes/no, 0 otherwise.
  int64_t (*store)(cbfgen_handle params,
                   uint32_t op,
                   size_t family,
                   size_t member,
                   size_t instance,
                   double *values,
                   size_t len,
                   bool flag,
                   struct cbfgen_error *err);
  cbfgen_handle (*barriers_new)(cbfgen_handle params, struct cbfgen_error *err);
  void (*barriers_free)(cbfgen_handle barriers);
  int32_t (*barriers_evaluate)(cbfgen_handle barriers,
                               double t,
                               const double *x,
                               size_t n_x,
                               cbfgen_handle params,
                               struct cbfgen_error *err);
  // Row count of a barrier set or filter (0 for a null handle).
  size_t (*rows_len)(cbfgen_handle rows, bool filter);
  bool (*layout)(cbfgen_handle rows, bool filter, size_t i, struct cbfgen_row_layout *out);
  bool (*row)(cbfgen_handle rows, bool filter, size_t i, struct cbfgen_row *out);
  int32_t (*default_settings)(struct cbfgen_settings *out, struct cbfgen_error *err);
  cbfgen_handle (*filter_new)(const struct cbfgen_capacity_count *counts,
                              size_t n,
                              const struct cbfgen_settings *settings,
                              struct cbfgen_error *err);
  void (*filter_free)(cbfgen_handle filter);
  // One update at time `t`, state `x` (`n_x` of them), nominal input `u_ref` (`n_u`):
  // writes the input to apply into `u` (`n_u_out`, the system's input count) and
  // returns the safety verdict (0 met, 1 relaxed, 2 unassessed), or −1 with the error
  // (then `u` is untouched: apply `filter_fallback`). The rest of the update's report
  // is `filter_report`'s.
  int32_t (*filter_update)(cbfgen_handle filter,
                           double t,
                           const double *x,
                           size_t n_x,
                           const double *u_ref,
                           size_t n_u,
                           cbfgen_handle params,
                           double *u,
                           size_t n_u_out,
                           struct cbfgen_error *err);
  int32_t (*filter_report)(cbfgen_handle filter, struct cbfgen_report *out, struct cbfgen_error *err);
  int32_t (*filter_fallback)(cbfgen_handle filter,
                             const double *u_ref,
                             size_t n_u,
                             double *out,
                             size_t n_out,
                             struct cbfgen_error *err);
  int32_t (*filter_settings)(cbfgen_handle filter,
                             struct cbfgen_settings *out,
                             struct cbfgen_error *err);
  int32_t (*filter_worst_case)(cbfgen_handle filter,
                               struct cbfgen_worst_case *out,
                               struct cbfgen_error *err);
  int32_t (*filter_calibrate)(cbfgen_handle filter,
                              double t,
                              const double *x,
                              size_t n_x,
                              cbfgen_handle params,
                              struct cbfgen_calibration *out,
                              struct cbfgen_error *err);
  // Kernel `index` of the description's, inputs and outputs flattened (lengths checked).
  int32_t (*kernel_call)(size_t index,
                         const double *inputs,
                         size_t n_inputs,
                         double *outputs,
                         size_t n_outputs,
                         struct cbfgen_error *err);
} cbfgen_plugin_v1;











#endif  /* CBFGEN_ABI_H */
