// One filter update of the double integrator through the C++ wrapper: the update the Rust
// criterion bench `double_integrator/update` times (systems/double_integrator/benches/
// update.rs), at the same state, parameters and nominal input, reading the input back as
// it does. Prints the median over samples of the mean time per update, wall and thread
// CPU, in nanoseconds:  update_ns wall=<median> cpu=<median> samples=<n> updates=<per sample>
//
//   update_bench [samples] [updates per sample]     (defaults 31, 200000)
#include <cbfgen/cbfgen.hpp>
#include <cbfgen/systems/double_integrator.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

namespace {

double thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int samples = argc > 1 ? std::atoi(argv[1]) : 31;
  const int updates = argc > 2 ? std::atoi(argv[2]) : 200000;
  if (samples < 1 || updates < 1) {
    std::fprintf(stderr, "usage: update_bench [samples >= 1] [updates per sample >= 1]\n");
    return 2;
  }
  cbfgen::System system(cbfgen_double_integrator_plugin_v1());
  cbfgen::Params params(system);
  params.set("sine_barrier", Eigen::Vector3d(0.1, 2.0, -0.05));  // amplitude, omega, offset
  cbfgen::Filter filter(system, params);
  // 2 cm above the boundary and falling towards it: the row is active and binds.
  const double t = 0.3;
  const Eigen::Vector2d x(std::fma(0.1, std::sin(0.6), -0.03), -0.5);
  const Eigen::Matrix<double, 1, 1> u_ref(-3.0);
  if (!filter.update(t, x, u_ref, params) || filter.report().active_rows != 1) {
    std::fprintf(stderr, "the benchmark's state does not bind the row: %s\n", filter.error_message().c_str());
    return 1;
  }
  volatile double sink = 0.0;  // the input is read back, as the Rust bench returns it
  for (int k = 0; k < updates; ++k) {  // warm-up: caches, branch predictors, frequency
    filter.update(t, x, u_ref, params);
    sink = sink + filter.u()[0];
  }
  std::vector<double> wall, cpu;
  for (int s = 0; s < samples; ++s) {
    const double cpu_start = thread_cpu_ns();
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < updates; ++k) {
      filter.update(t, x, u_ref, params);
      sink = sink + filter.u()[0];
    }
    const double elapsed = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
    wall.push_back(elapsed / updates);
    cpu.push_back((thread_cpu_ns() - cpu_start) / updates);
  }
  std::printf("update_ns wall=%.2f cpu=%.2f samples=%d updates=%d\n", median(wall), median(cpu), samples, updates);
  return std::isfinite(sink) ? 0 : 1;
}
