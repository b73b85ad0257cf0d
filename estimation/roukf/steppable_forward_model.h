// Adapter that lets an Ensemble hold one SteppableSimulator per worker.
//
// The Ensemble clones a ForwardModel prototype once per worker; estimators that advance model
// states themselves (the ROUKF) reach the worker's simulator through
//   static_cast<SteppableForwardModel&>(ensemble.worker_model(worker)).simulator().
// This keeps Ensemble unchanged and the simulator interface small: the filter's own state (its
// covariance factors, the member states) stays in estimation/.
#pragma once

#include "estimation/ensemble.h"
#include "model/simulator.h"

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

class SteppableForwardModel final : public ForwardModel {
 public:
  // As a plain ForwardModel: full theta (the simulator's parameters) -> the listed channels of
  // sample() after advancing initial_state(theta) to t_end.
  SteppableForwardModel(std::unique_ptr<model::SteppableSimulator> simulator,
                        std::vector<int> channels, double t_end);

  model::SteppableSimulator& simulator() { return *simulator_; }
  const model::SteppableSimulator& simulator() const { return *simulator_; }

  int input_size() const override;
  std::vector<std::string> input_names() const override;
  std::vector<model::Channel> outputs() const override;
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                         Eigen::Ref<Eigen::VectorXd> z) override;
  std::unique_ptr<ForwardModel> clone() const override;

  // A SteppableSimulator copy of s (clone() returns a Simulator); throws std::logic_error if
  // the clone is not steppable.
  static std::unique_ptr<model::SteppableSimulator> clone_steppable(
      const model::SteppableSimulator& s);

 private:
  std::unique_ptr<model::SteppableSimulator> simulator_;
  std::vector<int> channels_;
  double t_end_ = 0.0;
};

}  // namespace sigmaheart::estimation
