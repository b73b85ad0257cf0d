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

// Far into a run t = k T carries rounding errors larger than the grid's margins; the grid used to
// return t itself there (dt = 50 ms, beat 19279: the periodic loop never advanced and overflowed
// its row buffer). Every step must advance by about dt, and no step may be a rounding error long.
TEST(Shell, TimeGridAdvancesByAboutDtFarIntoARun) {
  const double T = 0.85;
  for (const double dt : {0.05, 1e-3, 1e-5}) {
    for (const int beat : {19279, 9999, 123457}) {
      const double t_end = (beat + 1) * T;
      double t = beat * T;
      for (int k = 0; k < 50 && t < t_end; ++k) {
        const double next = next_time(t, t_end, dt, T);
        ASSERT_GT(next - t, 0.5 * dt) << "dt " << dt << ", beat " << beat << ", t = " << t;
        ASSERT_LE(next - t, dt * (1 + 1e-6)) << "dt " << dt << ", beat " << beat;
        t = next;
      }
    }
  }
  // A whole beat at 50 ms from beat 19279 takes the 17 steps of every beat.
  double t = 19279 * T;
  int steps = 0;
  while (t < 19280 * T && steps < 100) {
    t = next_time(t, 19280 * T, 0.05, T);
    ++steps;
  }
  EXPECT_EQ(steps, 17);
}

// The periodic loop on its own, past validate()'s limits (a stepper that only moves the clock):
// 20000 beats at dt = 50 ms used to stall at beat 19279 and write past its row buffer.
TEST(Shell, PeriodicLoopAdvancesAndStaysInItsBuffersPastTheLimitsOfTheOptions) {
  const Shell m = healthy();
  SphereOptions o;
  o.dt = 0.05;
  o.min_beats = 20000;
  o.max_beats = 20000;
  State initial;
  initial.x = Eigen::VectorXd::Zero(6);
  fill_relaxed_state(m, initial.x);
  long long calls = 0;
  const auto step_to = [&](State& s, double t1, int*, int*) {
    ++calls;
    s.time = t1;
    return Status::Ok();
  };
  const auto sample = [](const State& s) { return Eigen::VectorXd::Constant(1, s.time); };
  const RunResult r = run_periodic(m, o, {{"t", "s", "clock"}}, initial, step_to, sample);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_EQ(r.info.beats, 20000);
  EXPECT_EQ(calls, 20000LL * 17);  // 0.85 s / 50 ms = 17 steps in every beat
  EXPECT_EQ(r.trajectory.samples(), 18);
  EXPECT_DOUBLE_EQ(r.trajectory.times(17), m.period);
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
