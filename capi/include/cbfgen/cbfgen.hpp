// cbfgen from C++17: a generated system's safety filter with RAII handles and Eigen maps.
//
//   #include <cbfgen/cbfgen.hpp>
//   #include <cbfgen/systems/double_integrator.h>
//
//   cbfgen::System system(cbfgen_double_integrator_plugin_v1());   // checks the ABI
//   cbfgen::Params params(system);
//   params.set("sine_barrier", Eigen::Vector3d(0.2, 2.0, -0.5));  // amplitude, omega, offset
//   cbfgen::Filter filter(system, params);                         // default settings
//   // every cycle (no allocation, no exception):
//   if (!filter.update(t, x, u_nominal, params)) { /* filter.error_message() */ }
//   apply(filter.u());                                             // safe unless !filter.met()
//
// Configuration throws cbfgen::Error (its code() a cbfgen_error_code); the per-cycle calls
// (Filter::update, Filter::fallback) are noexcept and report failure by their return value,
// with the code and message kept in the filter. A Filter is used by one thread at a time.
#ifndef CBFGEN_HPP
#define CBFGEN_HPP

#include <Eigen/Core>
#include <cstddef>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cbfgen.h"

namespace cbfgen {

// An error from a configuration call: its code (cbfgen_error_code) and message.
class Error : public std::runtime_error {
 public:
  Error(std::uint32_t code, const std::string& message) : std::runtime_error(message), code_(code) {}
  explicit Error(const cbfgen_error& e)
      : Error(e.code, std::string(reinterpret_cast<const char*>(e.text), e.len)) {}
  std::uint32_t code() const noexcept { return code_; }

 private:
  std::uint32_t code_;
};

namespace detail {
inline std::string str(cbfgen_str s) { return std::string(reinterpret_cast<const char*>(s.ptr), s.len); }
inline void check(long long status, const cbfgen_error& e) {
  if (status < 0) throw Error(e);
}
inline cbfgen_handle handle(cbfgen_handle h, const cbfgen_error& e) {
  if (h == nullptr) throw Error(e);
  return h;
}
}  // namespace detail

using Vector = Eigen::VectorXd;
using VectorRef = Eigen::Ref<const Eigen::VectorXd>;

// A system: its entry table, checked against these headers once. Cheap to copy.
class System {
 public:
  explicit System(const cbfgen_plugin_v1* table) : table_(table) {
    cbfgen_error err{};
    detail::check(cbfgen_check(table, &err), err);
  }
  const cbfgen_plugin_v1& table() const noexcept { return *table_; }
  const cbfgen_description& description() const noexcept { return *table_->describe(); }
  std::string name() const { return detail::str(description().name); }
  std::size_t nx() const noexcept { return description().nx; }
  std::size_t nu() const noexcept { return description().nu; }
  std::size_t families() const noexcept { return description().n_families; }

  // The index of family `name` (throws UNKNOWN_NAME, listing the families).
  std::size_t family(const std::string& name) const {
    long i = cbfgen_family_index(table_, name.c_str());
    if (i >= 0) return static_cast<std::size_t>(i);
    std::string known;
    for (std::size_t f = 0; f < families(); ++f) {
      known += (f ? ", " : "") + detail::str(description().families[f].name);
    }
    throw Error(CBFGEN_ERROR_CODE_UNKNOWN_NAME, this->name() + ": no family \"" + name + "\" (it has " + known + ")");
  }

  // The index of member `name` of an indexed family (throws UNKNOWN_NAME).
  std::size_t member(std::size_t family, const std::string& name) const {
    long i = cbfgen_member_index(table_, family, name.c_str());
    if (i < 0) throw Error(CBFGEN_ERROR_CODE_UNKNOWN_NAME, this->name() + ": no member \"" + name + "\"");
    return static_cast<std::size_t>(i);
  }

