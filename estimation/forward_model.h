// Adapter from the simulator contract to the estimators' ForwardModel: a subset of a simulator's
// parameters is estimated, the others stay at a base value; the run's trajectory goes through an
// observer. docs/architecture.md, "Data flow of one calibration".
#pragma once

#include "estimation/ensemble.h"
#include "model/simulator.h"
#include "observers/observer.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

// evaluate(theta_estimated): full = base_theta with full(estimated[k]) = theta_estimated(k);
// the full vector is checked against the ParameterSpace bounds (kOutOfBounds, no clipping), run
// by the simulator and observed. Any non-ok Status (size mismatch, bounds, simulator, observer)
// is returned unchanged apart from a prefix naming the stage. Not thread-safe: one clone per
// worker (Ensemble does that).
class SimulatorForwardModel final : public ForwardModel {
 public:
  // estimated: indices into simulator.parameters(), distinct and in range; base_theta: a full
  // parameter vector (size parameters().size()). Throws std::invalid_argument otherwise.
  SimulatorForwardModel(const model::Simulator& simulator, const observers::Observer& observer,
                        std::vector<int> estimated, Eigen::VectorXd base_theta);
  // The same by parameter names (did-you-mean on a typo), base = the simulator's nominal values.
  SimulatorForwardModel(const model::Simulator& simulator, const observers::Observer& observer,
                        const std::vector<std::string>& estimated_names);

  int input_size() const override { return static_cast<int>(estimated_.size()); }
  std::vector<std::string> input_names() const override;
  std::vector<model::Channel> outputs() const override { return observer_->outputs(); }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                         Eigen::Ref<Eigen::VectorXd> z) override;
  std::unique_ptr<ForwardModel> clone() const override;
  int warm_start_size() const override;
  model::Status evaluate_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                              Eigen::Ref<Eigen::VectorXd> z, const Eigen::VectorXd& from,
                              Eigen::VectorXd* produce) override;

  // The full parameter vector evaluate() would run for theta_estimated.
  Eigen::VectorXd full_theta(const Eigen::Ref<const Eigen::VectorXd>& theta_estimated) const;
  const std::vector<int>& estimated_indices() const { return estimated_; }
  const Eigen::VectorXd& base_theta() const { return base_theta_; }
  const model::Simulator& simulator() const { return *simulator_; }
  // The simulator's result of the last evaluate() on this object (for best-fit curves).
  const model::RunResult& last_run() const { return last_run_; }

 private:
  std::unique_ptr<model::Simulator> simulator_;
  std::unique_ptr<observers::Observer> observer_;
  std::vector<int> estimated_;
  Eigen::VectorXd base_theta_;
  model::RunResult last_run_;
};

}  // namespace sigmaheart::estimation
