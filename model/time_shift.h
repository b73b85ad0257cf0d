// A model whose clock runs a fitted time shift ahead of the data's: the parameter t_shift [s]
// (appended to the inner model's parameters, nominal 0) moves every observation time of an
// assimilation, t_model = t + t_shift (docs/estimation.md s.4.9, "Alignment").
//
// Aligning a foreign record on the model's beat by a landmark (end-diastole) is exact only to the
// frames' resolution: half a frame spacing, 14 ms at 30 frames of 0.85 s. A regional volume
// changes by up to 0.1 mL per ms, so on a five-patch twin with 0.05 mL noise the best curve shift
// from the prior-mean beat (4 ms off) still leaves a whole-data NIS of 160 against its band of
// 6.2. Estimated with the other parameters the shift is what the data say, as the offset of the
// ECG trigger is estimated in Marchesseau et al. 2013 (Med Image Anal 17:816, s.2.4, "time
// shift"): a shift changes what every member observes, not its dynamics.
//
// Stepping: the initial state (time 0) is the inner model's at 0; from there a state at time t
// is the inner model's at t + t_shift, so advance(state, theta, t_end) advances the inner model
// from state.time + t_shift (0 from the initial state) to t_end + t_shift. state.time stays in
// the data's clock. run() is the inner model's beat with its times moved by -t_shift.
#pragma once

#include "model/wrapped_simulator.h"

#include <memory>

namespace sigmaheart::model {

class TimeShift final : public WrappedSimulator {
 public:
  // Throws std::invalid_argument when inner is null or already has a parameter t_shift.
  explicit TimeShift(std::unique_ptr<SteppableSimulator> inner);

  static constexpr const char* kName = "t_shift";
  // inner's parameters, then t_shift [s] (nominal 0, bounds +-1 s).
  static ParameterSpace shifted_space(const ParameterSpace& inner);

  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  SIGMAHEART_STEPPING_OVERRIDES;

 private:
  Eigen::VectorXd inner_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
    return theta.head(inner_->parameters().size());
  }
  double shift(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
    return theta.size() == space_.size() ? theta(space_.size() - 1) : 0.0;
  }
  std::unique_ptr<SteppableSimulator> rewrap(std::unique_ptr<SteppableSimulator> inner) const override {
    return std::make_unique<TimeShift>(std::move(inner));
  }
};

}  // namespace sigmaheart::model