  // ẋ = f(x) + g(x) u.
  Vector xdot(const VectorRef& x, const VectorRef& u) const {
    Vector out(static_cast<Eigen::Index>(nx()));
    cbfgen_error err{};
    detail::check(table_->dynamics(CBFGEN_DYNAMICS_XDOT, x.data(), static_cast<std::size_t>(x.size()), u.data(),
                                   static_cast<std::size_t>(u.size()), out.data(), nx(), &err),
                  err);
    return out;
  }

 private:
  const cbfgen_plugin_v1* table_;
};

// Runtime parameters (obstacles, boundaries, limits): owned, movable, copied by cloning.
class Params {
 public:
  // Parameters with `capacity` slots for capacity families (none: each one's default).
  explicit Params(const System& system, const std::vector<cbfgen_capacity_count>& capacity = {})
      : system_(system), handle_(nullptr) {
    cbfgen_error err{};
    handle_ = detail::handle(system.table().params_new(capacity.data(), capacity.size(), &err), err);
  }
  Params(const Params& other) : system_(other.system_), handle_(nullptr) {
    cbfgen_error err{};
    handle_ = detail::handle(system_.table().params_clone(other.handle_, &err), err);
  }
  Params(Params&& other) noexcept : system_(other.system_), handle_(std::exchange(other.handle_, nullptr)) {}
  Params& operator=(Params other) noexcept {
    std::swap(handle_, other.handle_);
    std::swap(system_, other.system_);
    return *this;
  }
  ~Params() { system_.table().params_free(handle_); }

  // Instance `instance` of family `family` (member `member`) to `values`: its parameters
  // in order, each flattened row-major.
  Params& set(std::size_t family, std::size_t member, std::size_t instance, const VectorRef& values) {
    cbfgen_error err{};
    detail::check(cbfgen_params_set(&system_.table(), handle_, family, member, instance, values.data(),
                                    static_cast<std::size_t>(values.size()), &err),
                  err);
    return *this;
  }
  Params& set(const std::string& family, const VectorRef& values, std::size_t instance = 0) {
    return set(system_.family(family), 0, instance, values);
  }
  // The same with the numbers written out: params.set("speed_limit", {1.5}).
  Params& set(const std::string& family, std::initializer_list<double> values, std::size_t instance = 0) {
    return set(family, VectorRef(Eigen::Map<const Vector>(values.begin(), static_cast<Eigen::Index>(values.size()))),
               instance);
  }
  // Add an instance to a capacity or optional family.
  Params& push(const std::string& family, const VectorRef& values) {
    cbfgen_error err{};
    detail::check(cbfgen_params_push(&system_.table(), handle_, system_.family(family), 0, values.data(),
                                     static_cast<std::size_t>(values.size()), &err),
                  err);
    return *this;
  }
  Params& push(const std::string& family, std::initializer_list<double> values) {
    return push(family, VectorRef(Eigen::Map<const Vector>(values.begin(), static_cast<Eigen::Index>(values.size()))));
  }
  // Remove every instance of a capacity or optional family.
  Params& clear(const std::string& family) {
    cbfgen_error err{};
    detail::check(system_.table().store(handle_, CBFGEN_STORE_CLEAR, system_.family(family), 0, 0, nullptr, 0,
                                        false, &err),
                  err);
    return *this;
  }
  cbfgen_handle handle() const noexcept { return handle_; }
  const System& system() const noexcept { return system_; }

 private:
  System system_;
  cbfgen_handle handle_;
};

// A filter's settings, owned: per family its poles, priority, activation and class-K
// function; per input its weight and limits; the solver's.
struct Settings {
  std::vector<cbfgen_family_params> families;
  Vector input_weights, input_min, input_max;
  cbfgen_solver solver{};
  bool measure_cpu_time = false;
  bool cull_far_rows = true;

