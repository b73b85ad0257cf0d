// Coverage of the reported spread over noise replicates (issue 11): the 5-patch twin of
// regional_twin_test.cpp with the true noise, split passes, seeds 1..100. For each patch the
// +-2 std interval must contain the truth in 90-99 % of the replicates (a filter whose spread is
// right covers 95.4 %; with 100 replicates the binomial spread is 2.1 %), every replicate must end
// within 10 % of the truth, and the whole-data NIS must fall inside its 95 % band in 90-99 % of
// them, as must the truth inside the 95 % credible ellipsoid of all five (RoukfSummary::truth_d2
// <= chi2_0.95(5)).
#include "tests/estimation/roukf/regional_twin_helpers.h"

namespace sigmaheart::estimation::twin_testing {
namespace {

TEST(RoukfRegionalTwin, TwoStdIntervalsCoverTheTruthInNinetyToNinetyNinePercentOfReplicates) {
  const model::lumped::RegionalVentricle model = five_patch_model();
  constexpr int kReplicates = 100;
  Eigen::VectorXi covered = Eigen::VectorXi::Zero(5);
  int nis_inside = 0, joint_inside = 0;
  for (int seed = 1; seed <= kReplicates; ++seed) {
    RegionalTwinOptions o;
    o.infarct_segments = {1, 2};
    o.seed = static_cast<std::uint64_t>(seed);
    const TwinOutcome t = run_twin(model, o);
    ASSERT_TRUE(t.summary.ok()) << "seed " << seed << ": " << t.summary.message;
    const Eigen::VectorXd z = standardised_errors(t);
    for (int s = 0; s < 5; ++s) covered(s) += std::abs(z(s)) <= 2.0 ? 1 : 0;
    joint_inside += t.summary.truth_d2 <= t.summary.truth_d2_limit ? 1 : 0;
    nis_inside += (t.summary.nis_mean >= t.summary.nis_band_lower &&
                   t.summary.nis_mean <= t.summary.nis_band_upper) ? 1 : 0;
    EXPECT_LT(t.summary.error_percent.maxCoeff(), 10.0) << "seed " << seed;
  }
  std::printf("+-2 std coverage per patch [%%]: %d %d %d %d %d; truth inside the 95 %% credible "
              "ellipsoid: %d %%; NIS inside its band: %d %%\n",
              covered(0), covered(1), covered(2), covered(3), covered(4), joint_inside, nis_inside);
  for (int s = 0; s < 5; ++s) {
    EXPECT_GE(covered(s), 90) << "patch " << s + 1;
    EXPECT_LE(covered(s), 99) << "patch " << s + 1;
  }
  EXPECT_GE(nis_inside, 90);
  EXPECT_LE(nis_inside, 99);
  // Measured 94 (2026-11-26) with the MAP refinement (docs/estimation.md s.4.7); 90, at the band's
  // edge, without it: the split-pass estimate ends about one posterior std short of the MAP along
  // the best-informed direction (experiments/regional-personalization/README.md, "Why the MAP
  // refinement").
  EXPECT_GE(joint_inside, 90);
  EXPECT_LE(joint_inside, 99);
}

}  // namespace
}  // namespace sigmaheart::estimation::twin_testing
