#include "model/activation/pacing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace sigmaheart::model::activation {
namespace {

constexpr double kV = 0.6;  // [m/s] the graph's default conduction velocity

double edge(int a, int b) {
  for (const SegmentEdge& e : aha17_graph())
    if ((e.a == a && e.b == b) || (e.a == b && e.b == a)) return e.length;
  ADD_FAILURE() << "no edge " << a << "-" << b;
  return std::nan("");
}

// By hand: the basal ring's centres lie at mid-height of the basal third of the reference
// ellipsoid (r_s 25 mm, r_l 45 mm, base 13.2 mm: z = (13.2 + (13.2 - 58.2 / 3)) / 2 = 3.5 mm),
// radius 25 sqrt(1 - (3.5 / 45)^2) mm, 60 degrees apart.
double basal_arc() {
  const double z = 0.5 * (0.0132 + (0.0132 - (0.0132 + 0.045) / 3.0));
  return 0.025 * std::sqrt(1.0 - (z / 0.045) * (z / 0.045)) * std::numbers::pi / 3.0;
}

Stimulus at(int segment, double t, const char* lead = "LV") { return {lead, {segment, Surface::kEpicardium, {}}, t}; }

TEST(SegmentPacing, BasalRingEdgesAreTheArcBetweenTheCentres) {
  EXPECT_NEAR(basal_arc(), 0.026101, 1e-5);
  for (int k = 1; k <= 6; ++k) EXPECT_NEAR(edge(k, k % 6 + 1), basal_arc(), 1e-9) << "edge " << k;
  // Every edge joins neighbours: 36 edges, every segment reachable, lengths of 15-35 mm.
  EXPECT_EQ(aha17_graph().size(), 36u);
  for (const SegmentEdge& e : aha17_graph()) {
    EXPECT_GT(e.length, 0.010) << e.a << "-" << e.b;
    EXPECT_LT(e.length, 0.035) << e.a << "-" << e.b;
  }
}

TEST(SegmentPacing, TwoSitesAndADelayGiveTheEarliestArrival) {
  PacingPlan plan;
  plan.intrinsic = false;
  plan.stimuli = {at(1, 0.0, "RV"), at(4, 0.020)};
  const PacingOutcome o = segment_pacing(plan, {});
  const double L = basal_arc() / kV;  // 43.5 ms
  const auto& t = o.segment_times;
  EXPECT_NEAR(t[0], 0.0, 1e-12);
  EXPECT_NEAR(t[3], 0.020, 1e-12);
  EXPECT_NEAR(t[1], L, 1e-9);            // 2 from 1
  EXPECT_NEAR(t[5], L, 1e-9);            // 6 from 1
  EXPECT_NEAR(t[2], 0.020 + L, 1e-9);    // 3 from 4 (0.020 + L < 2 L)
  EXPECT_NEAR(t[4], 0.020 + L, 1e-9);    // 5 from 4
  EXPECT_NEAR(t[6], edge(1, 7) / kV, 1e-9);  // mid anterior straight below 1
  EXPECT_EQ(o.captured, (std::vector<bool>{true, true}));
  EXPECT_NEAR(o.earliest, 0.0, 1e-12);
  double latest = 0.0;
  for (double x : t) latest = std::max(latest, x);
  EXPECT_NEAR(o.total_activation(), latest, 1e-12);
}

TEST(SegmentPacing, FusionWithTheIntrinsicWaveKeepsTheEarlierFront) {
  // An LBBB-like intrinsic sequence: septum (2, 3, 8, 9, 14) first, lateral wall (5, 6, 11, 12, 16)
  // 140 ms later, the rest at 70 ms.
  std::array<double, kSegments> intrinsic;
  intrinsic.fill(0.070);
  for (int s : {2, 3, 8, 9, 14}) intrinsic[static_cast<size_t>(s - 1)] = 0.0;
  for (int s : {5, 6, 11, 12, 16}) intrinsic[static_cast<size_t>(s - 1)] = 0.140;
  PacingPlan plan;
  plan.stimuli = {at(5, -0.040)};
  const auto& t = segment_pacing(plan, intrinsic).segment_times;
  const double L = basal_arc() / kV;
  EXPECT_NEAR(t[4], -0.040, 1e-12);                          // the paced segment
  EXPECT_NEAR(t[5], -0.040 + L, 1e-9);                       // 6: the paced wave, before 140 ms
  EXPECT_NEAR(t[3], -0.040 + L, 1e-9);                       // 4: the paced wave, before 70 ms
  EXPECT_NEAR(t[1], 0.0, 1e-12);                             // 2: the intrinsic septum first
  EXPECT_NEAR(t[10], -0.040 + edge(5, 11) / kV, 1e-9);       // 11 below the lead
  EXPECT_NEAR(t[15], std::min(0.140, t[10] + edge(11, 16) / kV), 1e-9);
  // Without the intrinsic wave the septum waits for the paced one, three basal arcs away.
  plan.intrinsic = false;
  EXPECT_NEAR(segment_pacing(plan, intrinsic).segment_times[1], -0.040 + 3 * L, 1e-9);
}

TEST(SegmentPacing, ScarNeitherConductsNorCaptures) {
  PacingPlan plan;
  plan.intrinsic = false;
  plan.scar = {2};
  plan.stimuli = {at(1, 0.0), at(2, -0.050)};  // the second lead sits in the scar
  const PacingOutcome o = segment_pacing(plan, {});
  EXPECT_EQ(o.captured, (std::vector<bool>{true, false}));
  EXPECT_NE(o.note.find("scar segment 2"), std::string::npos) << o.note;
  const auto& t = o.segment_times;
  EXPECT_NEAR(t[1], basal_arc() / kV, 1e-9);  // reached (what is left of it activates) ...
  // ... but it passes nothing on: 3 is reached round the scar, below it through the mid ring
  // (1-7-8-9-3), not through 2 (1-2-3) and not the long way round the base (1-6-5-4-3).
  const double below = edge(1, 7) + edge(7, 8) + edge(8, 9) + edge(3, 9);
  const double round = 4 * basal_arc();
  ASSERT_LT(below, round);
  EXPECT_NEAR(t[2], below / kV, 1e-9);
  EXPECT_GT(t[2], 2 * basal_arc() / kV + 0.03);
  EXPECT_NEAR(o.earliest, 0.0, 1e-12);  // the scar is left out of the activation time
}

TEST(SegmentPacing, ASegmentEnclosedByScarIsNeverReached) {
  PacingPlan plan;
  plan.intrinsic = false;
  plan.scar = {13, 14, 15, 16};
  plan.stimuli = {at(1, 0.0)};
  const PacingOutcome o = segment_pacing(plan, {});
  EXPECT_TRUE(std::isinf(o.segment_times[16]));
  EXPECT_TRUE(std::isfinite(o.segment_times[12]));  // the scar itself is reached
}

TEST(SegmentPacing, InvalidPlansAreRefused) {
  PacingPlan plan;
  plan.intrinsic = false;
  EXPECT_THROW(segment_pacing(plan, {}), std::invalid_argument);  // nothing activates
  plan.stimuli = {at(18, 0.0)};
  EXPECT_THROW(segment_pacing(plan, {}), std::invalid_argument);
  plan.stimuli = {{"LV", {0, Surface::kEpicardium, Eigen::Vector3d(0.0, 0.0, 0.0)}, 0.0}};
  EXPECT_THROW(segment_pacing(plan, {}), std::invalid_argument);  // a point on the graph
  plan.stimuli = {at(3, 0.0)};
  plan.intrinsic = true;
  std::array<double, kSegments> bad{};
  bad[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(segment_pacing(plan, bad), std::invalid_argument);
}

// A sequence made on the graph itself (two septal sources at 20 ms, 0.7 m/s) gives its velocity
// back exactly: every time is 20 ms + distance / 0.7 m/s, a line through the (distance, time) points.
TEST(SequenceVelocity, RecoversTheVelocityOfASequenceMadeOnTheGraph) {
  PacingPlan made;
  made.intrinsic = false;
  made.stimuli = {at(8, 0.02), at(9, 0.02)};
  std::array<double, kSegments> none;
  none.fill(std::numeric_limits<double>::infinity());
  std::array<double, kSegments> times = segment_pacing(made, none, {0.7}).segment_times;
  SequenceVelocity v = sequence_velocity(times, {});
  ASSERT_TRUE(v.failure.empty()) << v.failure;
  EXPECT_NEAR(v.velocity, 0.7, 1e-12);
  EXPECT_EQ(v.sources, (std::vector<int>{8, 9}));
  EXPECT_EQ(v.segments, 17);
  EXPECT_NEAR(v.r_squared, 1.0, 1e-12);
  // Scar segments are left out of the fit, whatever their times.
  times[4] = times[5] = 0.4;
  v = sequence_velocity(times, {5, 6});
  EXPECT_NEAR(v.velocity, 0.7, 1e-12);
  EXPECT_EQ(v.segments, 15);
  EXPECT_LT(sequence_velocity(times, {}).velocity, 0.5);  // the same times with 5, 6 counted: slower
  // A sequence that does not spread (synchronous) has no velocity, and says why.
  std::array<double, kSegments> flat;
  flat.fill(0.03);
  v = sequence_velocity(flat, {});
  EXPECT_EQ(v.velocity, 0.0);
  EXPECT_NE(v.failure.find("do not spread"), std::string::npos) << v.failure;
  // Two segments outside scar are no line.
  std::vector<int> all_but_two;
  for (int k = 3; k <= kSegments; ++k) all_but_two.push_back(k);
  v = sequence_velocity(times, all_but_two);
  EXPECT_NE(v.failure.find("fewer than 3"), std::string::npos) << v.failure;
}

}  // namespace
}  // namespace sigmaheart::model::activation
