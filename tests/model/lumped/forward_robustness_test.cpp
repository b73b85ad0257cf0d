// The whole-box robustness census (sobol_census.h), built twice (tests/model/lumped/CMakeLists.txt):
// lumped_forward_robustness_test (suite ForwardRobustness: 256 sphere, 64 regional points) and
// lumped_forward_robustness_slow_test (suite ForwardRobustnessSlow: 4096 points each).
#include "tests/model/lumped/sobol_census.h"

namespace sigmaheart::model::lumped {
namespace {

TEST(SIGMAHEART_CENSUS_SUITE, SphereGivesABeatAtEverySobolPointOfItsBox) {
  LumpedSphere sim;
  const int n = SIGMAHEART_CENSUS_SPHERE_POINTS;
  expect_no_failure(census(sim, n), "sphere, " + std::to_string(n) + " points");
}

TEST(SIGMAHEART_CENSUS_SUITE, RegionalGivesABeatAtEverySobolPointOfItsBox) {
  RegionalVentricle sim(five_patches());
  const int n = SIGMAHEART_CENSUS_REGIONAL_POINTS;
  expect_no_failure(census(sim, n), "regional (5 patches), " + std::to_string(n) + " points");
}

}  // namespace
}  // namespace sigmaheart::model::lumped
