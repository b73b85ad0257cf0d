// The targets of issue 11 on the foreign-data bench (experiments/foreign-data/README.md,
// "Calibrating the foreign cases"): every one of the 16 foreign cases, calibrated by the UT with the
// shipped config experiments/foreign-data/calibrate-foreign.yaml, must reach a volume mean relative
// error under 5 %, a pressure RMS under 8 % of the observed peak, a MAP objective not above the
// prior's, a status "converged", and an objective within 1.2 times that of the multi-start Ceres
// reference (32 Sobol' points, 4 local runs, half-width 2 prior std) on the same prior and data.
// The same numbers as experiments/foreign-data/run prints; label slow (1-4 min per case on 2 loaded
// cores, mostly the reference). The shipped config calibrates the sphere with an atrial chamber
// (lumped-sphere-atrium, 14 parameters); with the prescribed atrial pressure
// (calibrate-foreign-12.yaml) elastance-healthy failed (model form; README.md, "Outcome").
#include "app/calibration_setup.h"
#include "app/config.h"
#include "estimation/forward_model.h"
#include "estimation/least_squares.h"
#include "estimation/ut_calibration.h"
#include "tests/support/case_name.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace sigmaheart {
namespace {

const std::string kDir = std::string(SIGMAHEART_SOURCE_DIR) + "/";

struct ForeignCase {
  std::string name;
  double period = 0;             // [s]
  double noise_V = 2, noise_P = 2;  // [mL], [mmHg]: the case's own (harder acquisitions: 1-4)
};

std::vector<ForeignCase> foreign_cases() {
  std::vector<ForeignCase> out;
  for (const auto& c : YAML::LoadFile(kDir + "configs/data/foreign/cases.yaml")["cases"]) {
    // All 16 cases: the eight of issue 11 (elastance and one-fibre phenotypes, 30 frames), the
    // Mooney-Rivlin family and the harder acquisitions of issue 45. Not every case meets the
    // targets yet (experiments/foreign-data/README.md, "Outcome (issue 45, speed)" and "The slow
    // bench with its reference": the misses and why); this test fails on those until they do.
    out.push_back({c["name"].as<std::string>(), c["period"].as<double>(), c["noise"]["V_lv"].as<double>(),
                   c["noise"]["P_lv"].as<double>()});
  }
  return out;
}

// Mean of |y - z| / |y| over the V_lv frames [%] and the RMS of y - z over the P_lv frames
// relative to the largest observed P_lv [%] (the issue's two error measures).
struct CurveErrors {
  double volume_percent = NAN, pressure_percent = NAN;
};
CurveErrors curve_errors(const observers::ObservationSet& obs, const Eigen::VectorXd& z) {
  double v_sum = 0, p_sq = 0, p_peak = 0;
  int nv = 0, np = 0;
  for (int i = 0; i < obs.size(); ++i) {
    const std::string& n = obs.names[static_cast<size_t>(i)];
    if (n.rfind("V_lv@", 0) == 0) {
      v_sum += std::abs(obs.y(i) - z(i)) / std::abs(obs.y(i));
      ++nv;
    } else if (n.rfind("P_lv@", 0) == 0) {
      p_sq += (obs.y(i) - z(i)) * (obs.y(i) - z(i));
      p_peak = std::max(p_peak, obs.y(i));
      ++np;
    }
  }
  return {nv ? 100 * v_sum / nv : NAN, np && p_peak > 0 ? 100 * std::sqrt(p_sq / np) / p_peak : NAN};
}

class ForeignCalibration : public ::testing::TestWithParam<ForeignCase> {};

TEST_P(ForeignCalibration, ShippedConfigMeetsTheIssueTargets) {
  const ForeignCase& c = GetParam();
  const app::Config config = app::load_config(
      kDir + "experiments/foreign-data/calibrate-foreign.yaml",
      {"observations.file=" + kDir + "configs/data/foreign/" + c.name + ".csv",
       "period=" + std::to_string(c.period), "observations.noise.V_lv=" + std::to_string(c.noise_V) + " mL",
       "observations.noise.P_lv=" + std::to_string(c.noise_P) + " mmHg"});
  const app::CalibrationProblem problem = app::parse_calibration_problem(config);
  const auto simulator = config.simulator.make();
  estimation::SimulatorForwardModel forward(*simulator, *problem.observer, problem.prior.names());
  estimation::EnsembleOptions two_threads;
  two_threads.threads = 2;

  estimation::UtOptions ut = problem.options;
  ut.ensemble = two_threads;
  const estimation::UtSummary s =
      estimation::UtCalibration(forward, problem.prior, problem.observations, ut).run();
  estimation::LeastSquaresOptions ls = problem.least_squares;
  ls.ensemble = two_threads;
  ls.screen_points = 32;
  ls.starts = 4;
  ls.screen_width = 2.0;
  const estimation::LeastSquaresSummary ref =
      estimation::solve_map(forward, problem.prior, problem.observations, ls);

  ASSERT_TRUE(s.fit_after && s.fit_after->status.ok()) << c.name << ": " << s.message;
  const CurveErrors e = curve_errors(problem.observations, s.fit_after->z);
  std::printf("%s: V err %.2f %%, P RMS %.2f %% of peak, Phi %.1f (prior %.1f), reference %.1f, "
              "%s, %d + %d runs\n",
              c.name.c_str(), e.volume_percent, e.pressure_percent, s.objective, s.objective_prior,
              ref.cost, estimation::to_string(s.termination), s.simulations, ref.simulations);
  EXPECT_EQ(s.termination, estimation::UtTermination::kConverged) << c.name << ": " << s.message;
  EXPECT_LT(e.volume_percent, 5.0) << c.name;
  EXPECT_LT(e.pressure_percent, 8.0) << c.name;
  EXPECT_LE(s.objective, s.objective_prior) << c.name << ": the fit is worse than the prior";
  EXPECT_LE(s.objective, 1.2 * ref.cost) << c.name << ": the UT missed the multi-start MAP point";
}

INSTANTIATE_TEST_SUITE_P(ForeignBench, ForeignCalibration, ::testing::ValuesIn(foreign_cases()),
                         [](const ::testing::TestParamInfo<ForeignCase>& param) {
                           return testing::case_test_name(param.param.name);
                         });

}  // namespace
}  // namespace sigmaheart
