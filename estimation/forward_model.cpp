#include "estimation/forward_model.h"

#include <set>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

namespace {

std::vector<int> indices_of(const model::ParameterSpace& space,
                            const std::vector<std::string>& names) {
  std::vector<int> out;
  out.reserve(names.size());
  for (const auto& n : names) out.push_back(space.index_or_throw(n));
  return out;
}

}  // namespace

SimulatorForwardModel::SimulatorForwardModel(const model::Simulator& simulator,
                                             const observers::Observer& observer,
                                             std::vector<int> estimated,
                                             Eigen::VectorXd base_theta)
    : simulator_(simulator.clone()),
      observer_(observer.clone()),
      estimated_(std::move(estimated)),
      base_theta_(std::move(base_theta)) {
  if (!simulator_ || !observer_) {
    throw std::invalid_argument("SimulatorForwardModel: clone() of simulator or observer is null");
  }
  const int n = simulator_->parameters().size();
  if (base_theta_.size() != n) {
    std::ostringstream s;
    s << "SimulatorForwardModel: base theta has " << base_theta_.size() << " entries, simulator '"
      << simulator_->name() << "' has " << n << " parameters";
    throw std::invalid_argument(s.str());
  }
  std::set<int> seen;
  for (int i : estimated_) {
    if (i < 0 || i >= n || !seen.insert(i).second) {
      std::ostringstream s;
      s << "SimulatorForwardModel: estimated parameter index " << i
        << " is out of range [0, " << n << ") or repeated";
      throw std::invalid_argument(s.str());
    }
  }
}

SimulatorForwardModel::SimulatorForwardModel(const model::Simulator& simulator,
                                             const observers::Observer& observer,
                                             const std::vector<std::string>& estimated_names)
    : SimulatorForwardModel(simulator, observer,
                            indices_of(simulator.parameters(), estimated_names),
                            simulator.parameters().nominal()) {}

std::vector<std::string> SimulatorForwardModel::input_names() const {
  std::vector<std::string> out;
  for (int i : estimated_) out.push_back(simulator_->parameters()[i].name);
  return out;
}

Eigen::VectorXd SimulatorForwardModel::full_theta(
    const Eigen::Ref<const Eigen::VectorXd>& theta_estimated) const {
  if (theta_estimated.size() != input_size()) {
    std::ostringstream s;
    s << "SimulatorForwardModel: expected " << input_size() << " estimated parameters, got "
      << theta_estimated.size();
    throw std::invalid_argument(s.str());
  }
  Eigen::VectorXd full = base_theta_;
  for (size_t k = 0; k < estimated_.size(); ++k) {
    full(estimated_[k]) = theta_estimated(static_cast<Eigen::Index>(k));
  }
  return full;
}

model::Status SimulatorForwardModel::evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                              Eigen::Ref<Eigen::VectorXd> z) {
  return evaluate_warm(theta, z, Eigen::VectorXd(), nullptr);
}

int SimulatorForwardModel::warm_start_size() const { return simulator_->warm_start_size(); }

model::Status SimulatorForwardModel::evaluate_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                                   Eigen::Ref<Eigen::VectorXd> z,
                                                   const Eigen::VectorXd& from,
                                                   Eigen::VectorXd* produce) {
  using model::Status;
  using model::StatusCode;
  if (produce) *produce = Eigen::VectorXd::Zero(warm_start_size());
  if (theta.size() != input_size() || z.size() != observer_->size()) {
    std::ostringstream s;
    s << "forward model: theta has " << theta.size() << " entries (expected " << input_size()
      << "), z has " << z.size() << " (expected " << observer_->size() << ")";
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  const Eigen::VectorXd full = full_theta(theta);
  if (const std::string bad = simulator_->parameters().check(full); !bad.empty()) {
    return Status::Error(StatusCode::kOutOfBounds, "parameters: " + bad);
  }
  last_run_ = simulator_->run_warm(full, from, produce);
  if (!last_run_.status.ok()) {
    return Status::Error(last_run_.status.code,
                         "simulator " + simulator_->name() + ": " + last_run_.status.message);
  }
  const Status observed = observer_->observe(last_run_.trajectory, z);
  if (!observed.ok()) return Status::Error(observed.code, "observer: " + observed.message);
  return Status::Ok();
}

std::unique_ptr<ForwardModel> SimulatorForwardModel::clone() const {
  return std::make_unique<SimulatorForwardModel>(*simulator_, *observer_, estimated_, base_theta_);
}

}  // namespace sigmaheart::estimation
