// The twin of experiments/global-calibration shared by its tests: a hidden truth of the lumped
// BCS sphere, its twelve global indices with measurement-like noise as observations, and the UT
// calibration (mode map) of five parameters from 25 % priors at the healthy defaults.
#pragma once

#include "estimation/forward_model.h"
#include "estimation/ut_calibration.h"
#include "model/lumped/sphere.h"
#include "model/units.h"
#include "observers/global_indices.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::global_twin {

using model::units::kMilliLitre;
using model::units::kMmHg;

// Truth: every estimated parameter 8-15 % away from the healthy default the prior starts from.
inline const std::vector<std::pair<std::string, double>> kTruthFactors = {
    {"sigma0", 1.15}, {"k_ATP", 0.9}, {"k_RS", 1.12}, {"c2", 0.88}, {"R_d", 1.1}};

// Measurement-like noise of each index (std, SI): cine-MRI volumes to 2 mL, timings to a frame
// (~10 ms at 30 frames per beat), catheter pressures to 2 mmHg.
inline double noise_std(const std::string& name) {
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

  // truth_factors: truth = factor x healthy default, per estimated parameter (default kTruthFactors).
  explicit Twin(const std::vector<std::pair<std::string, double>>& truth_factors = kTruthFactors) {
    observers::GlobalIndicesOptions gi;
    gi.indices = {"EDV", "ESV", "dVdt_min", "dVdt_max", "t_ES", "ejection_duration", "P_max",
                  "dPdt_max", "dPdt_min", "EDP", "P_ar_sys", "P_ar_dia"};
    observer = std::make_unique<observers::GlobalIndices>(gi, sphere.channels());
    const auto& space = sphere.parameters();
    truth.resize(static_cast<Eigen::Index>(truth_factors.size()));
    for (size_t j = 0; j < truth_factors.size(); ++j) {
      names.push_back(truth_factors[j].first);
      truth(static_cast<Eigen::Index>(j)) =
          space[space.index_or_throw(truth_factors[j].first)].nominal * truth_factors[j].second;
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

}  // namespace sigmaheart::global_twin
