#include "observers/beat.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::observers {
namespace {

Eigen::VectorXd linspace_times(int n, double dt) {
  return Eigen::VectorXd::LinSpaced(n, 0.0, dt * (n - 1));
}

TEST(Beat, DropsTheRepeatedLastSampleOfAClosedBeat) {
  const Eigen::VectorXd t = linspace_times(11, 0.1);  // 0 .. 1 s
  Eigen::MatrixXd v(11, 1);
  for (int k = 0; k < 11; ++k) v(k, 0) = std::cos(2 * M_PI * t(k));
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, v, {}, g).ok());
  EXPECT_TRUE(g.closed);
  EXPECT_EQ(g.samples(), 10);
  EXPECT_DOUBLE_EQ(g.period, 1.0);
}

TEST(Beat, TakesOneFrameMoreThanTheSpanAsThePeriodOfOpenFrames) {
  const Eigen::VectorXd t = linspace_times(30, 0.8 / 30);
  Eigen::MatrixXd v(30, 1);
  for (int k = 0; k < 30; ++k) v(k, 0) = std::cos(2 * M_PI * t(k) / 0.8);
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, v, measured_frames(), g).ok());
  EXPECT_FALSE(g.closed);
  EXPECT_EQ(g.samples(), 30);
  EXPECT_NEAR(g.period, 0.8, 1e-12);
}

TEST(Beat, DecidesClosureByTimesWhenThePeriodIsGiven) {
  const Eigen::VectorXd t = linspace_times(31, 0.8 / 30);
  Eigen::MatrixXd v = Eigen::MatrixXd::Random(31, 1);  // values do not repeat: times decide
  BeatOptions o;
  o.periodicity = Periodicity::kAuto;
  o.period = 0.8;
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, v, o, g).ok());
  EXPECT_TRUE(g.closed);
  o.period = 0.9;
  ASSERT_TRUE(make_beat_grid(t, v, o, g).ok());
  EXPECT_FALSE(g.closed);
  EXPECT_DOUBLE_EQ(g.period, 0.9);
  o.period = 0.5;
  EXPECT_FALSE(make_beat_grid(t, v, o, g).ok());
}

TEST(Beat, GuessesClosureFromValuesWhenAskedToDecide) {
  const Eigen::VectorXd t = linspace_times(31, 1.0 / 30);
  Eigen::MatrixXd v(31, 1);
  for (int k = 0; k < 31; ++k) v(k, 0) = std::cos(2 * M_PI * (t(k) - 0.1));
  BeatOptions o;
  o.periodicity = Periodicity::kAuto;
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, v, o, g).ok());
  EXPECT_TRUE(g.closed);  // last = first
  ASSERT_TRUE(make_beat_grid(t.head(30), v.topRows(30), o, g).ok());
  EXPECT_FALSE(g.closed);  // last is one frame before: |x_last - x_first| = 7 % of the range
  EXPECT_NEAR(g.period, 1.0, 1e-12);
}

TEST(Beat, SpreadsTheMismatchOfAClosedBeatLinearly) {
  const Eigen::VectorXd t = linspace_times(5, 0.25);
  Eigen::VectorXd x(5);
  x << 1.0, 2.0, 3.0, 2.0, 1.4;
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, x, {}, g).ok());
  const Eigen::VectorXd u = g.unique_samples(x);
  ASSERT_EQ(u.size(), 4);
  EXPECT_NEAR(u(1), 2.0 - 0.4 * 0.25, 1e-15);
  EXPECT_NEAR(u(3), 2.0 - 0.4 * 0.75, 1e-15);
}

TEST(Beat, RefusesTimesThatDoNotIncrease) {
  Eigen::VectorXd t(4);
  t << 0.0, 0.1, 0.1, 0.2;
  BeatGrid g;
  const auto s = make_beat_grid(t, Eigen::MatrixXd::Zero(4, 1), {}, g);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message.find("do not increase"), std::string::npos);
}

