// The named outputs of a model that returns values rather than curves (docs/architecture.md s.2,
// "Models whose outputs are not curves"): such a model's Trajectory has one sample (t = 0) and one
// channel per value, an output vector `y` of n > 1 values being the channels y[0] .. y[n-1]. This
// observer picks outputs by name — a whole vector (`y`: all its elements in order) or one element
// (`y[1]`, or a scalar output by its own name) — so calibration observations and sensitivity
// outputs can be any output of any black-box model; the estimators see an ordinary Observer.
#pragma once

#include "observers/observer.h"

#include <string>
#include <vector>

namespace sigmaheart::observers {

class OutputValues final : public Observer {
 public:
  // `names`: outputs or elements (at least one); `channels`: the simulator's channels. Throws
  // std::invalid_argument for an unknown name (with a did-you-mean) or a name given twice.
  OutputValues(const std::vector<std::string>& names, const std::vector<model::Channel>& channels);

  std::vector<model::Channel> outputs() const override;
  // kBadOutput unless the trajectory has exactly one sample (a model with curves is observed with
  // curves or indices) or when a channel is missing.
  model::Status observe(const model::Trajectory& trajectory, Eigen::Ref<Eigen::VectorXd> z) const override;
  std::unique_ptr<Observer> clone() const override { return std::make_unique<OutputValues>(*this); }

 private:
  std::vector<model::Channel> outputs_;
};

// The channel names a name stands for: itself when a channel has that name, else name[0],
// name[1], ... in order; empty when neither.
std::vector<std::string> expand_output_name(const std::string& name, const std::vector<model::Channel>& channels);

}  // namespace sigmaheart::observers
