// The C++ wrapper's error path: configuration errors throw cbfgen::Error with their code
// and message; per-cycle errors return false with the code kept in the filter, and the
// filter works again on the next good call. Prints one line per case; exits 1 on any miss.
#include <cbfgen/cbfgen.hpp>
#include <cbfgen/systems/double_integrator.h>

#include <cstdio>
#include <string>

namespace {

int failures = 0;

void expect(bool ok, const char* what) {
  std::printf("%s %s\n", ok ? "ok" : "FAILED", what);
  failures += !ok;
}

// Whether `f` throws cbfgen::Error with `code` and a message containing `text`.
template <class F>
bool throws(F f, std::uint32_t code, const std::string& text) {
  try {
    f();
  } catch (const cbfgen::Error& e) {
    std::printf("  threw %u: %s\n", e.code(), e.what());
    return e.code() == code && std::string(e.what()).find(text) != std::string::npos;
  }
  return false;
}

}  // namespace

int main() {
  expect(throws([] { cbfgen::System s(nullptr); }, CBFGEN_ERROR_CODE_NULL_POINTER, "null pointer"),
         "a null table is refused");
  cbfgen::System system(cbfgen_double_integrator_plugin_v1());
  expect(system.name() == "double_integrator" && system.nx() == 2 && system.nu() == 1, "the description");

  cbfgen::Params params(system);
  expect(throws([&] { params.set("no_such_family", Eigen::Vector3d(0.2, 2.0, -0.5)); },
                CBFGEN_ERROR_CODE_UNKNOWN_NAME, "it has sine_barrier"),
         "an unknown family names the known ones");
  expect(throws([&] { params.set("sine_barrier", Eigen::Vector2d(0.2, 2.0)); }, CBFGEN_ERROR_CODE_LENGTH_MISMATCH,
                "expected length 3, got 2"),
         "a wrong number of parameters");
  expect(throws([&] { params.set("sine_barrier", {0.2, 2.0, -0.5, 1.0}); }, CBFGEN_ERROR_CODE_LENGTH_MISMATCH,
                "expected length 3, got 4"),
         "a wrong number of parameters, written out");
  expect(throws([&] { params.push("sine_barrier", Eigen::Vector3d(0.2, 2.0, -0.5)); },
                CBFGEN_ERROR_CODE_UNSUPPORTED, "fixed"),
         "pushing onto a fixed family");
  expect(throws([&] { cbfgen::Params p(system, {{5, 0, 3}}); }, CBFGEN_ERROR_CODE_NO_SUCH_INDEX, "family"),
         "a capacity for a family that does not exist");

  const cbfgen::Params unset(system);  // copied below: the clone is unset too
  params.set("sine_barrier", {0.2, 2.0, -0.5});
  cbfgen::Filter filter(system, params);
  const Eigen::Vector2d falling(-0.45, -1.0);  // 5 cm above the boundary at t = 0, falling at 1 m/s
  const Eigen::VectorXd push_down = Eigen::VectorXd::Constant(1, -5.0);

  expect(!filter.update(0.0, Eigen::Vector3d(0.0, 0.0, 0.0), push_down, params) &&
             filter.error().code == CBFGEN_ERROR_CODE_LENGTH_MISMATCH &&
             filter.error_message() == "state: expected length 2, got 3",
         "a state of the wrong length is refused with its code");
  const cbfgen::Params unset_copy = unset;
  expect(!filter.update(0.0, falling, push_down, unset_copy) &&
             filter.error().code == CBFGEN_ERROR_CODE_PARAM_OUT_OF_DOMAIN &&
             filter.error_message().find("never set") != std::string::npos,
         "unset parameters are refused");
  Eigen::VectorXd fallback(1);
  expect(filter.fallback(push_down, fallback) && fallback[0] == -5.0, "the fallback is the clipped nominal input");

  // The next good update works, and brakes as the ECBF asks: u >= -20 h' - 100 h = 23.
  expect(filter.update(0.0, falling, push_down, params) && filter.met() && filter.u()[0] >= 23.0 - 1e-9,
         "the filter recovers and holds the boundary");
  expect(filter.rows() == 1 && filter.active(0) && filter.cause(0).kind == 0, "the row report");
  const cbfgen_row_layout row = filter.layout(0);
  expect(row.family == 0 && row.instance == 0, "the row's place");
  expect(throws([&] { filter.layout(1); }, CBFGEN_ERROR_CODE_NO_SUCH_INDEX, "no row 1"), "no such row");
  expect(filter.worst_case().qp_solves >= 1, "the stated worst case");

  // Settings outside their domain are refused at construction.
  cbfgen::Settings settings = cbfgen::Settings::defaults(system);
  settings.input_weights[0] = -1.0;
  expect(throws([&] { cbfgen::Filter f(system, settings, params); }, CBFGEN_ERROR_CODE_OUT_OF_RANGE, "input weight"),
         "a negative input weight");
  return failures == 0 ? 0 : 1;
}
