// The pieces the sphere and the regional ventricle share (model/lumped/shell.h): the beat-local
// time grid, the passive law's derivative, the static initial equilibrium, the parameter names.
#include "model/lumped/shell.h"

#include <gtest/gtest.h>

namespace sigmaheart::model::lumped::shell {
namespace {

Shell healthy() {
  const ParameterSpace space = LumpedSphere::default_parameters();
  return unpack(space.nominal(), global_indices(space));
}

TEST(Shell, TimeGridStepsByDtAndLandsExactlyOnEveryBeatEnd) {
  const double T = 0.85, dt = 2e-3;
  double t = 0.0;
  int steps = 0, beat_ends = 0;
  while (t < 3 * T) {
    const double next = next_time(t, 3 * T, dt, T);
    EXPECT_GT(next, t);
    EXPECT_LE(next - t, dt * (1 + 1e-9));
    for (int b = 1; b <= 3; ++b) beat_ends += next == b * T ? 1 : 0;
    t = next;
    ++steps;
  }
  EXPECT_EQ(beat_ends, 3);
  EXPECT_EQ(steps, 3 * 425);  // 0.85 / 0.002 = 425 steps per beat
  // From inside a beat, a t_end before the next grid point is hit exactly.
  EXPECT_DOUBLE_EQ(next_time(0.1005, 0.101, 1e-3, T), 0.101);
}

TEST(Shell, PassiveStressDerivativeMatchesCentralDifferences) {
  const Shell m = healthy();
  for (double C : {0.8, 1.0, 1.3, 1.7, 2.2}) {
    double S = 0, dS = 0, Sp = 0, Sm = 0, unused = 0;
    passive_stress(m, C, S, dS);
    const double h = 1e-6 * C;
    passive_stress(m, C + h, Sp, unused);
    passive_stress(m, C - h, Sm, unused);
    EXPECT_NEAR(dS, (Sp - Sm) / (2 * h), 1e-6 * std::abs(dS) + 1e-9) << "C = " << C;
  }
  double S = 1, dS = 0;
  passive_stress(m, 1.0, S, dS);
  EXPECT_EQ(S, 0.0);  // stress-free reference
}

TEST(Shell, RelaxedStateIsInStaticPassiveBalanceWithTheAtrialPressure) {
  const Shell m = healthy();
  const double P = m.atrial(0.0);
  const double y = static_radius_offset(m, P);
  const double s = 1 + y / m.R0;
  double S = 0, dS = 0;
  passive_stress(m, s * s, S, dS);
  EXPECT_NEAR(m.d0 / m.R0 * s * S, P * s * s, 1e-9 * P);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(5);
  const double e = fill_relaxed_state(m, x);
  EXPECT_DOUBLE_EQ(x(kY), y);
  EXPECT_DOUBLE_EQ(e, 0.5 * (s * s - 1));
  EXPECT_GT(cavity_volume(m, y), 100e-6);  // a relaxed healthy LV holds > 100 mL at ~7 mmHg
}

TEST(Shell, BothModelsNameTheSameGlobalParameters) {
  const ParameterSpace sphere = LumpedSphere::default_parameters();
  for (const auto& n : global_names()) EXPECT_TRUE(sphere.index(n).has_value()) << n;
  EXPECT_EQ(global_names().size() + 1, static_cast<size_t>(sphere.size()));  // + sigma0
}

}  // namespace
}  // namespace sigmaheart::model::lumped::shell
