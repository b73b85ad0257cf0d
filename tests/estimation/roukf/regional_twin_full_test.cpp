// The twin experiment of experiments/regional-personalization, in full: 17 contractilities of an
// LBBB ventricle with an LAD-like infarct (40 % of nominal in segments 1, 2, 7, 8, 13, 14, 17)
// from regional volumes with noise 0.05 mL, the filter with that true noise, no forgetting, the
// frames split over passes (RoukfPassMode::kSplit, so the data count once).
#include "tests/estimation/roukf/regional_twin_helpers.h"

namespace sigmaheart::estimation::twin_testing {
namespace {

TEST(RoukfRegionalTwin, WithTheTrueNoiseEveryContractilityIsRecoveredWithinTenPercent) {
  const TwinOutcome t = run_twin(16);
  print(t);  // before the checks, so a failing run still shows its report
  ASSERT_TRUE(t.summary.ok()) << t.summary.message;
  expect_within_ten_percent_and_consistent(t);
  expect_infarct_found(t, {1, 2, 7, 8, 13, 14, 17});
  // The truth inside the reported +-2 std: for 17 independent standard normals the chance that 3
  // or more fall outside is 4 % (and that all fall inside only 45 %), so at least 15 of 17.
  const Eigen::VectorXd z = standardised_errors(t);
  int within_two = 0;
  for (int s = 0; s < 17; ++s) within_two += std::abs(z(s)) <= 2.0 ? 1 : 0;
  EXPECT_GE(within_two, 15);
}

}  // namespace
}  // namespace sigmaheart::estimation::twin_testing
