// A safety-filter controller with ros2_control's life cycle: configure (load the system,
// size every buffer), activate, then update at 1 kHz (no allocation, no exception),
// deactivate. It wraps any nominal controller: update() takes the nominal command and
// returns the safe one.
#pragma once

#include <cbfgen/cbfgen.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

// As controller_interface::return_type.
enum class ReturnType { OK, ERROR };

class SafetyFilterController {
 public:
  // What on_configure needs: the system, and its parameters (the world it must keep out of).
  using ParamsFactory = std::function<cbfgen::Params(const cbfgen::System&)>;

  SafetyFilterController(const cbfgen_plugin_v1* table, ParamsFactory make_params)
      : table_(table), make_params_(std::move(make_params)) {}

  // Check the library, build the parameters and the filter (rows and report buffers are
  // allocated here, once). Errors are reported, not thrown, as a controller's are.
  ReturnType on_configure() {
    try {
      system_.emplace(table_);
      params_.emplace(make_params_(*system_));
      filter_.emplace(*system_, *params_);
      command_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(system_->nu()));
      return ReturnType::OK;
    } catch (const cbfgen::Error& e) {
      last_error_ = e.what();
      return ReturnType::ERROR;
    }
  }

  ReturnType on_activate() { return filter_ ? ReturnType::OK : ReturnType::ERROR; }
  ReturnType on_deactivate() { return ReturnType::OK; }

  // One control period: the safe command for `state` at `time` given the nominal one.
  // On a refused update the command is the filter's fallback (the nominal input clipped
  // to the limits, reported as unsafe) and the controller reports ERROR.
  ReturnType update(double time, const Eigen::Ref<const Eigen::VectorXd>& state,
                    const Eigen::Ref<const Eigen::VectorXd>& nominal) noexcept {
    if (!filter_) return ReturnType::ERROR;  // not configured
    if (filter_->update(time, state, nominal, *params_)) {
      command_ = filter_->u();
      return ReturnType::OK;
    }
    filter_->fallback(nominal, command_);
    return ReturnType::ERROR;
  }

  const Eigen::VectorXd& command() const noexcept { return command_; }
  const cbfgen::Filter& filter() const noexcept { return *filter_; }
  const cbfgen::System& system() const noexcept { return *system_; }
  cbfgen::Params& params() noexcept { return *params_; }
  const std::string& last_error() const noexcept { return last_error_; }

 private:
  const cbfgen_plugin_v1* table_;
  ParamsFactory make_params_;
  std::optional<cbfgen::System> system_;
  std::optional<cbfgen::Params> params_;
  std::optional<cbfgen::Filter> filter_;
  Eigen::VectorXd command_;
  std::string last_error_;
};
