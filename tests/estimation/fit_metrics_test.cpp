// The fit and truth metrics every estimator summary carries (estimation/fit_metrics.h).
#include "estimation/fit_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace sigmaheart::estimation {
namespace {

TEST(FitMetrics, RelativeErrorsAndRmsNormalisedResidualByHand) {
  const Eigen::Vector3d y(100.0, -50.0, 2.0), z(110.0, -45.0, 2.0), sigma(5.0, 5.0, 0.1);
  const FitMetrics f = fit_metrics(y, z, sigma);
  EXPECT_NEAR(f.relative_error_percent(0), 10.0, 1e-12);
  EXPECT_NEAR(f.relative_error_percent(1), 10.0, 1e-12);
  EXPECT_EQ(f.relative_error_percent(2), 0.0);
  EXPECT_NEAR(f.mean_relative_error_percent, 20.0 / 3.0, 1e-12);
  // residuals in noise stds: -2, -1, 0 -> sqrt(5 / 3)
  EXPECT_NEAR(f.rms_normalised_residual, std::sqrt(5.0 / 3.0), 1e-14);
}

TEST(FitMetrics, AFailedRunGivesNaNAndSizesAreChecked) {
  const Eigen::Vector2d y(1.0, 2.0), sigma(0.1, 0.1);
  const FitMetrics f = fit_metrics(y, Eigen::Vector2d::Constant(std::nan("")), sigma);
  EXPECT_TRUE(std::isnan(f.rms_normalised_residual));
  EXPECT_TRUE(std::isnan(f.mean_relative_error_percent));
  const FitMetrics g = missing_fit_metrics(2);
  EXPECT_EQ(g.relative_error_percent.size(), 2);
  EXPECT_TRUE(std::isnan(g.rms_normalised_residual));
  EXPECT_THROW(fit_metrics(y, Eigen::Vector3d::Zero(), sigma), std::invalid_argument);
}

TEST(FitMetrics, ErrorsAgainstATruthArePercentOfTheTruth) {
  const Eigen::VectorXd e = relative_errors_percent(Eigen::Vector2d(1.1, 45.0), Eigen::Vector2d(1.0, 50.0));
  EXPECT_NEAR(e(0), 10.0, 1e-12);
  EXPECT_NEAR(e(1), 10.0, 1e-12);
  EXPECT_THROW(relative_errors_percent(Eigen::Vector2d::Zero(), Eigen::Vector3d::Ones()),
               std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::estimation
