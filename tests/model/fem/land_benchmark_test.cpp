// Coarse Land et al. 2015 problems (fast tier). The coarsest meshes carry a discretisation error
// that was measured against our finer meshes (experiments/land-benchmark/README.md); each
// tolerance below is that measured error, not a guess. The finer meshes, checked against the
// published spread with no tolerance, are in land_benchmark_slow_test.cpp.
#include "model/fem/land_benchmark.h"

#include <gtest/gtest.h>

namespace sigmaheart::model::fem {
namespace {

// Land problem `problem` on the coarsest mesh (refinement 1).
LandResult run_coarse(int problem) {
  LandOptions o;
  o.problem = problem;
  o.refinement = 1;
  return run_land_problem(o);
}

// Distance from x to the interval r (0 inside) [mm].
double distance_to(double x, const LandRange& r) { return x < r.low ? r.low - x : x > r.high ? x - r.high : 0.0; }

TEST(LandBenchmark, Problem1CoarseBeamDeflectsUpwardWithinItsDiscretisationErrorOfThePublishedSpread) {
  const LandResult r = run_coarse(1);
  ASSERT_TRUE(r.summary.converged) << r.summary.brief_report();
  // 8 x 1 x 1 cubes of quadratic tetrahedra: 4.0557 mm. Its discretisation error, measured, is
  // 0.103 mm to K = 4 (4.1590 mm) and 0.107 mm to the Richardson limit (4.163 mm); it lies
  // 0.095 mm below the published spread 4.151..4.180 mm (fig. 3).
  EXPECT_GT(r.primary, 0.0);
  EXPECT_LT(r.primary, LandReference::kProblem1Deflection.low);  // the coarse beam is too stiff
  EXPECT_LE(distance_to(r.primary, LandReference::kProblem1Deflection), 0.107);
}

TEST(LandBenchmark, Problem2CoarseInflationPutsBothApicesInsideThePublishedSpread) {
  const LandResult r = run_coarse(2);
  ASSERT_TRUE(r.summary.converged) << r.summary.brief_report();
  // K = 1 (one quadratic element across the wall): -26.781 / -27.939 mm, inside the spread of
  // the ten codes (fig. 6) with no tolerance.
  EXPECT_TRUE(LandReference::kProblem2EndoApex.contains(r.primary)) << r.primary;
  EXPECT_TRUE(LandReference::kProblem2EpiApex.contains(r.secondary)) << r.secondary;
  // Without LifeV the epicardial apex is 0.17 mm short of the spread; its measured discretisation
  // error at K = 1 is 0.333 mm (K = 3: -28.272 mm), the endocardial one 0.131 mm (K = 3: -26.650).
  EXPECT_LE(distance_to(r.primary, LandReference::kProblem2EndoApexWithoutLifeV), 0.131);
  EXPECT_LE(distance_to(r.secondary, LandReference::kProblem2EpiApexWithoutLifeV), 0.333);
  EXPECT_LT(r.secondary, r.primary);  // the wall keeps a positive thickness at the apex
}

TEST(LandBenchmark, OptionsAreValidated) {
  LandOptions o;
  o.problem = 4;
  EXPECT_FALSE(o.validate().empty());
  EXPECT_THROW(run_land_problem(o), std::invalid_argument);
}

TEST(LandBenchmark, PublishedRangesAreOrderedAndNested) {
  using R = LandReference;
  for (const LandRange& r : {R::kProblem1Deflection, R::kProblem2EndoApex, R::kProblem2EpiApex,
                             R::kProblem2EndoApexWithoutLifeV, R::kProblem2EpiApexWithoutLifeV, R::kProblem3EndoApex,
                             R::kProblem3EpiApex})
    EXPECT_LT(r.low, r.high);
  EXPECT_GE(R::kProblem2EndoApexWithoutLifeV.low, R::kProblem2EndoApex.low);
  EXPECT_LE(R::kProblem2EndoApexWithoutLifeV.high, R::kProblem2EndoApex.high);
  EXPECT_GE(R::kProblem2EpiApexWithoutLifeV.low, R::kProblem2EpiApex.low);
  EXPECT_LE(R::kProblem2EpiApexWithoutLifeV.high, R::kProblem2EpiApex.high);
  EXPECT_TRUE(R::kProblem1Deflection.contains(4.17));
  EXPECT_FALSE(R::kProblem1Deflection.contains(4.15));
}

}  // namespace
}  // namespace sigmaheart::model::fem
