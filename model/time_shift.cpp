#include "model/time_shift.h"

#include <stdexcept>

namespace sigmaheart::model {

ParameterSpace TimeShift::shifted_space(const ParameterSpace& inner) {
  if (inner.index(kName)) throw std::invalid_argument(std::string(kName) + " is already a parameter");
  std::vector<Parameter> params = inner.all();
  params.push_back({kName, "s", 0.0, -1.0, 1.0,
                    "time shift of the model's clock against the data's, t_model = t + t_shift (model/time_shift.h)",
                    "timing", 0});
  return ParameterSpace(std::move(params));
}

TimeShift::TimeShift(std::unique_ptr<SteppableSimulator> inner)
    : WrappedSimulator(std::move(inner), "TimeShift") {
  space_ = shifted_space(inner_->parameters());
}

RunResult TimeShift::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  RunResult r = inner_->run(inner_theta(theta));
  r.trajectory.times.array() -= shift(theta);
  return r;
}

State TimeShift::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  return inner_->initial_state(inner_theta(theta));
}

Status TimeShift::advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end) {
  const double s = shift(theta);
  State inner{state.time > 0.0 ? state.time + s : state.time, std::move(state.x)};
  const Status st = inner_->advance(inner, inner_theta(theta), t_end + s);
  state.x = std::move(inner.x);
  state.time = st.ok() ? t_end : inner.time - s;
  return st;
}

Eigen::VectorXd TimeShift::sample(const State& state, const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  const State inner{state.time > 0.0 ? state.time + shift(theta) : state.time, state.x};
  return inner_->sample(inner, inner_theta(theta));
}

}  // namespace sigmaheart::model
