// Coverage of the reported spread of the full 17-segment twin (regional_twin_full_test.cpp) over
// noise replicates, seeds 1..20: 340 segment intervals. Issue 11 asks that every segment of a twin
// lie inside its +-2 std; for 17 segments whose standardised errors are independent standard
// normals all 17 fall inside in only 45 % of replicates (0.954^17), so a single run cannot show
// that the spread is right. What a right spread must give is coverage: 95.4 % of the intervals
// contain the truth (binomial std 1.1 % over 340), checked here at 90-99 %, together with every
// replicate within 10 % of the truth and the whole-data NIS inside its 95 % band. The joint form of
// the ask, the truth inside the 95 % credible ellipsoid of all 17 (RoukfSummary::truth_d2), is
// counted the same way.
#include "tests/estimation/roukf/regional_twin_helpers.h"

namespace sigmaheart::estimation::twin_testing {
namespace {

TEST(RoukfRegionalTwin, SeventeenSegmentIntervalsCoverTheTruthInNinetyToNinetyNinePercent) {
  constexpr int kReplicates = 20;
  Eigen::VectorXi covered = Eigen::VectorXi::Zero(17);
  int all_inside = 0, nis_inside = 0, joint_inside = 0;
  double worst_error = 0;
  for (int seed = 1; seed <= kReplicates; ++seed) {
    RegionalTwinOptions o;
    o.seed = static_cast<std::uint64_t>(seed);
    const TwinOutcome t = run_twin(16, o);
    ASSERT_TRUE(t.summary.ok()) << "seed " << seed << ": " << t.summary.message;
    const Eigen::VectorXd z = standardised_errors(t);
    int inside = 0;
    for (int s = 0; s < 17; ++s) {
      const int in = std::abs(z(s)) <= 2.0 ? 1 : 0;
      covered(s) += in;
      inside += in;
    }
    all_inside += inside == 17 ? 1 : 0;
    joint_inside += t.summary.truth_d2 <= t.summary.truth_d2_limit ? 1 : 0;
    nis_inside += (t.summary.nis_mean >= t.summary.nis_band_lower &&
                   t.summary.nis_mean <= t.summary.nis_band_upper) ? 1 : 0;
    const double last = t.summary.error_percent.maxCoeff();
    worst_error = std::max(worst_error, last);
    EXPECT_LT(last, 10.0) << "seed " << seed;
    std::printf("seed %2d: %2d of 17 inside +-2 std, joint d2 %.2f (limit %.2f), worst error %.2f %%, "
                "max |z| %.2f\n", seed, inside, t.summary.truth_d2, t.summary.truth_d2_limit, last,
                z.cwiseAbs().maxCoeff());
  }
  const double coverage = 100.0 * covered.sum() / (17.0 * kReplicates);
  std::printf("+-2 std coverage: %.1f %% of %d intervals; per segment:", coverage, 17 * kReplicates);
  for (int s = 0; s < 17; ++s) std::printf(" %d", covered(s));
  std::printf(" (of %d)\nall 17 inside in %d of %d replicates; the truth inside the 95 %% credible "
              "ellipsoid (d2 <= chi2_0.95(17)) in %d; NIS inside its band in %d; worst error %.2f %%\n",
              kReplicates, all_inside, kReplicates, joint_inside, nis_inside, worst_error);
  EXPECT_GE(coverage, 90.0);
  EXPECT_LE(coverage, 99.0);
  EXPECT_GE(nis_inside, 17);  // 95 % band: 19 of 20 expected, at least 17 (binomial 3 std)
  // The joint form of "every segment inside its +-2 std": with a right posterior d2 is
  // chi-square(17), inside chi2_0.95(17) with probability 0.95; the same binomial bound.
  EXPECT_GE(joint_inside, 17);
}

}  // namespace
}  // namespace sigmaheart::estimation::twin_testing
