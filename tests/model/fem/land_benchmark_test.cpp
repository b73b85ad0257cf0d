// Coarse Land et al. 2015 problems (fast tier, tolerances fitting the coarse meshes); the finer
// meshes and the published-consensus tolerances are in land_benchmark_slow_test.cpp.
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

TEST(LandBenchmark, Problem1CoarseBeamDeflectsUpward) {
  const LandResult r = run_coarse(1);
  ASSERT_TRUE(r.summary.converged) << r.summary.brief_report();
  // 8 x 1 x 1 quadratic tetrahedra: 4.056 mm; the published value is about 4.17 mm.
  EXPECT_NEAR(r.primary, LandReference::kProblem1Deflection, 0.15);
}

TEST(LandBenchmark, Problem2CoarseInflationMovesTheApexDown) {
  const LandResult r = run_coarse(2);
  ASSERT_TRUE(r.summary.converged) << r.summary.brief_report();
  // K = 1 (one quadratic element across the wall): -26.78 / -27.94 mm.
  EXPECT_NEAR(r.primary, LandReference::kProblem2EndoApex, 0.5);
  EXPECT_NEAR(r.secondary, LandReference::kProblem2EpiApex, 0.5);
  EXPECT_LT(r.secondary, r.primary);  // the wall keeps a positive thickness at the apex
}

TEST(LandBenchmark, OptionsAreValidated) {
  LandOptions o;
  o.problem = 4;
  EXPECT_FALSE(o.validate().empty());
  EXPECT_THROW(run_land_problem(o), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model::fem
