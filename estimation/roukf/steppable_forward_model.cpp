#include "estimation/roukf/steppable_forward_model.h"

#include <stdexcept>

namespace sigmaheart::estimation {

SteppableForwardModel::SteppableForwardModel(std::unique_ptr<model::SteppableSimulator> simulator,
                                             std::vector<int> channels, double t_end)
    : simulator_(std::move(simulator)), channels_(std::move(channels)), t_end_(t_end) {
  if (!simulator_) throw std::invalid_argument("SteppableForwardModel: null simulator");
  const int nc = static_cast<int>(simulator_->channels().size());
  for (int c : channels_) {
    if (c < 0 || c >= nc) throw std::invalid_argument("SteppableForwardModel: channel index");
  }
}

std::unique_ptr<model::SteppableSimulator> SteppableForwardModel::clone_steppable(
    const model::SteppableSimulator& s) {
  std::unique_ptr<model::SteppableSimulator> steppable = model::into_steppable(s.clone());
  if (!steppable) {
    throw std::logic_error("clone() of steppable simulator '" + s.name() + "' is not steppable");
  }
  return steppable;
}

int SteppableForwardModel::input_size() const { return simulator_->parameters().size(); }

std::vector<std::string> SteppableForwardModel::input_names() const {
  return simulator_->parameters().names();
}

std::vector<model::Channel> SteppableForwardModel::outputs() const {
  const auto all = simulator_->channels();
  std::vector<model::Channel> out;
  out.reserve(channels_.size());
  for (int c : channels_) out.push_back(all[static_cast<size_t>(c)]);
  return out;
}

model::Status SteppableForwardModel::evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                              Eigen::Ref<Eigen::VectorXd> z) {
  if (z.size() != static_cast<Eigen::Index>(channels_.size())) {
    return model::Status::Error(model::StatusCode::kInvalidArgument,
                                "SteppableForwardModel: z has the wrong size");
  }
  model::State state = simulator_->initial_state(theta);
  const model::Status st = simulator_->advance(state, theta, t_end_);
  if (!st.ok()) return st;
  const Eigen::VectorXd s = simulator_->sample(state, theta);
  for (size_t i = 0; i < channels_.size(); ++i) z(static_cast<Eigen::Index>(i)) = s(channels_[i]);
  return model::Status::Ok();
}

std::unique_ptr<ForwardModel> SteppableForwardModel::clone() const {
  return std::make_unique<SteppableForwardModel>(clone_steppable(*simulator_), channels_, t_end_);
}

}  // namespace sigmaheart::estimation
