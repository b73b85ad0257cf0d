// Slow tier (4096 points) of the whole-box robustness census (sobol_census.h).
#include "tests/model/lumped/sobol_census.h"

namespace sigmaheart::model::lumped {
namespace {

TEST(ForwardRobustnessSlow, SphereGivesABeatAtEvery4096SobolPointOfItsBox) {
  LumpedSphere sim;
  expect_no_failure(census(sim, 4096), "sphere, 4096 points");
}

TEST(ForwardRobustnessSlow, RegionalGivesABeatAtEvery4096SobolPointOfItsBox) {
  RegionalVentricle sim(five_patches());
  expect_no_failure(census(sim, 4096), "regional (5 patches), 4096 points");
}

}  // namespace
}  // namespace sigmaheart::model::lumped
