#include "estimation/sensitivity/oat.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sh = sigmaheart::estimation::sensitivity;
using sigmaheart::testing::FunctionModel;
namespace model = sigmaheart::model;

namespace {

// y1 = a^2 + 3 b, y2 = a b c; fails when c > 10.
FunctionModel known() {
  return FunctionModel({"a", "b", "c"}, {{"y1", "1", ""}, {"y2", "1", ""}},
                       [](const Eigen::VectorXd& x, Eigen::Ref<Eigen::VectorXd> z) {
                         if (x(2) > 10.0) return model::Status::Error(model::StatusCode::kDiverged, "c too large");
                         z(0) = x(0) * x(0) + 3.0 * x(1);
                         z(1) = x(0) * x(1) * x(2);
                         return model::Status::Ok();
                       });
}

sigmaheart::estimation::PriorParameter range(const char* name, double nominal, double lower,
                                             double upper) {
  return sigmaheart::estimation::PriorParameter::uniform(name, "1", lower, upper, nominal);
}

sigmaheart::estimation::Prior ranges() {
  return {{range("a", 1.0, 0.5, 2.0), range("b", 2.0, 1.0, 4.0), range("c", 5.0, 1.0, 20.0)}, {}};
}

}  // namespace

TEST(Oat, RelativeStudyGivesTheHandComputedDeltasAndElasticities) {
  // Nominal (1, 2, 5): y1 = 7, y2 = 10. +-10 %:
  //  a: 0.9 -> y1 = 6.81, y2 = 9;   1.1 -> y1 = 7.21, y2 = 11
  //  b: 1.8 -> y1 = 6.4,  y2 = 9;   2.2 -> y1 = 7.6,  y2 = 11
  //  c: 4.5 -> y1 = 7,    y2 = 9;   5.5 -> y1 = 7,    y2 = 11
  // Elasticity of y1 to a: ((7.21 - 6.81)/7)/0.2 = 0.285714 (exact d ln y1/d ln a = 2a^2/y1 = 2/7);
  // of y2 to every parameter: (2/10)/0.2 = 1.
  sh::OatOptions o;
  o.relative_change = 0.1;
  const auto r = sh::run_oat(known(), ranges(), o);
  ASSERT_TRUE(r.ok()) << r.report();
  EXPECT_EQ(r.thetas.rows(), 7);
  EXPECT_NEAR(r.z_nominal(0), 7.0, 1e-12);
  EXPECT_NEAR(r.z_nominal(1), 10.0, 1e-12);
  EXPECT_NEAR(r.delta_low(0, 0), 6.81 - 7.0, 1e-12);
  EXPECT_NEAR(r.delta_high(0, 0), 7.21 - 7.0, 1e-12);
  EXPECT_NEAR(r.delta_low(1, 0), -0.6, 1e-12);
  EXPECT_NEAR(r.delta_high(1, 0), 0.6, 1e-12);
  EXPECT_NEAR(r.delta_low(2, 0), 0.0, 1e-12);
  EXPECT_NEAR(r.delta_high(2, 1), 1.0, 1e-12);
  EXPECT_NEAR(r.normalised(0, 0), 2.0 / 7.0, 1e-12);
  EXPECT_NEAR(r.normalised(1, 0), 6.0 / 7.0, 1e-12);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(r.normalised(i, 1), 1.0, 1e-12);
  // Tornado of y1: b (swing 1.2), a (0.4), c (0).
  const auto bars = r.tornado(0);
  ASSERT_EQ(bars.size(), 3u);
  EXPECT_EQ(bars[0].parameter, 1);
  EXPECT_EQ(bars[1].parameter, 0);
  EXPECT_EQ(bars[2].parameter, 2);
  EXPECT_NEAR(bars[0].swing, 1.2, 1e-12);
}

TEST(Oat, RangeStudyMovesEachParameterToItsBoundsAndReportsFailedRuns) {
  sh::OatOptions o;
  o.mode = sh::OatMode::kRange;
  const auto r = sh::run_oat(known(), ranges(), o);
  EXPECT_TRUE(r.ok());
  EXPECT_DOUBLE_EQ(r.theta_low(0), 0.5);
  EXPECT_DOUBLE_EQ(r.theta_high(2), 20.0);
  // a = 2: y1 = 4 + 6 = 10, delta 3.
  EXPECT_NEAR(r.delta_high(0, 0), 3.0, 1e-12);
  // c = 20 fails: that run is NaN and listed; the rest of the table stands.
  ASSERT_EQ(r.failed_runs.size(), 1u);
  EXPECT_EQ(r.failed_runs[0].block, "high c");
  EXPECT_TRUE(std::isnan(r.delta_high(2, 1)));
  EXPECT_FALSE(std::isnan(r.delta_low(2, 1)));
  EXPECT_EQ(r.tornado(1).back().parameter, 2);  // the failed parameter sorts last
  EXPECT_NE(r.report().find("c too large"), std::string::npos);
}

TEST(Oat, AFailedNominalRunInvalidatesTheStudy) {
  auto rr = ranges();
  rr.parameters[2].theta_nominal = 15.0;
  const auto r = sh::run_oat(known(), rr, sh::OatOptions{});
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.status, sh::StudyStatus::kFailedNominal);
  EXPECT_TRUE(std::isnan(r.delta_low(0, 0)));
  EXPECT_NE(r.report().find("INVALID"), std::string::npos);
}