  // The system's defaults (its spec's poles, its input limits).
  static Settings defaults(const System& system) {
    Settings s;
    s.families.resize(system.families());
    s.input_weights.resize(static_cast<Eigen::Index>(system.nu()));
    s.input_min.resize(s.input_weights.size());
    s.input_max.resize(s.input_weights.size());
    cbfgen_settings c = s.view();
    cbfgen_error err{};
    detail::check(system.table().default_settings(&c, &err), err);
    s.solver = c.solver;
    s.measure_cpu_time = c.measure_cpu_time;
    s.cull_far_rows = c.cull_far_rows;
    return s;
  }
  // The C view of these settings (pointing into them).
  cbfgen_settings view() {
    cbfgen_settings c{};
    c.n_families = families.size();
    c.n_inputs = static_cast<std::size_t>(input_weights.size());
    c.families = families.data();
    c.input_weights = input_weights.data();
    c.input_min = input_min.data();
    c.input_max = input_max.data();
    c.solver = solver;
    c.measure_cpu_time = measure_cpu_time;
    c.cull_far_rows = cull_far_rows;
    return c;
  }
};

// The ECBF-QP safety filter. Rows are laid out at construction for `params`' capacities;
// every buffer of the report is allocated then, so update() allocates nothing.
class Filter {
 public:
  Filter(const System& system, const Params& params) : Filter(system, Settings::defaults(system), params) {}
  Filter(const System& system, Settings settings, const Params& params) : system_(system), handle_(nullptr) {
    std::vector<cbfgen_capacity_count> capacity = capacity_of(params);
    cbfgen_settings c = settings.view();
    handle_ = detail::handle(system.table().filter_new(capacity.data(), capacity.size(), &c, &error_), error_);
    report_buffers();
  }
  Filter(const Filter&) = delete;
  Filter& operator=(const Filter&) = delete;
  Filter(Filter&& other) noexcept
      : system_(other.system_),
        handle_(std::exchange(other.handle_, nullptr)),
        u_(std::move(other.u_)),
        active_(std::move(other.active_)),
        delta_(std::move(other.delta_)),
        relative_(std::move(other.relative_)),
        causes_(std::move(other.causes_)),
        relaxation_(std::move(other.relaxation_)),
        report_(other.report_),
        report_stale_(other.report_stale_),
        verdict_(other.verdict_),
        error_(other.error_) {
    point_report();
  }
  ~Filter() { system_.table().filter_free(handle_); }

  // One update: the safe input for state `x` at time `t` (s) given the nominal `u_ref`.
  // True when it ran (then u() is the input to apply and met() says whether every safety
  // row held); false with error() set when the call was refused (a wrong length,
  // parameters of another system): apply fallback() then.
  bool update(double t, const VectorRef& x, const VectorRef& u_ref, const Params& params) noexcept {
    const int verdict = system_.table().filter_update(handle_, t, x.data(), static_cast<std::size_t>(x.size()),
                                                      u_ref.data(), static_cast<std::size_t>(u_ref.size()),
                                                      params.handle(), u_.data(), u_.size(), &error_);
    if (verdict < 0) return false;
    verdict_ = static_cast<std::uint8_t>(verdict);
    report_stale_ = true;
    return true;
  }
  // The input to apply after update() returned true.
  Eigen::Map<const Vector> u() const noexcept {
    return Eigen::Map<const Vector>(u_.data(), static_cast<Eigen::Index>(u_.size()));
  }
  // The filter's fallback for `u_ref` (its nominal input clipped to the limits), into `out`.
  bool fallback(const VectorRef& u_ref, Eigen::Ref<Vector> out) noexcept {
    return system_.table().filter_fallback(handle_, u_ref.data(), static_cast<std::size_t>(u_ref.size()),
                                           out.data(), static_cast<std::size_t>(out.size()), &error_) == 0;
  }

  // Every safety row held (no row relaxed) in the last update.
  bool met() const noexcept { return verdict_ == CBFGEN_VERDICT_MET; }
  // The last update's verdict: CBFGEN_VERDICT_MET, _RELAXED or _UNASSESSED.
  std::uint8_t verdict() const noexcept { return verdict_; }

