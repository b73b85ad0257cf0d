#include "estimation/sensitivity/test_functions.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace sigmaheart::estimation::sensitivity {

namespace {
// "x<i+1>"; built by appending (GCC 12 -O3 warns falsely on "x" + std::string).
std::string input_name(int i) {
  std::string name(1, 'x');
  name += std::to_string(i + 1);
  return name;
}
}  // namespace

std::vector<model::Channel> IshigamiModel::outputs() const {
  return {{"y", "1", "Ishigami function"}};
}

model::Status IshigamiModel::evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                      Eigen::Ref<Eigen::VectorXd> z) {
  if (theta.size() != 3 || z.size() != 1) {
    return model::Status::Error(model::StatusCode::kInvalidArgument,
                                "Ishigami: expects 3 inputs and 1 output");
  }
  const double s1 = std::sin(theta(0));
  const double s2 = std::sin(theta(1));
  const double x3 = theta(2);
  z(0) = s1 + a_ * s2 * s2 + b_ * x3 * x3 * x3 * x3 * s1;
  return model::Status::Ok();
}

std::unique_ptr<ForwardModel> IshigamiModel::clone() const {
  return std::make_unique<IshigamiModel>(*this);
}

ExactIndices ishigami_exact(double a, double b) {
  const double pi4 = std::pow(std::numbers::pi, 4);
  const double pi8 = pi4 * pi4;
  const double V1 = 0.5 * (1.0 + b * pi4 / 5.0) * (1.0 + b * pi4 / 5.0);
  const double V2 = a * a / 8.0;
  const double V13 = 8.0 * b * b * pi8 / 225.0;
  ExactIndices e;
  e.mean = a / 2.0;
  e.variance = a * a / 8.0 + b * pi4 / 5.0 + b * b * pi8 / 18.0 + 0.5;
  e.S1 = Eigen::Vector3d(V1, V2, 0.0) / e.variance;
  e.ST = Eigen::Vector3d(V1 + V13, V2, V13) / e.variance;
  // The only interaction is x1 x3 (b x3^4 sin x1); S12 = S23 = 0.
  e.S2 = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  e.S2(0, 1) = e.S2(1, 2) = 0.0;
  e.S2(0, 2) = V13 / e.variance;
  return e;
}

Prior ishigami_prior() {
  Prior prior;
  for (const char* n : {"x1", "x2", "x3"}) {
    prior.parameters.push_back(
        PriorParameter::uniform(n, "1", -std::numbers::pi, std::numbers::pi, 0.0));
  }
  return prior;
}

GFunctionModel::GFunctionModel(Eigen::VectorXd a) : a_(std::move(a)) {
  if (a_.size() == 0 || (a_.array() < 0).any()) {
    throw std::invalid_argument("G-function: needs at least one coefficient, all a_i >= 0");
  }
}

std::vector<std::string> GFunctionModel::input_names() const {
  std::vector<std::string> n;
  for (Eigen::Index i = 0; i < a_.size(); ++i) n.push_back(input_name(static_cast<int>(i)));
  return n;
}

std::vector<model::Channel> GFunctionModel::outputs() const {
  return {{"y", "1", "Sobol' G-function"}};
}

model::Status GFunctionModel::evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                       Eigen::Ref<Eigen::VectorXd> z) {
  if (theta.size() != a_.size() || z.size() != 1) {
    return model::Status::Error(model::StatusCode::kInvalidArgument,
                                "G-function: wrong input or output size");
  }
  double g = 1.0;
  for (Eigen::Index i = 0; i < a_.size(); ++i) {
    g *= (std::abs(4.0 * theta(i) - 2.0) + a_(i)) / (1.0 + a_(i));
  }
  z(0) = g;
  return model::Status::Ok();
}

std::unique_ptr<ForwardModel> GFunctionModel::clone() const {
  return std::make_unique<GFunctionModel>(*this);
}

ExactIndices g_function_exact(const Eigen::VectorXd& a) {
  const Eigen::ArrayXd Vi = 1.0 / (3.0 * (1.0 + a.array()).square());
  const double prod = (1.0 + Vi).prod();
  ExactIndices e;
  e.mean = 1.0;
  e.variance = prod - 1.0;
  e.S1 = Vi.matrix() / e.variance;
  e.ST = (Vi * prod / (1.0 + Vi)).matrix() / e.variance;
  // The variance of the product's (i, j) term is V_i V_j (Sobol' 2001, s.4).
  const auto p = static_cast<Eigen::Index>(a.size());
  e.S2 = Eigen::MatrixXd::Constant(p, p, std::numeric_limits<double>::quiet_NaN());
  for (Eigen::Index i = 0; i < p; ++i) {
    for (Eigen::Index j = i + 1; j < p; ++j) e.S2(i, j) = Vi(i) * Vi(j) / e.variance;
  }
  return e;
}

Prior g_function_prior(int p) {
  Prior prior;
  for (int i = 0; i < p; ++i) {
    prior.parameters.push_back(PriorParameter::uniform(input_name(i), "1", 0.0, 1.0, 0.5));
  }
  return prior;
}

Eigen::VectorXd g_function_default_a() {
  Eigen::VectorXd a(8);
  a << 0, 1, 4.5, 9, 99, 99, 99, 99;
  return a;
}

}  // namespace sigmaheart::estimation::sensitivity
