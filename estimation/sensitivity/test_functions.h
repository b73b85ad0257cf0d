// Analytic test models with exact variance-based sensitivity indices, as ForwardModels, so that a
// study set-up (design size, estimator, bootstrap) can be checked against exact numbers with the
// same code path that runs the heart model (docs/estimation.md s.6, "Exact checks").
#pragma once

#include "estimation/ensemble.h"
#include "estimation/sensitivity/design.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::estimation::sensitivity {

// Exact mean, variance, first-order S1 and total-order ST of a scalar test function.
struct ExactIndices {
  double mean = 0.0;
  double variance = 0.0;
  Eigen::VectorXd S1;
  Eigen::VectorXd ST;
  Eigen::MatrixXd S2;  // p x p, S2(i, j) for i < j; NaN on and below the diagonal
};

// Ishigami & Homma (1990): y = sin x1 + a sin^2 x2 + b x3^4 sin x1, x_i ~ U[-pi, pi].
// One output "y" [1]; inputs "x1", "x2", "x3".
class IshigamiModel final : public ForwardModel {
 public:
  explicit IshigamiModel(double a = 7.0, double b = 0.1) : a_(a), b_(b) {}
  int input_size() const override { return 3; }
  std::vector<std::string> input_names() const override { return {"x1", "x2", "x3"}; }
  std::vector<model::Channel> outputs() const override;
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                         Eigen::Ref<Eigen::VectorXd> z) override;
  std::unique_ptr<ForwardModel> clone() const override;

 private:
  double a_, b_;
};

// Exact indices of the Ishigami function (Ishigami & Homma 1990; Sobol' & Levitan 1999):
// V = a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2, V1 = (1 + b pi^4/5)^2 / 2, V2 = a^2/8,
// V13 = 8 b^2 pi^8 / 225, V3 = 0; ST1 = (V1 + V13)/V, ST2 = V2/V, ST3 = V13/V; S13 = V13/V
// (0.2437 for a = 7, b = 0.1), S12 = S23 = 0.
ExactIndices ishigami_exact(double a = 7.0, double b = 0.1);
// The study prior of the Ishigami inputs: uniform on [-pi, pi], nominal 0.
Prior ishigami_prior();

// Sobol' G-function (Sobol' 1993; Saltelli & Sobol' 1995): y = prod_i (|4 x_i - 2| + a_i)/(1 + a_i),
// x_i ~ U[0, 1]. One output "y" [1]; inputs "x1".."xp". a_i >= 0: small a_i = important input.
class GFunctionModel final : public ForwardModel {
 public:
  explicit GFunctionModel(Eigen::VectorXd a);
  int input_size() const override { return static_cast<int>(a_.size()); }
  std::vector<std::string> input_names() const override;
  std::vector<model::Channel> outputs() const override;
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                         Eigen::Ref<Eigen::VectorXd> z) override;
  std::unique_ptr<ForwardModel> clone() const override;

 private:
  Eigen::VectorXd a_;
};

// Exact indices of the G-function (Sobol' 2001, Math Comput Simul 55:271): V_i = 1/(3 (1 + a_i)^2),
// V = prod (1 + V_i) - 1, S1_i = V_i / V, ST_i = V_i prod_{j != i} (1 + V_j) / V, S2_ij = V_i V_j / V;
// mean 1.
ExactIndices g_function_exact(const Eigen::VectorXd& a);
// The study prior of the G-function inputs: uniform on [0, 1], nominal 0.5.
Prior g_function_prior(int p);
// The classic a = (0, 1, 4.5, 9, 99, 99, 99, 99) of Saltelli et al. 2010.
Eigen::VectorXd g_function_default_a();

}  // namespace sigmaheart::estimation::sensitivity
