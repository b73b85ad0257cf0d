// estimation/prior_conflict.cpp: prior_z and in_range against values computed by hand.
#include "estimation/prior_conflict.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::estimation {
namespace {

// alpha: log prior at 1.5 with std_eta 0.5, range [0.375, 6]; c_exp: log prior at 30 Pa with
// std_eta 1, range [7.5, 120] Pa; R_d: identity prior 1e8 +- 2e7 Pa s/m^3, no range.
Prior three_parameters() {
  Transform log;
  log.kind = TransformKind::kLog;
  Prior prior;
  prior.parameters.push_back(PriorParameter::gaussian("alpha", "1", 1.5, 0.5, SpreadKind::kEta, log));
  prior.parameters.push_back(PriorParameter::gaussian("c_exp", "Pa", 30.0, 1.0, SpreadKind::kEta, log));
  prior.parameters.push_back(
      PriorParameter::gaussian("R_d", "Pa s/m^3", 1e8, 2e7, SpreadKind::kAbsolute, Transform{}));
  prior.parameters[0].range_lower = 0.375;
  prior.parameters[0].range_upper = 6.0;
  prior.parameters[0].range_source = "[D4] default x/4";
  prior.parameters[1].range_lower = 7.5;
  prior.parameters[1].range_upper = 120.0;
  return prior;
}

TEST(PriorConflict, PriorZAndInRangeEqualHandComputedValues) {
  const Prior prior = three_parameters();
  // alpha 48.8 (the demo): eta = log(48.8 / 1.5) = 3.4823, z = 3.4823 / 0.5 = 6.9645,
  // outside [0.375, 6]. c_exp 60 Pa: z = log(2) / 1 = 0.693, inside. R_d 1.5e8: z = 5e7 / 2e7 = 2.5.
  Eigen::Vector3d theta(48.8, 60.0, 1.5e8);
  const PriorConflict c = prior_conflict(prior, prior.to_eta(theta));
  EXPECT_NEAR(c.prior_z(0), std::log(48.8 / 1.5) / 0.5, 1e-12);
  EXPECT_NEAR(c.prior_z(0), 6.9645, 1e-4);
  EXPECT_NEAR(c.prior_z(1), 0.693147, 1e-6);
  EXPECT_NEAR(c.prior_z(2), 2.5, 1e-12);
  EXPECT_NEAR(c.ratio(0), 48.8 / 1.5, 1e-12);
  EXPECT_EQ(c.in_range, (std::vector<int>{0, 1, -1}));
  EXPECT_EQ(c.absorbed_by, (std::vector<std::string>{"alpha"}));
  EXPECT_EQ(c.describe(),
            "prior conflict: model discrepancy absorbed by alpha (+6.96 prior std, 33x prior, "
            "outside 0.375-6 [D4])");
}

TEST(PriorConflict, BeyondThreePriorStdInsideTheRangeIsAConflictAndTheBoundaryIsInRange) {
  const Prior prior = three_parameters();
  // R_d at 1e8 - 3.2 * 2e7: z = -3.2 with no range; c_exp at exactly 120 Pa: inside, z = log 4.
  const Eigen::Vector3d theta(1.5, 120.0, 1e8 - 3.2 * 2e7);
  const PriorConflict c = prior_conflict(prior, prior.to_eta(theta));
  EXPECT_NEAR(c.prior_z(2), -3.2, 1e-12);
  EXPECT_NEAR(c.prior_z(1), std::log(4.0), 1e-12);
  EXPECT_EQ(c.in_range, (std::vector<int>{1, 1, -1}));
  EXPECT_EQ(c.absorbed_by, (std::vector<std::string>{"R_d"}));
  const Eigen::Vector3d at_prior(1.5, 30.0, 1e8);
  EXPECT_TRUE(prior_conflict(prior, prior.to_eta(at_prior)).describe().empty());
  EXPECT_THROW(prior_conflict(prior, Eigen::Vector2d(0, 0)), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::estimation
