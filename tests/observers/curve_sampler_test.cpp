#include "observers/curve_sampler.h"

#include "analytic_beat.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::observers {
namespace {

using testing::CosineBeat;
using testing::sample_beat;

Eigen::VectorXd frames(int n, double period) {
  return Eigen::VectorXd::LinSpaced(n, 0.0, period * (n - 1) / n);
}

TEST(CurveSampler, NamesFramesWithTwoDigitsOrAsManyAsNeeded) {
  EXPECT_EQ(frame_name("V_lv", 0, 30), "V_lv@f00");
  EXPECT_EQ(frame_name("V_lv", 29, 30), "V_lv@f29");
  EXPECT_EQ(frame_name("V_seg07", 5, 120), "V_seg07@f005");
  CurveSamplerOptions o;
  o.channels = {"V_lv", "P_lv"};
  o.frame_times = frames(30, 0.8);
  const CurveSampler s(o, {{"V_lv", "m^3", ""}, {"P_lv", "Pa", ""}});
  const auto out = s.outputs();
  ASSERT_EQ(out.size(), 60u);
  EXPECT_EQ(out[0].name, "V_lv@f00");
  EXPECT_EQ(out[30].name, "P_lv@f00");
  EXPECT_EQ(out[59].name, "P_lv@f29");
  EXPECT_EQ(out[45].unit, "Pa");
}

TEST(CurveSampler, PutsFrameZeroAtEndDiastoleAndWrapsAroundTheBeat) {
  CosineBeat b;
  b.t_ed = 0.65;  // late in the record: most frames wrap into the next beat
  const auto tr = sample_beat(b.channels(), b.period, 800, true);
  CurveSamplerOptions o;
  o.channels = {"V_lv", "P_lv"};
  o.frame_times = frames(30, b.period);
  const CurveSampler s(o, tr.channels);
  Eigen::VectorXd z(s.size());
  ASSERT_TRUE(s.observe(tr, z).ok());
  // Linear interpolation on a 1 ms grid: error <= A w^2 h^2 / 8 = 3e-10 m^3, plus the located
  // ED crossing (~2 us).
  for (int j = 0; j < 30; ++j) {
    const double t = b.ed_onset() + o.frame_times(j);
    EXPECT_NEAR(z(j), b.volume(t), 1e-9) << j;
    EXPECT_NEAR(z(30 + j), b.pressure(t), 0.5) << j;
  }
  const double sv = 2 * b.amplitude;
  EXPECT_NEAR(z(0), b.v0 + b.amplitude - 0.05 * sv, 1e-9);   // frame 0: onset of the ED plateau
  EXPECT_NEAR(z(15), b.v0 - b.amplitude + 0.05 * sv, 1e-9);  // half a beat later: end of ejection
}

TEST(CurveSampler, SamplesRegionalVolumesAlignedOnTheGlobalVolume) {
  CosineBeat b;
  auto channels = b.channels();
  const double w = b.w();
  channels.push_back({"V_seg07", "m^3", [=](double t) { return 5e-6 + 1e-6 * std::sin(w * t); }});
  const auto tr = sample_beat(channels, b.period, 800, true);
  CurveSamplerOptions o;
  o.channels = {"V_seg07"};
  o.frame_times = frames(30, b.period);
  o.interpolation = Interpolation::kCubic;
  const CurveSampler s(o, tr.channels);
  Eigen::VectorXd z(s.size());
  ASSERT_TRUE(s.observe(tr, z).ok());
  EXPECT_EQ(s.outputs()[7].name, "V_seg07@f07");
  for (int j = 0; j < 30; ++j) {
    // Cubic Hermite on 1 ms is exact to 1e-15 here; what remains is ED located to ~2 us.
    EXPECT_NEAR(z(j), 5e-6 + 1e-6 * std::sin(w * (b.ed_onset() + o.frame_times(j))), 5e-11) << j;
  }
}

TEST(CurveSampler, RefusesAnUnknownChannelWithDidYouMean) {
  CurveSamplerOptions o;
  o.channels = {"V_seg7"};
  o.frame_times = frames(30, 0.8);
  try {
    CurveSampler s(o, {{"V_lv", "m^3", ""}, {"V_seg07", "m^3", ""}});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'V_seg07'"), std::string::npos) << e.what();
  }
}

TEST(CurveSampler, ReportsATrajectoryWithoutTheChannelAsAStatus) {
  CurveSamplerOptions o;
  o.channels = {"P_lv"};
  o.frame_times = frames(30, 0.8);
  const CurveSampler s(o, {{"V_lv", "m^3", ""}, {"P_lv", "Pa", ""}});
  const CosineBeat b;
  auto tr = sample_beat(b.channels(), b.period, 100, true);
  tr.channels[1].name = "P_ao";
  Eigen::VectorXd z(s.size());
  EXPECT_FALSE(s.observe(tr, z).ok());
}

}  // namespace
}  // namespace sigmaheart::observers
