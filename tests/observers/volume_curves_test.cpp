// Checks of observed volume curves (observers/volume_curves.h, docs/models.md s.5.1): a clean beat
// passes with its ED/ES and regional EFs; a negative segment, a jump and a sum error are each
// named with their frame and segment.
#include "observers/volume_curves.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace sigmaheart::observers {
namespace {

// 20 frames of a beat: each segment s holds (s + 5) mL at ED, ejecting by a fraction that grows
// with s; V_lv is their sum. ED at frame 2, ES at frame 9.
VolumeCurves beat() {
  VolumeCurves c;
  const int n = 20;
  c.times = Eigen::VectorXd::LinSpaced(n, 0.0, 0.8 * (n - 1) / n);
  c.regional.resize(n, kAhaSegments);
  for (int k = 0; k < n; ++k) {
    const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * (k - 2) / 14.0);  // 0 at frame 2, 1 at 9
    for (int s = 1; s <= kAhaSegments; ++s)
      c.regional(k, s - 1) = (s + 5) * 1e-6 * (1 - (k >= 2 && k <= 16 ? w : 0.0) * (0.2 + 0.02 * s));
  }
  c.cavity = c.regional.rowwise().sum();
  return c;
}

TEST(VolumeCurves, ACleanBeatPassesWithItsEdEsAndRegionalEjectionFractions) {
  const VolumeChecks v = check_volume_curves(beat(), {});
  EXPECT_TRUE(v.ok()) << v.report();
  EXPECT_EQ(v.end_diastole, 0);  // frames 0-2 hold the ED volume: the first largest
  EXPECT_EQ(v.end_systole, 9);
  EXPECT_NEAR(v.regional_ef[6], 0.2 + 0.02 * 7, 1e-12);
  EXPECT_NEAR(v.max_sum_error, 0.0, 1e-15);
  VolumeCheckOptions o;
  o.end_diastole = 2;
  EXPECT_EQ(check_volume_curves(beat(), o).end_diastole, 2);
}

TEST(VolumeCurves, TrackingFailuresAreNamedWithFrameAndSegment) {
  VolumeCurves c = beat();
  c.regional(5, 6) = -0.1e-6;  // segment 7 negative at frame 5 (also a jump)
  c.regional(12, 2) *= 1.6;    // segment 3 jumps at frame 12 (60 % of its volume)
  c.cavity = c.regional.rowwise().sum();
  c.cavity(15) *= 1.05;        // the segments do not sum to V_lv at frame 15
  const VolumeChecks v = check_volume_curves(c, {});
  EXPECT_FALSE(v.ok());
  const std::string r = v.report();
  EXPECT_NE(r.find("frame 5: V_seg07: volume -0.1 mL (negative"), std::string::npos) << r;
  EXPECT_NE(r.find("frame 11: V_seg03: jumps by"), std::string::npos) << r;
  EXPECT_NE(r.find("frame 15: V_lv: the regional volumes sum to within 4.76 % of V_lv"), std::string::npos) << r;
  EXPECT_EQ(v.max_sum_error_frame, 15);
}

TEST(VolumeCurves, TheTrajectoryCarriesTheChannelsTheEstimatorsRead) {
  const model::Trajectory t = volume_trajectory(beat());
  ASSERT_EQ(t.channels.size(), 18u);
  EXPECT_EQ(t.channels[0].name, "V_lv");
  EXPECT_EQ(t.channels[17].name, "V_seg17");
  EXPECT_EQ(t.channels[17].family, "regional_volume");
  EXPECT_EQ(t.channels[17].segment, 17);
  EXPECT_THROW(check_volume_curves(VolumeCurves{}, {}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::observers