  // The last update's full report: relaxed rows and why, solver, timings. Read from the
  // filter on the first call after an update (copies into buffers sized at construction:
  // no allocation).
  const cbfgen_report& report() const noexcept {
    if (report_stale_) {
      cbfgen_error err{};
      report_stale_ = system_.table().filter_report(handle_, &report_, &err) != 0;
    }
    return report_;
  }
  std::size_t relaxed_rows() const noexcept { return report().safety.relaxed_rows; }
  // Per row: active, its slack, and why it was relaxed (cause.kind 0: it was not).
  std::size_t rows() const noexcept { return report_.n_rows; }
  bool active(std::size_t row) const noexcept { return report().active[row]; }
  double slack(std::size_t row) const noexcept { return report().delta[row]; }
  cbfgen_cause cause(std::size_t row) const noexcept { return report().causes[row]; }
  // Where row `row` is: its family, member, instance and row within the instance.
  cbfgen_row_layout layout(std::size_t row) const {
    cbfgen_row_layout l{};
    if (!system_.table().layout(handle_, true, row, &l)) {
      throw Error(CBFGEN_ERROR_CODE_NO_SUCH_INDEX, "no row " + std::to_string(row));
    }
    return l;
  }
  // The stated worst case of one update (counts; times with a calibration).
  cbfgen_worst_case worst_case() const {
    cbfgen_worst_case w{};
    cbfgen_error err{};
    detail::check(system_.table().filter_worst_case(handle_, &w, &err), err);
    return w;
  }

  // The last refused call's error.
  const cbfgen_error& error() const noexcept { return error_; }
  std::string error_message() const { return std::string(reinterpret_cast<const char*>(error_.text), error_.len); }
  cbfgen_handle handle() const noexcept { return handle_; }

 private:
  // The capacity counts `params` were sized with, read from their stores.
  std::vector<cbfgen_capacity_count> capacity_of(const Params& params) const {
    std::vector<cbfgen_capacity_count> counts;
    const cbfgen_description& d = system_.description();
    for (std::size_t f = 0; f < d.n_families; ++f) {
      if (d.families[f].instances != 2) continue;  // only capacity families have slots to size
      std::size_t members = d.families[f].n_members ? d.families[f].n_members : 1;
      for (std::size_t m = 0; m < members; ++m) {
        cbfgen_error err{};
        long long slots = system_.table().store(params.handle(), CBFGEN_STORE_SLOTS, f, m, 0, nullptr, 0, false, &err);
        detail::check(slots, err);
        counts.push_back(cbfgen_capacity_count{f, m, static_cast<std::size_t>(slots)});
      }
    }
    return counts;
  }
  void report_buffers() {
    std::size_t rows = system_.table().rows_len(handle_, true);
    u_.assign(system_.nu(), 0.0);
    active_.assign(rows, false);
    delta_.assign(rows, 0.0);
    relative_.assign(rows, 0.0);
    causes_.assign(rows, cbfgen_cause{});
    relaxation_.assign(system_.families(), cbfgen_family_relaxation{});
    report_ = cbfgen_report{};
    point_report();
    detail::check(system_.table().filter_report(handle_, &report_, &error_), error_);
    verdict_ = report_.safety.verdict;
  }
  void point_report() noexcept {
    report_.n_u = u_.size();
    report_.n_rows = delta_.size();
    report_.n_families = relaxation_.size();
    report_.u = u_.data();
    report_.active = reinterpret_cast<bool*>(active_.data());
    report_.delta = delta_.data();
    report_.relative = relative_.data();
    report_.causes = causes_.data();
    report_.relaxation = relaxation_.data();
  }

  System system_;
  cbfgen_handle handle_;
  std::vector<double> u_;
  std::vector<unsigned char> active_;  // not vector<bool>: C's bool array, one byte each
  std::vector<double> delta_, relative_;
  std::vector<cbfgen_cause> causes_;
  std::vector<cbfgen_family_relaxation> relaxation_;
  mutable cbfgen_report report_{};
  mutable bool report_stale_ = false;
  std::uint8_t verdict_ = CBFGEN_VERDICT_UNASSESSED;
  cbfgen_error error_{};
};

}  // namespace cbfgen

#endif  // CBFGEN_HPP
