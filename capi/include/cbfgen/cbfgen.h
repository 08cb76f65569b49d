/*
 * cbfgen from C (C99): a generated system's safety filter behind one table of entry points.
 *
 * A system's library (built by `python -m cbfgen.embed install`, docs/embedding.md)
 * exports one function, declared by the system's own header <cbfgen/systems/<name>.h>:
 *
 *     const cbfgen_plugin_v1 *cbfgen_<name>_plugin_v1(void);
 *
 * Everything else is a call through that table (<cbfgen/abi.h>, generated from the Rust
 * core). Its rules:
 *  - objects (parameters, filters, barrier sets) are opaque handles made by `*_new` and
 *    given back to `*_free` (which accept NULL);
 *  - every buffer is the caller's and travels with its length, which is checked;
 *  - a fallible call returns -1 (or a null handle) and writes a code and a message into
 *    the caller's `cbfgen_error` (which may be NULL); nothing unwinds into C;
 *  - `filter_update` does not allocate; a filter is used by one thread at a time,
 *    parameters may be shared by threads that only read them.
 *
 * The helpers below name the common steps; each is a few lines over the table.
 *
 *     const cbfgen_plugin_v1 *sys = cbfgen_double_integrator_plugin_v1();
 *     cbfgen_error err = {0};
 *     if (cbfgen_check(sys, &err) != 0) { fprintf(stderr, "%.*s\n", (int)err.len, err.text); }
 *     cbfgen_handle params = sys->params_new(NULL, 0, &err);
 *     double boundary[3] = {0.1, 2.0, -0.5};     // amplitude, omega, offset
 *     cbfgen_params_set(sys, params, cbfgen_family_index(sys, "sine_barrier"), 0, 0, boundary, 3, &err);
 *     cbfgen_handle filter = cbfgen_filter_new_default(sys, NULL, 0, &err);
 *     // every cycle: the input to apply into u, the verdict returned (-1: refused, see err)
 *     double u[1];
 *     int verdict = sys->filter_update(filter, t, x, 2, u_nominal, 1, params, u, 1, &err);
 *     // the full report (relaxed rows and why, solver, timings) when wanted:
 *     cbfgen_report report;
 *     cbfgen_report_init(sys, filter, &report, &err);        // allocates, once
 *     sys->filter_report(filter, &report, &err);
 */
#ifndef CBFGEN_H
#define CBFGEN_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "abi.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Report verdicts (cbfgen_safety.verdict). */
#define CBFGEN_VERDICT_MET 0
#define CBFGEN_VERDICT_RELAXED 1
#define CBFGEN_VERDICT_UNASSESSED 2

/* Write `code` and a printf-formatted message into `err` (if it is not NULL); returns -1. */
static inline int cbfgen_fail(cbfgen_error *err, uint32_t code, const char *format, ...) {
  if (err != NULL) {
    va_list args;
    int n;
    va_start(args, format);
    n = vsnprintf((char *)err->text, CBFGEN_ERROR_CAPACITY, format, args);
    va_end(args);
    err->code = code;
    err->len = n < 0 ? 0 : ((size_t)n < CBFGEN_ERROR_CAPACITY ? (size_t)n : CBFGEN_ERROR_CAPACITY - 1);
  }
  return -1;
}

/* Whether the plugin string `s` equals the NUL-terminated `name`. */
static inline int cbfgen_str_eq(cbfgen_str s, const char *name) {
  size_t n = strlen(name);
  return s.len == n && (n == 0 || memcmp(s.ptr, name, n) == 0);
}

/* 0 when `sys` is a table of this header's ABI version; else -1 with ABI_MISMATCH (a
 * library built by another cbfgen than these headers: reinstall both together). */
static inline int cbfgen_check(const cbfgen_plugin_v1 *sys, cbfgen_error *err) {
  if (sys == NULL) return cbfgen_fail(err, CBFGEN_ERROR_CODE_NULL_POINTER, "the system table is a null pointer");
  if (sys->abi_version != CBFGEN_ABI_VERSION) {
    return cbfgen_fail(err, CBFGEN_ERROR_CODE_ABI_MISMATCH,
                       "the system's library has cbfgen ABI %u, these headers ABI %u: install the library and "
                       "its headers from one build",
                       (unsigned)sys->abi_version, (unsigned)CBFGEN_ABI_VERSION);
  }
  return 0;
}

/* The index of the family called `name`, or -1. */
static inline long cbfgen_family_index(const cbfgen_plugin_v1 *sys, const char *name) {
  const cbfgen_description *d = sys->describe();
  size_t i;
  for (i = 0; i < d->n_families; ++i) {
    if (cbfgen_str_eq(d->families[i].name, name)) return (long)i;
  }
  return -1;
}

/* The index of member `name` of family `family` (an indexed family), or -1. */
static inline long cbfgen_member_index(const cbfgen_plugin_v1 *sys, size_t family, const char *name) {
  const cbfgen_description *d = sys->describe();
  size_t i;
  if (family >= d->n_families) return -1;
  for (i = 0; i < d->families[family].n_members; ++i) {
    if (cbfgen_str_eq(d->families[family].members[i], name)) return (long)i;
  }
  return -1;
}

