// Shared set-up of the regional twin tests (fast: one pass; slow: the full experiment).
#pragma once

#include "estimation/roukf/regional_twin.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <set>

namespace sigmaheart::estimation::twin_testing {

struct TwinOutcome {
  RegionalTwin twin;
  RoukfSummary summary;
  Eigen::MatrixXd errors;  // beats x segments, relative
};

// The twin with `o` (its model: LBBB, 17 AHA patches), `beats` passes.
inline TwinOutcome run_twin(int beats, RegionalTwinOptions o = {}) {
  model::lumped::RegionalOptions mo;
  mo.activation = model::lumped::ActivationPattern::kLbbb;
  model::lumped::RegionalVentricle model(mo);
  o.model = mo;
  o.beats = beats;
  TwinOutcome out;
  out.twin = make_regional_twin(model, o);
  out.twin.filter.ensemble.threads = 2;
  out.summary = run_roukf(model, out.twin.prior, out.twin.data, out.twin.filter);
  out.errors = per_beat_relative_errors(out.summary, out.twin.truth_sigma0);
  return out;
}

inline void print(const TwinOutcome& t) {
  std::printf("%s\n", t.summary.full_report().c_str());
  for (int b = 0; b < t.errors.rows(); ++b) {
    std::printf("pass %d: max error %.1f %%, mean %.1f %%\n", b + 1,
                100 * t.errors.row(b).maxCoeff(), 100 * t.errors.row(b).mean());
  }
}

// The infarcted segments are exactly the ones estimated below 70 % of the uniform prior.
inline void expect_infarct_found(const TwinOutcome& t) {
  const std::set<int> infarct = {1, 2, 7, 8, 13, 14, 17};
  for (int s = 1; s <= 17; ++s) {
    const double ratio = t.summary.theta(s - 1) / t.twin.nominal_sigma0;
    if (infarct.count(s)) {
      EXPECT_LT(ratio, 0.7) << "segment " << s;
    } else {
      EXPECT_GT(ratio, 0.7) << "segment " << s;
    }
  }
}

}  // namespace sigmaheart::estimation::twin_testing
