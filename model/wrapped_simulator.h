// The base of simulators that wrap another steppable simulator and change only its parameters
// (TimeShift, ZonedSimulator): the name, channels and state layout are the inner model's; the
// wrapper has its own parameter space and maps theta onto the inner model's in run/advance/sample.
// clone() and with_time_step_factor() wrap a clone (or a finer copy) of the inner model the same
// way, through rewrap().
#pragma once

#include "model/simulator.h"

#include <memory>
#include <stdexcept>
#include <string>

namespace sigmaheart::model {

class WrappedSimulator : public SteppableSimulator {
 public:
  std::string name() const override { return inner_->name(); }
  const ParameterSpace& parameters() const override { return space_; }
  std::vector<Channel> channels() const override { return inner_->channels(); }
  std::vector<Channel> state_layout() const override { return inner_->state_layout(); }
  const SteppableSimulator& inner() const { return *inner_; }

  std::unique_ptr<Simulator> clone() const override {
    std::unique_ptr<SteppableSimulator> inner = into_steppable(inner_->clone());
    if (!inner) throw std::logic_error(std::string(what_) + ": the inner clone is not steppable");
    return rewrap(std::move(inner));
  }
  std::unique_ptr<SteppableSimulator> with_time_step_factor(double factor) const override {
    std::unique_ptr<SteppableSimulator> finer = inner_->with_time_step_factor(factor);
    if (!finer) return nullptr;
    return rewrap(std::move(finer));
  }

 protected:
  // `what` names the wrapper in errors; throws std::invalid_argument when inner is null.
  WrappedSimulator(std::unique_ptr<SteppableSimulator> inner, const char* what)
      : inner_(std::move(inner)), what_(what) {
    if (!inner_) throw std::invalid_argument(std::string(what_) + ": no inner simulator");
  }

  // This wrapper (same options) around another inner simulator.
  virtual std::unique_ptr<SteppableSimulator> rewrap(std::unique_ptr<SteppableSimulator> inner) const = 0;

  std::unique_ptr<SteppableSimulator> inner_;
  ParameterSpace space_;  // set by the derived constructor

 private:
  const char* what_;
};

}  // namespace sigmaheart::model
