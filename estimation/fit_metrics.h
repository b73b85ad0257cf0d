// Numbers that say how well an estimate fits the data and, in twin experiments, how close it is to
// a known truth. Computed once here so commands, tests and experiments report the same values.
#pragma once

#include <Eigen/Core>

namespace sigmaheart::estimation {

// Fit of model outputs z to observations y with noise standard deviations sigma (same order, SI).
struct FitMetrics {
  Eigen::VectorXd relative_error_percent;  // 100 |y_i - z_i| / |y_i| (NaN where z_i is NaN)
  double mean_relative_error_percent = 0.0;
  // sqrt(mean_i ((y_i - z_i) / sigma_i)^2): 1 means a fit at the noise level.
  double rms_normalised_residual = 0.0;
};

// Throws std::invalid_argument when the sizes differ. A failed run (z all NaN) gives NaN metrics.
FitMetrics fit_metrics(const Eigen::Ref<const Eigen::VectorXd>& y,
                       const Eigen::Ref<const Eigen::VectorXd>& z,
                       const Eigen::Ref<const Eigen::VectorXd>& sigma);
// The metrics of a run that produced nothing: every entry NaN (m observations).
FitMetrics missing_fit_metrics(int m);

// 100 |estimate_j - truth_j| / |truth_j| per parameter (throws std::invalid_argument on sizes).
Eigen::VectorXd relative_errors_percent(const Eigen::Ref<const Eigen::VectorXd>& estimate,
                                        const Eigen::Ref<const Eigen::VectorXd>& truth);

}  // namespace sigmaheart::estimation