/* Set instance `instance` of family `family` (member `member`; 0 if not indexed) to the
 * `len` numbers of `values` (the family's parameters in order, flattened row-major). */
static inline int cbfgen_params_set(const cbfgen_plugin_v1 *sys, cbfgen_handle params, size_t family,
                                    size_t member, size_t instance, const double *values, size_t len,
                                    cbfgen_error *err) {
  /* The store only reads `values` for SET. */
  return (int)sys->store(params, CBFGEN_STORE_SET, family, member, instance, (double *)values, len, false, err);
}

/* Add an instance to a capacity or optional family (`values` as for cbfgen_params_set). */
static inline int cbfgen_params_push(const cbfgen_plugin_v1 *sys, cbfgen_handle params, size_t family,
                                     size_t member, const double *values, size_t len, cbfgen_error *err) {
  return (int)sys->store(params, CBFGEN_STORE_PUSH, family, member, 0, (double *)values, len, false, err);
}

/* Settings whose buffers this helper allocates (free them with cbfgen_settings_free). */
static inline int cbfgen_settings_init(const cbfgen_plugin_v1 *sys, cbfgen_settings *s, cbfgen_error *err) {
  const cbfgen_description *d = sys->describe();
  memset(s, 0, sizeof *s);
  s->n_families = d->n_families;
  s->n_inputs = d->nu;
  s->families = (cbfgen_family_params *)calloc(d->n_families ? d->n_families : 1, sizeof *s->families);
  s->input_weights = (double *)calloc(d->nu ? d->nu : 1, sizeof(double));
  s->input_min = (double *)calloc(d->nu ? d->nu : 1, sizeof(double));
  s->input_max = (double *)calloc(d->nu ? d->nu : 1, sizeof(double));
  if (!s->families || !s->input_weights || !s->input_min || !s->input_max) {
    return cbfgen_fail(err, CBFGEN_ERROR_CODE_NULL_POINTER, "out of memory for the settings' buffers");
  }
  return sys->default_settings(s, err);
}

static inline void cbfgen_settings_free(cbfgen_settings *s) {
  free(s->families);
  free(s->input_weights);
  free(s->input_min);
  free(s->input_max);
  memset(s, 0, sizeof *s);
}

/* A filter with the system's default settings and `n` capacity counts (NULL, 0: none). */
static inline cbfgen_handle cbfgen_filter_new_default(const cbfgen_plugin_v1 *sys,
                                                      const cbfgen_capacity_count *counts, size_t n,
                                                      cbfgen_error *err) {
  cbfgen_settings s;
  cbfgen_handle filter = NULL;
  if (cbfgen_settings_init(sys, &s, err) == 0) filter = sys->filter_new(counts, n, &s, err);
  cbfgen_settings_free(&s);
  return filter;
}

/* A report whose buffers are sized for `filter` (allocated here, once; free them with
 * cbfgen_report_free). `sys->filter_report` then fills it after every update. */
static inline int cbfgen_report_init(const cbfgen_plugin_v1 *sys, cbfgen_handle filter, cbfgen_report *r,
                                     cbfgen_error *err) {
  const cbfgen_description *d = sys->describe();
  size_t rows;
  if (filter == NULL) return cbfgen_fail(err, CBFGEN_ERROR_CODE_NULL_POINTER, "the filter handle is a null pointer");
  rows = sys->rows_len(filter, true);
  memset(r, 0, sizeof *r);
  r->n_u = d->nu;
  r->n_rows = rows;
  r->n_families = d->n_families;
  r->u = (double *)calloc(d->nu ? d->nu : 1, sizeof(double));
  r->active = (bool *)calloc(rows ? rows : 1, sizeof(bool));
  r->delta = (double *)calloc(rows ? rows : 1, sizeof(double));
  r->relative = (double *)calloc(rows ? rows : 1, sizeof(double));
  r->causes = (cbfgen_cause *)calloc(rows ? rows : 1, sizeof(cbfgen_cause));
  r->relaxation = (cbfgen_family_relaxation *)calloc(d->n_families ? d->n_families : 1,
                                                     sizeof(cbfgen_family_relaxation));
  if (!r->u || !r->active || !r->delta || !r->relative || !r->causes || !r->relaxation) {
    return cbfgen_fail(err, CBFGEN_ERROR_CODE_NULL_POINTER, "out of memory for the report's buffers");
  }
  return sys->filter_report(filter, r, err);
}

static inline void cbfgen_report_free(cbfgen_report *r) {
  free(r->u);
  free(r->active);
  free(r->delta);
  free(r->relative);
  free(r->causes);
  free(r->relaxation);
  memset(r, 0, sizeof *r);
}

#ifdef __cplusplus
}
#endif

#endif /* CBFGEN_H */
