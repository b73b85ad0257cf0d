#include "model/activation/paced_simulator.h"
#include "model/lumped/regional.h"
#include "model/lumped/sphere.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::model::activation {
namespace {

TEST(PacedSimulator, WritesTheFusedTimesIntoTheSegmentActivationTimesWrappedIntoThePeriod) {
  lumped::RegionalOptions options;
  options.activation = lumped::ActivationPattern::kLbbb;
  const lumped::RegionalVentricle model(options);
  EXPECT_EQ(PacedSimulator::route(model), "segment activation times");
  PacingPlan plan;
  plan.stimuli = {{"LV", {5, Surface::kEpicardium, {}}, -0.040}};
  const PacedSimulator paced(model, plan);
  const Eigen::VectorXd theta = model.parameters().nominal();
  PacingOutcome o;
  const Eigen::VectorXd th = paced.paced_theta(theta, &o);
  const std::vector<int> td = model.parameters().regional("activation_time");
  const double period = theta(*model.parameters().find("period"));
  std::array<double, kSegments> intrinsic{};
  for (int k = 0; k < kSegments; ++k) intrinsic[static_cast<size_t>(k)] = theta(td[static_cast<size_t>(k)]);
  const PacingOutcome expected = segment_pacing(plan, intrinsic);
  for (int k = 0; k < kSegments; ++k) {
    const double t = expected.segment_times[static_cast<size_t>(k)];
    EXPECT_NEAR(th(td[static_cast<size_t>(k)]), t < 0 ? t + period : t, 1e-12) << "segment " << k + 1;
  }
  EXPECT_NEAR(th(td[4]), period - 0.040, 1e-12);
  EXPECT_NEAR(o.total_activation(), expected.total_activation(), 1e-12);
  // Only the activation times change.
  for (int i = 0; i < theta.size(); ++i) {
    if (model.parameters()[i].family != "activation_time") {
      EXPECT_EQ(th(i), theta(i)) << model.parameters()[i].name;
    }
  }
}

TEST(PacedSimulator, RefusesAModelWithoutActivationOrAPointOnTheGraph) {
  const lumped::LumpedSphere sphere;
  EXPECT_TRUE(PacedSimulator::route(sphere).empty());
  PacingPlan plan;
  plan.stimuli = {{"LV", {5, Surface::kEpicardium, {}}, 0.0}};
  EXPECT_THROW(PacedSimulator(sphere, plan), std::invalid_argument);
  const lumped::RegionalVentricle regional;
  plan.stimuli = {{"LV", {0, Surface::kEpicardium, Eigen::Vector3d(0.0, 0.02, 0.0)}, 0.0}};
  EXPECT_THROW(PacedSimulator(regional, plan), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model::activation
