// Twin experiments of experiments/global-calibration, shrunk to test size: a hidden truth of the
// lumped BCS sphere, its global indices as observations, and the UT calibration recovering the
// truth from the healthy defaults (Marchesseau et al. 2013, Biomech Model Mechanobiol 12:815,
// calibrated up to five parameters this way).
#include "estimation/forward_model.h"
#include "estimation/ut_calibration.h"
#include "model/lumped/sphere.h"
#include "model/units.h"
#include "observers/global_indices.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace sigmaheart {
namespace {

using model::units::kMilliLitre;
using model::units::kMmHg;

// Truth: every estimated parameter 8-15 % away from the healthy default the prior starts from.
const std::vector<std::pair<std::string, double>> kTruthFactors = {
    {"sigma0", 1.15}, {"k_ATP", 0.9}, {"k_RS", 1.12}, {"c2", 0.88}, {"R_d", 1.1}};

// Measurement-like noise of each index (std, SI): cine-MRI volumes to 2 mL, timings to a frame
// (~10 ms at 30 frames per beat), catheter pressures to 2 mmHg.
double noise_std(const std::string& name) {
  if (name == "EDV" || name == "ESV") return 2.0 * kMilliLitre;
  if (name == "dVdt_min" || name == "dVdt_max") return 20.0 * kMilliLitre;
  if (name == "t_ES" || name == "ejection_duration") return 0.010;
  if (name == "P_max" || name == "P_ar_sys" || name == "P_ar_dia") return 2.0 * kMmHg;
  if (name == "dPdt_max" || name == "dPdt_min") return 50.0 * kMmHg;
  if (name == "EDP") return 0.5 * kMmHg;
  return 0.0;
}

struct Twin {
  model::lumped::LumpedSphere sphere;
  std::unique_ptr<observers::GlobalIndices> observer;
  std::vector<std::string> names;
  Eigen::VectorXd truth;
  observers::ObservationSet obs;

  Twin() {
    observers::GlobalIndicesOptions gi;
    gi.indices = {"EDV", "ESV", "dVdt_min", "dVdt_max", "t_ES", "ejection_duration", "P_max",
                  "dPdt_max", "dPdt_min", "EDP", "P_ar_sys", "P_ar_dia"};
    observer = std::make_unique<observers::GlobalIndices>(gi, sphere.channels());
    const auto& space = sphere.parameters();
    truth.resize(static_cast<Eigen::Index>(kTruthFactors.size()));
    for (size_t j = 0; j < kTruthFactors.size(); ++j) {
      names.push_back(kTruthFactors[j].first);
      truth(static_cast<Eigen::Index>(j)) =
          space[space.index_or_throw(kTruthFactors[j].first)].nominal * kTruthFactors[j].second;
    }
    estimation::SimulatorForwardModel fm(sphere, *observer, names);
    Eigen::VectorXd z(observer->size());
    const auto status = fm.evaluate(truth, z);
    EXPECT_TRUE(status.ok()) << status.message;
    for (const auto& c : observer->outputs()) {
      obs.names.push_back(c.name);
      obs.units.push_back(c.unit);
    }
    obs.y = z;
    obs.R = Eigen::MatrixXd::Zero(z.size(), z.size());
    for (Eigen::Index i = 0; i < z.size(); ++i) {
      const double s = noise_std(obs.names[static_cast<size_t>(i)]);
      obs.R(i, i) = s * s;
    }
  }

  estimation::UtSummary calibrate() const {
    estimation::SimulatorForwardModel fm(sphere, *observer, names);
    estimation::Prior params;
    const auto& space = sphere.parameters();
    for (const auto& n : names) {
      const model::Parameter& q = space[space.index_or_throw(n)];
      // 25 % (log transform: exactly 0.25 in eta)
      params.parameters.push_back(estimation::PriorParameter::gaussian(
          n, q.unit, q.nominal, 0.25, estimation::SpreadKind::kRelative,
          {estimation::TransformKind::kLog, q.nominal}, 0.0));
    }
    estimation::UtOptions o;
    o.sigma.rule = estimation::SigmaRule::kSimplex;
    o.mode = estimation::UtMode::kMap;  // the MAP point with its Laplace covariance
    o.max_iterations = 30;
    o.tolerance = 1e-2;  // 1 % of the prior std
    o.sample_scale = 0.3;  // a more local statistical linearisation, see UtOptions
    o.ensemble.threads = 2;
    estimation::UtCalibration cal(fm, params, obs, o);
    EXPECT_EQ(cal.validate(), "");
    return cal.run();
  }
};

TEST(GlobalCalibrationTwin, RecoversFiveParametersWithinFivePercentFromNoiseFreeIndices) {
  Twin twin;
  const auto s = twin.calibrate();
  ASSERT_TRUE(s.ok()) << s.message;
  for (Eigen::Index j = 0; j < twin.truth.size(); ++j) {
    const double rel = std::abs(s.theta_of_eta_mean(j) - twin.truth(j)) / twin.truth(j);
    EXPECT_LT(rel, 0.05) << twin.names[static_cast<size_t>(j)] << ": estimate "
                         << s.theta_of_eta_mean(j) << ", truth " << twin.truth(j);
  }
  EXPECT_EQ(s.failures, 0);
}

// One noise draw says little about a posterior; eight seeded draws check its calibration: with
// a well-calibrated posterior about 95 % of the (parameter, draw) errors lie within two posterior
// standard deviations. We ask for at least 90 % (36 of 40); measured with mode map (the MAP point
// and its Laplace covariance): 37 of 40 (38 of 40 with the earlier iterate-keep-spread). The
// misses lie along the curved sigma0-k_ATP valley, where the linearised posterior understates the
// spread.
TEST(GlobalCalibrationTwin, NoisyIndicesGiveEstimatesWithinTwoPosteriorStd) {
  const Twin clean;
  int inside = 0, total = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    Twin twin;
    std::mt19937_64 rng(20131015 + seed);
    std::normal_distribution<double> normal;
    for (Eigen::Index i = 0; i < twin.obs.y.size(); ++i) {
      twin.obs.y(i) = clean.obs.y(i) + std::sqrt(twin.obs.R(i, i)) * normal(rng);
    }
    const auto s = twin.calibrate();
    ASSERT_TRUE(s.ok()) << "seed " << seed << ": " << s.message;
    for (Eigen::Index j = 0; j < twin.truth.size(); ++j) {
      const double z = std::abs(s.theta_of_eta_mean(j) - twin.truth(j)) / s.theta_std(j);
      inside += z < 2.0;
      ++total;
      EXPECT_LT(s.theta_std(j), 0.25 * twin.truth(j)) << "the data must tighten the 25 % prior";
    }
  }
  EXPECT_GE(inside, (90 * total + 99) / 100) << inside << " of " << total << " within 2 std";
  std::printf("%d of %d errors within 2 posterior std\n", inside, total);
}

}  // namespace
}  // namespace sigmaheart
