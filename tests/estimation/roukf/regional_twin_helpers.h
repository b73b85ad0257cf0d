// Shared set-up of the regional twin tests (fast: 5 patches and a narrow-prior check; slow: the
// full 17-segment experiment).
#pragma once

#include "estimation/roukf/regional_twin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>

namespace sigmaheart::estimation::twin_testing {

struct TwinOutcome {
  RegionalTwin twin;
  RoukfSummary summary;
  Eigen::MatrixXd errors;  // passes x segments, relative
};

// The twin with `o` on `model`; o.model is set to the model's options.
inline TwinOutcome run_twin(const model::lumped::RegionalVentricle& model, RegionalTwinOptions o) {
  o.model = model.options();
  TwinOutcome out;
  out.twin = make_regional_twin(model, o);
  out.twin.filter.ensemble.threads = 2;
  out.summary = run_roukf(model, out.twin.prior, out.twin.data, out.twin.filter);
  out.errors = per_beat_relative_errors(out.summary, out.twin.truth_sigma0);
  return out;
}

// The 17-segment LBBB ventricle of the experiment, at most `beats` passes.
inline TwinOutcome run_twin(int beats, RegionalTwinOptions o = {}) {
  model::lumped::RegionalOptions mo;
  mo.activation = model::lumped::ActivationPattern::kLbbb;
  o.beats = beats;
  return run_twin(model::lumped::RegionalVentricle(mo), o);
}

// Five equal patches activated 0, 30, ..., 120 ms (a septal-to-lateral sequence spanning about
// the LBBB pattern's 140 ms); the twins on it put the infarct in patches 1 and 2.
inline model::lumped::RegionalVentricle five_patch_model() {
  model::lumped::RegionalOptions mo;
  mo.area_shares = std::vector<double>(5, 0.2);
  mo.activation = model::lumped::ActivationPattern::kExplicit;
  mo.activation_times = {0.0, 0.03, 0.06, 0.09, 0.12};
  return model::lumped::RegionalVentricle(mo);
}

// (eta - eta_true) / std of every segment at the end (RoukfSummary::truth_z).
inline const Eigen::VectorXd& standardised_errors(const TwinOutcome& t) { return t.summary.truth_z; }

inline void print(const TwinOutcome& t) {
  std::printf("%s\n", t.summary.full_report().c_str());
  for (int b = 0; b < t.errors.rows(); ++b) {
    if (!t.errors.row(b).allFinite()) continue;
    std::printf("pass %d: max error %.1f %%, mean %.1f %%\n", b + 1,
                100 * t.errors.row(b).maxCoeff(), 100 * t.errors.row(b).mean());
  }
  if (t.summary.error_percent.size() > 0) {
    std::printf("final estimate: max error %.1f %%, mean %.1f %%\n", t.summary.error_percent.maxCoeff(),
                t.summary.error_percent.mean());
  }
  const Eigen::VectorXd z = standardised_errors(t);
  for (Eigen::Index s = 0; s < z.size(); ++s) {
    std::printf("segment %2d: (eta - truth) / std = %+.2f\n", static_cast<int>(s) + 1, z(s));
  }
  std::printf("joint: (eta - truth)^T P^-1 (eta - truth) = %.2f (chi2_0.95(%d) = %.2f)\n",
              t.summary.truth_d2, static_cast<int>(z.size()), t.summary.truth_d2_limit);
}

// The final errors (after the MAP refinement, RoukfSummary::error_percent): every segment within
// 10 % of its truth, and the consistency statistic (the whole-data NIS of the split passes) inside
// its chi-square 95 % band.
inline void expect_within_ten_percent_and_consistent(const TwinOutcome& t) {
  ASSERT_EQ(t.summary.error_percent.size(), t.twin.truth_sigma0.size());
  for (Eigen::Index s = 0; s < t.summary.error_percent.size(); ++s) {
    EXPECT_LT(t.summary.error_percent(s), 10.0) << "segment " << s + 1;
  }
  EXPECT_GE(t.summary.nis_mean, t.summary.nis_band_lower);
  EXPECT_LE(t.summary.nis_mean, t.summary.nis_band_upper);
}

// The infarcted segments are exactly the ones estimated below 70 % of the uniform prior.
inline void expect_infarct_found(const TwinOutcome& t, const std::set<int>& infarct) {
  for (int s = 1; s <= static_cast<int>(t.twin.truth_sigma0.size()); ++s) {
    const double ratio = t.summary.theta(s - 1) / t.twin.nominal_sigma0;
    if (infarct.count(s)) {
      EXPECT_LT(ratio, 0.7) << "segment " << s;
    } else {
      EXPECT_GT(ratio, 0.7) << "segment " << s;
    }
  }
}

}  // namespace sigmaheart::estimation::twin_testing
