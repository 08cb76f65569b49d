// Two safety-filter controllers at 1 kHz: the built-in double integrator kept above a
// moving boundary, and a user's spec (examples/your_robot: a unicycle in a corridor,
// driven straight at an obstacle). Each is simulated with its own dynamics; the clearance
// is measured by plain geometry here, not by the filter's rows. Exits 1 if an update
// failed or the clearance went below -kSampledDip.
#include <cbfgen/systems/double_integrator.h>
#include <cbfgen/systems/your_robot.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "safety_filter_controller.hpp"

namespace {

// The filter's guarantee is in continuous time; a command held for 1 ms lets the state dip
// by O(dt) before the next sample (here up to ~50 um on the double integrator, whose
// boundary moves at 0.4 m/s). The Rust filter's sampled-data certificate removes the dip
// (docs/filter.md); it is not in the C ABI yet.
constexpr double kSampledDip = 1e-4;  // [m]

struct Run {
  double min_clearance = INFINITY;
  int updates = 0, failed = 0, relaxed = 0;
  double max_update_us = 0.0, total_update_us = 0.0;
};

// Simulate `controller` for `seconds` at 1 kHz from `x`, the nominal command from
// `nominal(t, x)`, the clearance from `clearance(t, x)`.
template <class Nominal, class Clearance>
Run simulate(SafetyFilterController& controller, Eigen::VectorXd x, double seconds, Nominal nominal,
             Clearance clearance) {
  const double dt = 1e-3;
  Run run;
  for (int k = 0; k < static_cast<int>(seconds / dt); ++k) {
    const double t = k * dt;
    const Eigen::VectorXd u_nominal = nominal(t, x);
    const auto start = std::chrono::steady_clock::now();
    const ReturnType status = controller.update(t, x, u_nominal);
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    run.updates += 1;
    run.failed += status != ReturnType::OK;
    run.relaxed += !controller.filter().met();
    run.max_update_us = std::max(run.max_update_us, us);
    run.total_update_us += us;
    x += dt * controller.system().xdot(x, controller.command());
    run.min_clearance = std::min(run.min_clearance, clearance(t + dt, x));
  }
  return run;
}

bool report(const char* name, const Run& run, const char* unit) {
  std::printf("%s: %d updates, %d failed, %d relaxed; min clearance %.3e %s; update mean %.1f us, max %.1f us\n",
              name, run.updates, run.failed, run.relaxed, run.min_clearance, unit,
              run.total_update_us / run.updates, run.max_update_us);
  return run.failed == 0 && run.min_clearance >= -kSampledDip;
}

}  // namespace

int main() {
  // The double integrator q'' = u above s(t) = A sin(w t) + c, pushed down at 5 m/s^2.
  const double A = 0.2, w = 2.0, c = -0.5;
  SafetyFilterController lift(cbfgen_double_integrator_plugin_v1(), [&](const cbfgen::System& system) {
    cbfgen::Params params(system);
    params.set("sine_barrier", Eigen::Vector3d(A, w, c));  // amplitude, omega, offset
    return params;
  });
  // The unicycle (px, py, heading, speed; accel, turn rate) in a corridor |y| <= 1 m, under
  // 1.5 m/s, driven at full throttle straight at a disc of radius 0.5 m at (3, 0.05).
  const double ox = 3.0, oy = 0.05, radius = 0.5;
  SafetyFilterController unicycle(cbfgen_your_robot_plugin_v1(), [&](const cbfgen::System& system) {
    cbfgen::Params params(system, {{system.family("obstacle"), 0, 4}});  // room for 4 discs
    params.set("speed_limit", {1.5});
    params.push("obstacle", {ox, oy, radius});                   // centre, radius
    params.set("corridor", Eigen::Vector3d(0.0, 1.0, 1.0), 0);  // normal (0, 1), offset 1: y >= -1
    params.set("corridor", Eigen::Vector3d(0.0, -1.0, 1.0), 1);  // y <= 1
    return params;
  });
  for (SafetyFilterController* controller : {&lift, &unicycle}) {
    if (controller->on_configure() != ReturnType::OK || controller->on_activate() != ReturnType::OK) {
      std::fprintf(stderr, "configure failed: %s\n", controller->last_error().c_str());
      return 1;
    }
  }

  const Run lifted = simulate(
      lift, Eigen::Vector2d(0.0, 0.0), 2.0, [](double, const Eigen::VectorXd&) { return Eigen::VectorXd::Constant(1, -5.0); },
      [&](double t, const Eigen::VectorXd& x) { return x[0] - (A * std::sin(w * t) + c); });
  const Run drove = simulate(
      unicycle, Eigen::Vector4d(0.0, 0.0, 0.0, 0.0), 6.0,
      [](double, const Eigen::VectorXd&) { return Eigen::Vector2d(2.0, 0.0).eval(); },
      [&](double, const Eigen::VectorXd& x) {
        const double to_disc = std::hypot(x[0] - ox, x[1] - oy) - radius;
        return std::min({to_disc, x[1] + 1.0, 1.0 - x[1]});
      });
  const bool ok = report("double_integrator", lifted, "m") & report("your_robot", drove, "m");
  return ok ? 0 : 1;
}
