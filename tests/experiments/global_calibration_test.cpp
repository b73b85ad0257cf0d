// Twin experiments of experiments/global-calibration, shrunk to test size: a hidden truth of the
// lumped BCS sphere, its global indices as observations, and the UT calibration recovering the
// truth from the healthy defaults (Marchesseau et al. 2013, Biomech Model Mechanobiol 12:815,
// calibrated up to five parameters this way).
#include "tests/experiments/global_twin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace sigmaheart {
namespace {

using global_twin::Twin;

TEST(GlobalCalibrationTwin, RecoversFiveParametersWithinFivePercentFromNoiseFreeIndices) {
  Twin twin;
  const auto s = twin.calibrate();
  ASSERT_TRUE(s.ok()) << s.message;
  for (Eigen::Index j = 0; j < twin.truth.size(); ++j) {
    const double rel = std::abs(s.theta_of_eta_mean(j) - twin.truth(j)) / twin.truth(j);
    EXPECT_LT(rel, 0.05) << twin.names[static_cast<size_t>(j)] << ": estimate "
                         << s.theta_of_eta_mean(j) << ", truth " << twin.truth(j);
  }
  EXPECT_EQ(s.failures, 0);
}

// One noise draw says little about a posterior; eight seeded draws check its calibration: with
// a well-calibrated posterior about 95 % of the (parameter, draw) errors lie within two posterior
// standard deviations. We ask for at least 90 % (36 of 40); measured with mode map (the MAP point
// and its Laplace covariance): 37 of 40 (38 of 40 with the earlier iterate-keep-spread). The
// misses lie along the curved sigma0-k_ATP valley, where the linearised posterior understates the
// spread.
TEST(GlobalCalibrationTwin, NoisyIndicesGiveEstimatesWithinTwoPosteriorStd) {
  const Twin clean;
  int inside = 0, total = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    Twin twin;
    std::mt19937_64 rng(20131015 + seed);
    std::normal_distribution<double> normal;
    for (Eigen::Index i = 0; i < twin.obs.y.size(); ++i) {
      twin.obs.y(i) = clean.obs.y(i) + std::sqrt(twin.obs.R(i, i)) * normal(rng);
    }
    const auto s = twin.calibrate();
    ASSERT_TRUE(s.ok()) << "seed " << seed << ": " << s.message;
    for (Eigen::Index j = 0; j < twin.truth.size(); ++j) {
      const double z = std::abs(s.theta_of_eta_mean(j) - twin.truth(j)) / s.theta_std(j);
      inside += z < 2.0;
      ++total;
      EXPECT_LT(s.theta_std(j), 0.25 * twin.truth(j)) << "the data must tighten the 25 % prior";
    }
  }
  EXPECT_GE(inside, (90 * total + 99) / 100) << inside << " of " << total << " within 2 std";
  std::printf("%d of %d errors within 2 posterior std\n", inside, total);
}

}  // namespace
}  // namespace sigmaheart
