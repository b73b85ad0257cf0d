// Concatenation of observers: z = (z_1, z_2, ...), e.g. global indices and curves at frames in one
// observation vector (docs/estimation.md s.5: "an ObservationSet can mix them").
#pragma once

#include "observers/observer.h"

#include <memory>
#include <vector>

namespace sigmaheart::observers {

class CompositeObserver : public Observer {
 public:
  // Output names must be unique across the parts (an always-on invariant check: throws
  // std::invalid_argument naming the duplicate and the two parts). No part may be null.
  explicit CompositeObserver(std::vector<std::unique_ptr<Observer>> parts);

  std::vector<model::Channel> outputs() const override { return outputs_; }
  // Each part fills its own segment of z; the first failing part's Status is returned, its message
  // prefixed with the part's position.
  model::Status observe(const model::Trajectory& trajectory,
                        Eigen::Ref<Eigen::VectorXd> z) const override;
  std::unique_ptr<Observer> clone() const override;

  int parts() const { return static_cast<int>(parts_.size()); }
  const Observer& part(int i) const { return *parts_.at(static_cast<size_t>(i)); }

 private:
  std::vector<std::unique_ptr<Observer>> parts_;
  std::vector<int> offsets_;  // start of each part in z
  std::vector<model::Channel> outputs_;
};

}  // namespace sigmaheart::observers
