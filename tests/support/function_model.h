// A forward model from a function, for the estimation tests and their small closed-form maps:
// the inputs and outputs by name, evaluate() calls the function, clone() copies it (with whatever
// it captured).
#pragma once

#include "estimation/forward_model.h"
#include "observers/observer.h"

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::testing {

// prefix followed by i ("t0", "o3").
// GCC 12 warns (-Wrestrict, a false positive) on "literal" + std::string at -O3.
inline std::string indexed(const char* prefix, int i) {
  std::string s(prefix);
  s += std::to_string(i);
  return s;
}

using Map = std::function<model::Status(const Eigen::VectorXd& theta, Eigen::Ref<Eigen::VectorXd> z)>;

class FunctionModel final : public estimation::ForwardModel {
 public:
  FunctionModel(std::vector<std::string> inputs, std::vector<model::Channel> outputs, Map f)
      : inputs_(std::move(inputs)), outputs_(std::move(outputs)), f_(std::move(f)) {}
  // p inputs t0, t1, ... and m outputs o0, o1, ... (unit "1").
  FunctionModel(int p, int m, Map f) : f_(std::move(f)) {
    for (int j = 0; j < p; ++j) inputs_.push_back(indexed("t", j));
    for (int i = 0; i < m; ++i) outputs_.push_back({indexed("o", i), "1", ""});
  }

  int input_size() const override { return static_cast<int>(inputs_.size()); }
  std::vector<std::string> input_names() const override { return inputs_; }
  std::vector<model::Channel> outputs() const override { return outputs_; }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                         Eigen::Ref<Eigen::VectorXd> z) override {
    return f_(theta, z);
  }
  std::unique_ptr<estimation::ForwardModel> clone() const override {
    return std::make_unique<FunctionModel>(*this);
  }

 private:
  std::vector<std::string> inputs_;
  std::vector<model::Channel> outputs_;
  Map f_;
};

// Data for a model's outputs: names and units from outputs(), values y and noise covariance R.
inline observers::ObservationSet observations_for(const estimation::ForwardModel& model,
                                                  Eigen::VectorXd y, Eigen::MatrixXd R) {
  observers::ObservationSet obs;
  for (const auto& c : model.outputs()) {
    obs.names.push_back(c.name);
    obs.units.push_back(c.unit);
  }
  obs.y = std::move(y);
  obs.R = std::move(R);
  return obs;
}

}  // namespace sigmaheart::testing
