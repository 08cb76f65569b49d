/* A closed loop in C on the double integrator's static library: 2 000 updates at 1 kHz,
 * the nominal input pushing down through the moving boundary, Euler steps of the system's
 * own dynamics. Prints t, q, q', u per step as hexadecimal floats (exact), for the test to
 * compare with the Rust filter's (through Python) bit for bit. */
#include <cbfgen/cbfgen.h>
#include <cbfgen/systems/double_integrator.h>

static int failed(const char *what, const cbfgen_error *err) {
  fprintf(stderr, "%s: %.*s\n", what, (int)err->len, (const char *)err->text);
  return 1;
}

int main(void) {
  const cbfgen_plugin_v1 *sys = cbfgen_double_integrator_plugin_v1();
  cbfgen_error err = {0, 0, {0}};
  const double boundary[3] = {0.2, 2.0, -0.5}; /* amplitude, omega, offset */
  const double dt = 1e-3, u_ref[1] = {-5.0};
  double x[2] = {0.0, 0.0}, xdot[2], u[1];
  cbfgen_handle params, filter;
  cbfgen_report report;
  long family;
  int k, verdict;
  if (cbfgen_check(sys, &err) != 0) return failed("check", &err);
  params = sys->params_new(NULL, 0, &err);
  if (params == NULL) return failed("params", &err);
  family = cbfgen_family_index(sys, "sine_barrier");
  if (family < 0 || cbfgen_params_set(sys, params, (size_t)family, 0, 0, boundary, 3, &err) != 0) {
    return failed("set", &err);
  }
  filter = cbfgen_filter_new_default(sys, NULL, 0, &err);
  if (filter == NULL || cbfgen_report_init(sys, filter, &report, &err) != 0) return failed("filter", &err);
  for (k = 0; k < 2000; ++k) {
    const double t = k * dt;
    verdict = sys->filter_update(filter, t, x, 2, u_ref, 1, params, u, 1, &err);
    if (verdict < 0) return failed("update", &err);
    /* The full report agrees with what the update returned. */
    if (sys->filter_report(filter, &report, &err) != 0) return failed("report", &err);
    if (report.u[0] != u[0] || report.safety.verdict != verdict) {
      fprintf(stderr, "step %d: the report says u %a verdict %u, the update %a %d\n", k, report.u[0],
              (unsigned)report.safety.verdict, u[0], verdict);
      return 1;
    }
    printf("%a %a %a %a %d\n", t, x[0], x[1], u[0], verdict);
    if (sys->dynamics(CBFGEN_DYNAMICS_XDOT, x, 2, u, 1, xdot, 2, &err) != 0) return failed("xdot", &err);
    x[0] = x[0] + dt * xdot[0];
    x[1] = x[1] + dt * xdot[1];
  }
  cbfgen_report_free(&report);
  sys->filter_free(filter);
  sys->params_free(params);
  return 0;
}