TEST(Beat, DifferentiatesAQuadraticExactlyOnANonUniformGrid) {
  Eigen::VectorXd t(6);
  t << 0.0, 0.07, 0.2, 0.23, 0.4, 0.61;
  Eigen::VectorXd x = (3.0 * t.array().square() - 2.0 * t.array() + 1.0).matrix();
  BeatOptions o;
  o.periodicity = Periodicity::kNone;
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, x, o, g).ok());
  const Eigen::VectorXd d = derivative(g, x);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(d(i), 6.0 * t(i) - 2.0, 1e-12) << i;
}

TEST(Beat, CentredDifferencesOfAPeriodicSineLoseSincOfTheStep) {
  const int n = 30;
  const double T = 1.0, h = T / n, w = 2 * M_PI / T;
  const Eigen::VectorXd t = linspace_times(n, h);
  const Eigen::VectorXd x = (w * t.array()).sin().matrix();
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, x, measured_frames(), g).ok());
  const Eigen::VectorXd d = derivative(g, x);
  // (sin(w(t+h)) - sin(w(t-h))) / 2h = w cos(wt) sin(wh)/(wh), including the wrapped ends.
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(d(i), w * std::cos(w * t(i)) * std::sin(w * h) / (w * h), 1e-12) << i;
  }
}

TEST(Beat, RefinesAnExtremumBetweenFramesByTheParabolaVertex) {
  const int n = 30;
  const double T = 1.0, h = T / n, w = 2 * M_PI / T, t_peak = 0.51 * h;  // between frames 0 and 1
  const Eigen::VectorXd t = linspace_times(n, h);
  const Eigen::VectorXd x = (w * (t.array() - t_peak)).cos().matrix();
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, x, measured_frames(), g).ok());
  const Extremum raw = find_max(g, x, false);
  const Extremum fine = find_max(g, x, true);
  EXPECT_GT(1.0 - raw.value, 5e-3);           // the frame maximum misses the peak by 0.5 %
  EXPECT_NEAR(fine.value, 1.0, 2e-4);         // the vertex is 25x closer
  EXPECT_NEAR(fine.time, t_peak, 0.02 * h);
}

TEST(Beat, InterpolatesAcrossTheWrapOfAPeriodicBeat) {
  const int n = 10;
  const Eigen::VectorXd t = linspace_times(n, 0.1);
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, 0.0, 9.0);
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, x, measured_frames(), g).ok());  // period 1 s
  EXPECT_NEAR(*interpolate(g, x, nullptr, 0.95, Interpolation::kLinear), 4.5, 1e-12);  // 9 -> 0
  EXPECT_NEAR(*interpolate(g, x, nullptr, 1.05, Interpolation::kLinear), 0.5, 1e-12);
  EXPECT_NEAR(*interpolate(g, x, nullptr, -0.85, Interpolation::kLinear), 1.5, 1e-12);
}

TEST(Beat, CubicInterpolationIsExactOnAQuadratic) {
  Eigen::VectorXd t(5);
  t << 0.0, 0.1, 0.25, 0.3, 0.5;
  const Eigen::VectorXd x = (t.array().square() + t.array()).matrix();
  BeatOptions o;
  o.periodicity = Periodicity::kNone;
  BeatGrid g;
  ASSERT_TRUE(make_beat_grid(t, x, o, g).ok());
  const Eigen::VectorXd d = derivative(g, x);
  for (double s : {0.05, 0.2, 0.27, 0.44}) {
    EXPECT_NEAR(*interpolate(g, x, &d, s, Interpolation::kCubic), s * s + s, 1e-12) << s;
  }
  EXPECT_FALSE(interpolate(g, x, &d, 0.6, Interpolation::kCubic).has_value());
}

TEST(Beat, ParsesPeriodicityAndInterpolationNames) {
  EXPECT_EQ(parse_periodicity("open"), Periodicity::kOpen);
  EXPECT_FALSE(parse_periodicity("periodic").has_value());
  EXPECT_EQ(parse_interpolation("cubic"), Interpolation::kCubic);
  EXPECT_STREQ(to_string(Periodicity::kClosed), "closed");
}

}  // namespace
}  // namespace sigmaheart::observers
