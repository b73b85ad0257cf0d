#include "observers/pump_work.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

namespace sigmaheart::observers {
namespace {

std::string seg(int s) { return std::string("V_seg") + (s < 10 ? "0" : "") + std::to_string(s); }

// An elliptic PV loop, ejection at high pressure and filling at low pressure: its area is
// pi a b exactly, and the trapezoidal rule on n points of the ellipse gives (n / 2pi) sin(2pi / n) of
// it. Segment s holds the share w_s of the volume, its pressure the cavity's.
model::Trajectory loop(int n, double a, double b, bool regional) {
  model::Trajectory t;
  t.channels = {{"V_lv", "m^3", ""}, {"P_lv", "Pa", ""}};
  if (regional)
    for (int s = 1; s <= 17; ++s) t.channels.push_back({seg(s), "m^3", "", "regional_volume", s});
  t.times.resize(n);
  t.values.resize(n, static_cast<Eigen::Index>(t.channels.size()));
  for (int k = 0; k < n; ++k) {
    const double phi = 2.0 * std::numbers::pi * k / n;
    t.times(k) = 0.8 * k / n;
    const double V = 1e-4 + a * std::cos(phi), P = 8e3 + b * std::sin(phi);  // high P while V falls
    t.values(k, 0) = V;
    t.values(k, 1) = P;
    if (regional)
      for (int s = 1; s <= 17; ++s) t.values(k, 1 + s) = V * (s == 5 ? 0.10 : s == 2 ? 0.02 : 0.88 / 15.0);
  }
  return t;
}

TEST(PumpWork, IsTheAreaOfTheLoopAndTheRegionalLoopsOfTheSegments) {
  const int n = 400;
  const double a = 3e-5, b = 6e3;
  const model::Trajectory t = loop(n, a, b, true);
  const PumpWork w(t.channels);
  ASSERT_TRUE(w.regional());
  Eigen::VectorXd z(w.size());
  ASSERT_TRUE(w.observe(t, z).ok());
  const double exact = std::numbers::pi * a * b * (n / (2.0 * std::numbers::pi)) * std::sin(2.0 * std::numbers::pi / n);
  EXPECT_NEAR(z(0), exact, 1e-12 * exact);
  EXPECT_NEAR(z(0), std::numbers::pi * a * b, 1e-4 * std::numbers::pi * a * b);  // 565 mJ
  // Septal segments 2, 3, 8, 9, 14 hold 0.02 and 4 x 0.88/15 of the volume; lateral 5 holds 0.10.
  const double septal = (0.02 + 4 * 0.88 / 15.0) / 5.0, lateral = (0.10 + 4 * 0.88 / 15.0) / 5.0;
  EXPECT_NEAR(z(1), septal * exact, 1e-12 * exact);
  EXPECT_NEAR(z(2), lateral * exact, 1e-12 * exact);
  EXPECT_NEAR(z(3), (lateral - septal) * exact, 1e-12 * exact);
}

TEST(PumpWork, WithoutRegionalVolumesOnlyTheStrokeWork) {
  const model::Trajectory t = loop(100, 3e-5, 6e3, false);
  const PumpWork w(t.channels);
  EXPECT_FALSE(w.regional());
  EXPECT_EQ(w.size(), 1);
  Eigen::VectorXd z(1);
  EXPECT_TRUE(w.observe(t, z).ok());
  EXPECT_GT(z(0), 0.0);
  EXPECT_THROW(PumpWork({{"V_lv", "m^3", ""}}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::observers
