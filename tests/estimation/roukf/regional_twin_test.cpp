// Shortened twin experiment of experiments/regional-personalization (one pass over the measured
// beat): the ROUKF already separates the LAD-infarcted segments of a 17-patch LBBB ventricle from
// the healthy ones (estimation/roukf/regional_twin.h). The full experiment is
// regional_twin_full_test.cpp (slow).
#include "tests/estimation/roukf/regional_twin_helpers.h"

namespace sigmaheart::estimation::twin_testing {
namespace {

TEST(RoukfRegionalTwin, FirstPassAlreadySeparatesTheInfarctedSegments) {
  const TwinOutcome t = run_twin(1);
  ASSERT_TRUE(t.summary.ok()) << t.summary.message;
  print(t);
  EXPECT_EQ(t.summary.members, 18);
  EXPECT_EQ(t.summary.steps.size(), 30u);
  expect_infarct_found(t);
  // The spread shrank from the prior 0.5 in every segment.
  for (int s = 0; s < 17; ++s) EXPECT_LT(std::sqrt(t.summary.eta_covariance(s, s)), 0.4);
}

}  // namespace
}  // namespace sigmaheart::estimation::twin_testing
