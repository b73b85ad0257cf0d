#include "estimation/fit_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace sigmaheart::estimation {

FitMetrics fit_metrics(const Eigen::Ref<const Eigen::VectorXd>& y,
                       const Eigen::Ref<const Eigen::VectorXd>& z,
                       const Eigen::Ref<const Eigen::VectorXd>& sigma) {
  if (z.size() != y.size() || sigma.size() != y.size()) {
    throw std::invalid_argument("fit_metrics: y, z and sigma differ in size");
  }
  FitMetrics f;
  const Eigen::Index m = y.size();
  f.relative_error_percent.resize(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    f.relative_error_percent(i) = 100.0 * std::abs(z(i) - y(i)) / std::max(std::abs(y(i)), 1e-300);
  }
  f.mean_relative_error_percent = f.relative_error_percent.mean();
  f.rms_normalised_residual =
      std::sqrt((y - z).cwiseQuotient(sigma).squaredNorm() / static_cast<double>(m));
  return f;
}

FitMetrics missing_fit_metrics(int m) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  FitMetrics f;
  f.relative_error_percent = Eigen::VectorXd::Constant(m, kNaN);
  f.mean_relative_error_percent = kNaN;
  f.rms_normalised_residual = kNaN;
  return f;
}

Eigen::VectorXd relative_errors_percent(const Eigen::Ref<const Eigen::VectorXd>& estimate,
                                        const Eigen::Ref<const Eigen::VectorXd>& truth) {
  if (estimate.size() != truth.size()) {
    throw std::invalid_argument("relative_errors_percent: estimate and truth differ in size");
  }
  return (100.0 * (estimate - truth).array().abs() / truth.array().abs()).matrix();
}

}  // namespace sigmaheart::estimation
