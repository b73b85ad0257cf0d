// The twin experiment of experiments/regional-personalization, in full: 17 contractilities of an
// LBBB ventricle with an LAD-like infarct (40 % of nominal in segments 1, 2, 7, 8, 13, 14, 17)
// from noisy regional volumes, 4 passes over the measured beat.
#include "tests/estimation/roukf/regional_twin_helpers.h"

namespace sigmaheart::estimation::twin_testing {
namespace {

TEST(RoukfRegionalTwin, RecoversEveryContractilityWithinTenPercentInFourPasses) {
  const TwinOutcome t = run_twin(4);
  print(t);  // before the checks, so a failing run still shows its report
  ASSERT_TRUE(t.summary.ok()) << t.summary.message;
  expect_infarct_found(t);
  const int last = static_cast<int>(t.errors.rows()) - 1;
  for (int s = 0; s < 17; ++s) EXPECT_LT(t.errors(last, s), 0.10) << "segment " << s + 1;
  // Errors fall from the first pass to the last.
  EXPECT_LT(t.errors.row(last).maxCoeff(), 0.5 * t.errors.row(0).maxCoeff());
  // The truth lies inside the reported +-2 sigma interval for most segments.
  int covered = 0;
  for (int s = 0; s < 17; ++s) {
    const double truth = t.twin.truth_sigma0(s);
    covered += (t.summary.theta_lower(s) <= truth && truth <= t.summary.theta_upper(s)) ? 1 : 0;
  }
  EXPECT_GE(covered, 15);
}

}  // namespace
}  // namespace sigmaheart::estimation::twin_testing
