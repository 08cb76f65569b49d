/* Bad calls through the C interface: each returns its error code and a message, never
 * crashes, and leaves the filter usable. Prints "<case> <code> <message>" per case; exits
 * 1 if any case returned something else than it should. */
#include <cbfgen/cbfgen.h>
#include <cbfgen/systems/double_integrator.h>

static int failures = 0;

static void expect(const char *name, long long status, long long fail_value, uint32_t code, cbfgen_error *err) {
  printf("%s %u %.*s\n", name, (unsigned)err->code, (int)err->len, (const char *)err->text);
  if (status != fail_value || err->code != code || err->len == 0) {
    fprintf(stderr, "%s: returned %lld with code %u, expected %lld with code %u\n", name, status,
            (unsigned)err->code, fail_value, (unsigned)code);
    ++failures;
  }
  memset(err, 0, sizeof *err);
}

int main(void) {
  const cbfgen_plugin_v1 *sys = cbfgen_double_integrator_plugin_v1();
  cbfgen_plugin_v1 other_abi = *sys;
  cbfgen_error err = {0, 0, {0}};
  const double good[3] = {0.2, 2.0, -0.5}, x[2] = {0.0, 0.0}, x3[3] = {0.0, 0.0, 0.0}, u_ref[1] = {-5.0};
  const double falling[2] = {-0.45, -1.0}; /* 5 cm above the boundary, falling at 1 m/s */
  double u[2], nan_boundary[3] = {0.2, 2.0, 0.0};
  cbfgen_handle params, unset, filter;
  cbfgen_report report;
  size_t rows;

  other_abi.abi_version = CBFGEN_ABI_VERSION + 1;
  expect("check_null", cbfgen_check(NULL, &err), -1, CBFGEN_ERROR_CODE_NULL_POINTER, &err);
  expect("check_abi", cbfgen_check(&other_abi, &err), -1, CBFGEN_ERROR_CODE_ABI_MISMATCH, &err);
  if (cbfgen_check(sys, &err) != 0) return 1;

  params = sys->params_new(NULL, 0, &err);
  unset = sys->params_new(NULL, 0, &err);
  filter = cbfgen_filter_new_default(sys, NULL, 0, &err);
  if (params == NULL || unset == NULL || filter == NULL) return 1;
  if (cbfgen_family_index(sys, "no_such_family") != -1) ++failures;
  expect("set_wrong_length", cbfgen_params_set(sys, params, 0, 0, 0, good, 2, &err), -1,
         CBFGEN_ERROR_CODE_LENGTH_MISMATCH, &err);
  expect("set_no_family", cbfgen_params_set(sys, params, 7, 0, 0, good, 3, &err), -1,
         CBFGEN_ERROR_CODE_NO_SUCH_INDEX, &err);
  nan_boundary[2] = 0.0 / 0.0;
  expect("set_nan", cbfgen_params_set(sys, params, 0, 0, 0, nan_boundary, 3, &err), -1,
         CBFGEN_ERROR_CODE_PARAM_OUT_OF_DOMAIN, &err);
  expect("store_bad_op", sys->store(params, 99, 0, 0, 0, NULL, 0, false, &err), -1,
         CBFGEN_ERROR_CODE_NO_SUCH_INDEX, &err);
  if (cbfgen_params_set(sys, params, 0, 0, 0, good, 3, &err) != 0) return 1;

  expect("update_null_filter", sys->filter_update(NULL, 0.0, x, 2, u_ref, 1, params, u, 1, &err), -1,
         CBFGEN_ERROR_CODE_NULL_POINTER, &err);
  expect("update_null_params", sys->filter_update(filter, 0.0, x, 2, u_ref, 1, NULL, u, 1, &err), -1,
         CBFGEN_ERROR_CODE_NULL_POINTER, &err);
  expect("update_null_state", sys->filter_update(filter, 0.0, NULL, 2, u_ref, 1, params, u, 1, &err), -1,
         CBFGEN_ERROR_CODE_NULL_POINTER, &err);
  expect("update_wrong_state_length", sys->filter_update(filter, 0.0, x3, 3, u_ref, 1, params, u, 1, &err), -1,
         CBFGEN_ERROR_CODE_LENGTH_MISMATCH, &err);
  expect("update_wrong_input_length", sys->filter_update(filter, 0.0, x, 2, u_ref, 0, params, u, 1, &err), -1,
         CBFGEN_ERROR_CODE_LENGTH_MISMATCH, &err);
  expect("update_wrong_output_length", sys->filter_update(filter, 0.0, x, 2, u_ref, 1, params, u, 2, &err), -1,
         CBFGEN_ERROR_CODE_LENGTH_MISMATCH, &err);
  expect("update_unset_params", sys->filter_update(filter, 0.0, x, 2, u_ref, 1, unset, u, 1, &err), -1,
         CBFGEN_ERROR_CODE_PARAM_OUT_OF_DOMAIN, &err);
  expect("dynamics_bad_op", sys->dynamics(7, x, 2, u_ref, 1, u, 1, &err), -1, CBFGEN_ERROR_CODE_NO_SUCH_INDEX,
         &err);
  expect("kernel_no_such", sys->kernel_call(1000, NULL, 0, NULL, 0, &err), -1, CBFGEN_ERROR_CODE_NO_SUCH_INDEX,
         &err);
  /* No error buffer: the call still fails cleanly. */
  if (sys->filter_update(NULL, 0.0, x, 2, u_ref, 1, params, u, 1, NULL) != -1) ++failures;

  /* A report sized for other rows is refused, not overrun. */
  if (cbfgen_report_init(sys, filter, &report, &err) != 0) return 1;
  rows = report.n_rows;
  report.n_rows = rows + 1;
  expect("report_wrong_rows", sys->filter_report(filter, &report, &err), -1, CBFGEN_ERROR_CODE_LENGTH_MISMATCH,
         &err);
  report.n_rows = rows;

  /* After every refusal the filter still works: falling onto the boundary, it brakes
   * (h = 0.05, h' = -1.4: the ECBF with poles 10, 10 asks u >= -20 h' - 100 h = 23). */
  if (sys->filter_update(filter, 0.0, falling, 2, u_ref, 1, params, u, 1, &err) != CBFGEN_VERDICT_MET ||
      !(u[0] >= 23.0 - 1e-6)) {
    fprintf(stderr, "the filter did not recover: %.*s\n", (int)err.len, (const char *)err.text);
    ++failures;
  }
  printf("recovered u %a\n", u[0]);

  sys->params_free(NULL); /* like free(NULL) */
  sys->filter_free(NULL);
  cbfgen_report_free(&report);
  sys->filter_free(filter);
  sys->params_free(unset);
  sys->params_free(params);
  return failures == 0 ? 0 : 1;
}
