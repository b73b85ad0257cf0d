// Small sample (256 sphere, 64 regional points) of the whole-box robustness census (sobol_census.h); the 4096-point version is
// forward_robustness_slow_test.cpp.
#include "tests/model/lumped/sobol_census.h"

namespace sigmaheart::model::lumped {
namespace {

TEST(ForwardRobustness, SphereGivesABeatAtEvery256SobolPointOfItsBox) {
  LumpedSphere sim;
  expect_no_failure(census(sim, 256), "sphere, 256 points");
}

TEST(ForwardRobustness, RegionalGivesABeatAtEvery64SobolPointsOfItsBox) {
  RegionalVentricle sim(five_patches());
  expect_no_failure(census(sim, 64), "regional (5 patches), 64 points");
}

}  // namespace
}  // namespace sigmaheart::model::lumped
