// Coverage of the calibration's posterior (issue "estimation that holds on foreign data", numbers
// that must hold): 100 twin replicates of experiments/global-calibration, each with its truth
// drawn from the calibration's own prior (log-normal, 25 % in eta around the healthy defaults) and
// its noise drawn with the true observation covariance. For a posterior that is right, the +-2
// standard-deviation interval (the MAP point and its Laplace covariance, in eta) holds the truth
// in 95.4 % of the replicates; with 100 replicates the binomial spread is 2.1 points, so each
// parameter must lie in 90-99 %. Slow label: 100 calibrations, about 40 s.
// Measured when written (main after the MAP-consistent UT): sigma0 95, k_ATP 96, k_RS 89, c2 95,
// R_d 92 of 100, every calibration converged. k_RS fails by one replicate, and a more local
// linearisation (sample_scale 0.05 instead of 0.3: closer to the Laplace covariance) makes every
// parameter worse (86-92), so the Gaussian approximation at the MAP point understates the spread
// here. A suspect is the forward map itself: outputs that step when the number of beats to
// periodicity changes, and timing indices quantised by dt, bend the linearisation (issue 11,
// item 2). Left failing on purpose until that is fixed: no wider interval, no inflated noise.
#include "tests/experiments/global_twin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace sigmaheart {
namespace {

using global_twin::Twin;

TEST(CalibrationCoverage, TwoStdIntervalsHoldTheTruthInNinetyToNinetyNinePercentOfTwins) {
  constexpr int kReplicates = 100;
  const std::vector<std::string> names = {"sigma0", "k_ATP", "k_RS", "c2", "R_d"};
  std::vector<int> inside(names.size(), 0);
  int calibrated = 0;
  for (int r = 0; r < kReplicates; ++r) {
    std::mt19937_64 rng(4242 + static_cast<std::uint64_t>(r));
    std::normal_distribution<double> normal;
    std::vector<std::pair<std::string, double>> factors;
    Eigen::VectorXd eta_truth(static_cast<Eigen::Index>(names.size()));
    for (size_t j = 0; j < names.size(); ++j) {
      eta_truth(static_cast<Eigen::Index>(j)) = 0.25 * normal(rng);  // the prior: N(0, 0.25^2) in eta
      factors.emplace_back(names[j], std::exp(eta_truth(static_cast<Eigen::Index>(j))));
    }
    Twin twin(factors);
    for (Eigen::Index i = 0; i < twin.obs.y.size(); ++i) twin.obs.y(i) += std::sqrt(twin.obs.R(i, i)) * normal(rng);
    const auto s = twin.calibrate();
    EXPECT_TRUE(s.ok()) << "replicate " << r << ": " << s.message;
    if (!s.ok()) continue;
    ++calibrated;
    for (size_t j = 0; j < names.size(); ++j) {
      const auto k = static_cast<Eigen::Index>(j);
      inside[j] += std::abs(s.eta_mean(k) - s.eta_prior_mean(k) - eta_truth(k)) < 2.0 * s.eta_std(k);
    }
  }
  for (size_t j = 0; j < names.size(); ++j) {
    const double percent = 100.0 * inside[j] / kReplicates;
    std::printf("%-7s truth inside +-2 std in %d of %d replicates (%.0f %%)\n", names[j].c_str(), inside[j],
                kReplicates, percent);
    EXPECT_GE(percent, 90.0) << names[j];
    EXPECT_LE(percent, 99.0) << names[j];
  }
  EXPECT_EQ(calibrated, kReplicates);
}

}  // namespace
}  // namespace sigmaheart
