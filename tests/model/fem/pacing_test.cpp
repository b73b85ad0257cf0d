#include "model/fem/electromechanics.h"
#include "model/fem/pacing.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace sigmaheart::model::fem {
namespace {

namespace act = model::activation;

LeftVentricle3D coarse(ActivationSource source) {
  LeftVentricle3DOptions o;
  o.activation = source;
  return LeftVentricle3D(o);
}

act::PacingPlan lead_at(int segment, double t, bool intrinsic = true) {
  act::PacingPlan plan;
  plan.intrinsic = intrinsic;
  plan.stimuli = {{"LV", {segment, act::Surface::kEpicardium, std::nullopt}, t}};
  return plan;
}

TEST(Lv3dPacing, TheIntrinsicPlanGivesBackTheConfiguredPattern) {
  LeftVentricle3D lv = coarse(ActivationSource::kLbbb);
  const std::vector<double> before = lv.activation_times();
  const act::PacingOutcome o = lv.pace({});
  const std::vector<double>& after = lv.activation_times();
  ASSERT_EQ(after.size(), before.size());
  for (size_t i = 0; i < after.size(); ++i) ASSERT_NEAR(after[i], before[i], 1e-12) << i;
  EXPECT_NEAR(o.earliest, 0.0, 1e-12);
  EXPECT_GT(o.total_activation(), 0.12);  // the LBBB of docs/models.md s.4.6 (130-180 ms on the bench meshes)
}

TEST(Lv3dPacing, ALeadFusesWithTheIntrinsicWaveFromItsSegmentCentre) {
  LeftVentricle3D lv = coarse(ActivationSource::kLbbb);
  const act::PacingOutcome intrinsic = lv.pace({});
  const act::PacingOutcome paced = lv.pace(lead_at(5, -0.040));
  EXPECT_EQ(paced.captured, std::vector<bool>{true});
  EXPECT_NEAR(paced.earliest, -0.040, 1e-9);  // the lead sits on a vertex
  // The basal inferolateral wall, last in LBBB, is now activated first; the septum stays intrinsic.
  EXPECT_LT(paced.segment_times[4], 0.0);
  EXPECT_GT(intrinsic.segment_times[4], 0.09);
  // Fusion only brings activation forward; the septum, activated from the right, hardly moves.
  for (int s = 0; s < 17; ++s) EXPECT_LE(paced.segment_times[s], intrinsic.segment_times[s] + 1e-12) << s + 1;
  for (int s : {1, 2, 7, 8}) EXPECT_LT(intrinsic.segment_times[s] - paced.segment_times[s], 0.005) << s + 1;
  // The latest activation comes earlier (the total, from the stimulus 40 ms before the intrinsic
  // onset, need not be shorter: one LV lead).
  EXPECT_LT(paced.latest, intrinsic.latest - 0.02);
  // Each call starts from the intrinsic activation again.
  const act::PacingOutcome again = lv.pace({});
  EXPECT_NEAR(again.segment_times[4], intrinsic.segment_times[4], 1e-12);
}

TEST(Lv3dPacing, ScarBlocksTheWaveAndALeadInScarDoesNotCapture) {
  LeftVentricle3D lv = coarse(ActivationSource::kSynchronous);
  const act::PacingOutcome open = lv.pace(lead_at(5, 0.0, false));
  act::PacingPlan blocked = lead_at(5, 0.0, false);
  blocked.scar = {11};  // mid inferolateral, straight below the lead
  const act::PacingOutcome round = lv.pace(blocked);
  // Apical lateral (16) lies beyond the scar: the wave goes round it.
  EXPECT_GT(round.segment_times[15], open.segment_times[15] + 0.005);
  // The scar itself takes the earliest time on its border: no later than its neighbours there.
  EXPECT_LE(round.segment_times[10], round.segment_times[15]);
  act::PacingPlan in_scar = lead_at(11, -0.05, true);
  in_scar.scar = {11};
  const act::PacingOutcome none = lv.pace(in_scar);
  EXPECT_EQ(none.captured, std::vector<bool>{false});
  EXPECT_NE(none.note.find("no capture"), std::string::npos);
  EXPECT_NEAR(none.earliest, 0.0, 1e-12);  // only the intrinsic (synchronous) activation
}

TEST(Lv3dPacing, APointOutsideTheMeshIsRefusedAndLeavesTheModelUnchanged) {
  LeftVentricle3D lv = coarse(ActivationSource::kHealthy);
  const std::vector<double> before = lv.activation_times();
  act::PacingPlan plan;
  plan.stimuli = {{"LV", {0, act::Surface::kEpicardium, Eigen::Vector3d(0.0, 0.0, 0.2)}, 0.0}};
  EXPECT_THROW(lv.pace(plan), std::invalid_argument);
  EXPECT_EQ(lv.activation_times(), before);
  // A point inside the wall is placed in its segment.
  Eigen::Vector3d inside = Eigen::Vector3d::Zero();  // the centroid of the first tetrahedron
  for (int k = 0; k < 4; ++k) inside += 0.25 * lv.mesh().nodes.row(lv.mesh().tets(0, k)).transpose();
  const PlacedSite p = place_lead(lv.mesh(), lv.labels(), {0, act::Surface::kEpicardium, inside});
  EXPECT_EQ(p.segment, lv.labels().element_segment[0]);
}

}  // namespace
}  // namespace sigmaheart::model::fem
