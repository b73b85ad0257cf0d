// The 3D electromechanical LV against the simulator contract (tests/model/simulator_contract.h) on
// the coarse mesh, and beats repeated to periodicity. Slow tier: each contract case runs up to four
// beats (about 20 s of CPU each).
#include "model/fem/electromechanics.h"

#include "tests/model/simulator_contract.h"

#include <gtest/gtest.h>

namespace sigmaheart::model::fem {
namespace {

LeftVentricle3DOptions coarse_one_beat() {
  LeftVentricle3DOptions o;
  o.dt = 0.01;
  o.max_beats = 1;
  o.periodic_tolerance = 1.0;
  return o;
}

// Beats repeat until the beat-start state changes by less than 1e-3 (relative) from one beat to
// the next; the count and the EF of the periodic beat are reported.
TEST(LeftVentricle3DSlow, BeatsRepeatToPeriodicity) {
  LeftVentricle3DOptions o = coarse_one_beat();
  o.max_beats = 12;
  o.periodic_tolerance = 1e-3;
  LeftVentricle3D lv(o);
  const RunResult r = lv.run(lv.parameters().nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_LE(r.info.periodicity_change, 1e-3);
  EXPECT_GE(r.info.beats, 2);
  const Eigen::VectorXd V = r.trajectory.channel("V_lv");
  EXPECT_LT(std::abs(V(V.size() - 1) - V(0)), 1e-3 * V(0));
  std::printf("periodic after %d beats (change %.2e): EDV %.1f mL, ESV %.1f mL\n", r.info.beats,
              r.info.periodicity_change, V.maxCoeff() * 1e6, V.minCoeff() * 1e6);
}

}  // namespace
}  // namespace sigmaheart::model::fem

namespace sigmaheart::testing {
namespace {

INSTANTIATE_TEST_SUITE_P(Lv3d, SimulatorContract,
                         ::testing::Values(ContractCase{"lv_3d_coarse",
                                                        [] {
                                                          return std::make_unique<model::fem::LeftVentricle3D>(
                                                              model::fem::coarse_one_beat());
                                                        },
                                                        0.1, 0.3, 0.05}),
                         contract_case_name);

}  // namespace
}  // namespace sigmaheart::testing
