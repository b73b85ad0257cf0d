// How far an estimate went from its prior and from physiology (docs/estimation.md s.11.4), for any
// estimator that returns a point in eta (UT calibration, least squares, the ROUKF's final state).
//
// Per parameter j:  prior_z_j = (eta_j - eta0_j) / sigma0_j, the distance from the prior mean in
// prior standard deviations in the transformed space where the prior is Gaussian; in_range_j:
// range_lower_j <= theta_j <= range_upper_j (PriorParameter's physiological range, -1 when none).
// A parameter with |prior_z| > z_limit (3: a two-sided tail of 0.27 % under the prior) or outside
// its range is one the data pushed beyond what the model's physiology allows: with a fit at the
// noise level this is the model's discrepancy being absorbed by that parameter (Brynjarsdottir &
// O'Hagan 2014, Inverse Problems 30:114007, s.2: without a discrepancy term a calibration moves
// parameters to compensate for model error), and the report says so in words.
#pragma once

#include "estimation/prior.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sigmaheart::estimation {

struct PriorConflict {
  std::vector<std::string> names;
  Eigen::VectorXd prior_z;             // [prior std], transformed space
  Eigen::VectorXd ratio;               // theta / theta_prior (NaN when theta_prior is 0)
  std::vector<int> in_range;           // 1 inside, 0 outside, -1 no range stated
  std::vector<std::string> absorbed_by;  // |prior_z| > z_limit or outside the range
  double z_limit = 3.0;
  // "prior conflict: model discrepancy absorbed by alpha (+4.7 prior std, 32x prior, outside
  // 0.375-6), ..."; empty when no parameter conflicts.
  std::string describe() const;
  // "+4.7 prior std, 32x prior, outside 0.375-6 [D4]" for parameter j.
  std::string detail(int j) const;

  std::vector<double> range_lower, range_upper;  // per parameter (NaN: none)
  std::vector<std::string> range_source;
};

// eta: the estimate in the prior's coordinates (size prior.size()). Throws std::invalid_argument
// on a size mismatch or z_limit <= 0.
PriorConflict prior_conflict(const Prior& prior, const Eigen::Ref<const Eigen::VectorXd>& eta,
                             double z_limit = 3.0);

}  // namespace sigmaheart::estimation
