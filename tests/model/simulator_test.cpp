#include "model/simulator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace sigmaheart::model {
namespace {

ParameterSpace two_parameters() {
  return ParameterSpace({{"sigma0", "Pa", 1.25e5, 0.0, 1e7, "contractility"},
                         {"k_ATP", "1/s", 35.0, 1.0, 200.0, "contraction rate"}});
}

TEST(ParameterSpace, LooksUpByNameAndSuggestsTheClosestName) {
  const auto space = two_parameters();
  EXPECT_EQ(space.index("k_ATP"), 1);
  EXPECT_FALSE(space.index("k_atp_").has_value());
  try {
    space.index_or_throw("sigma_0");
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'sigma0'"), std::string::npos) << e.what();
  }
}

TEST(ParameterSpace, CheckNamesTheParameterOutOfBounds) {
  const auto space = two_parameters();
  Eigen::VectorXd theta = space.nominal();
  EXPECT_EQ(space.check(theta), "");
  theta(1) = 500.0;
  const auto msg = space.check(theta);
  EXPECT_NE(msg.find("k_ATP"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1/s"), std::string::npos) << msg;
  theta(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(space.check(theta), "");
  EXPECT_NE(space.check(Eigen::VectorXd::Zero(3)), "");
}

TEST(ParameterSpace, SetNominalRejectsValuesOutsideBounds) {
  auto space = two_parameters();
  space.set_nominal("sigma0", 2e5);
  EXPECT_DOUBLE_EQ(space.nominal()(0), 2e5);
  EXPECT_THROW(space.set_nominal("sigma0", -1.0), std::invalid_argument);
  EXPECT_THROW(space.set_nominal("nope", 1.0), std::invalid_argument);
}

TEST(ParameterSpace, RejectsDuplicateNamesAndNominalOutsideBounds) {
  EXPECT_THROW(ParameterSpace({{"a", "1", 0.5, 0, 1, ""}, {"a", "1", 0.5, 0, 1, ""}}),
               std::invalid_argument);
  EXPECT_THROW(ParameterSpace({{"a", "1", 2.0, 0, 1, ""}}), std::invalid_argument);
}

TEST(Trajectory, ChannelLookupNamesTheMissingChannel) {
  Trajectory t;
  t.times = Eigen::VectorXd::LinSpaced(3, 0.0, 1.0);
  t.channels = {{"V_lv", "m^3", ""}, {"P_lv", "Pa", ""}};
  t.values = Eigen::MatrixXd::Random(3, 2);
  EXPECT_EQ(t.channel("P_lv"), t.values.col(1));
  try {
    t.channel("V_LV ");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("V_lv"), std::string::npos) << e.what();
  }
}

TEST(ClosestMatch, IgnoresFarAwayWords) {
  EXPECT_EQ(closest_match("sigma0", {"sigma0", "k_RS"}), "sigma0");
  EXPECT_EQ(closest_match("xyzzyq", {"sigma0", "k_RS"}), "");
}

}  // namespace
}  // namespace sigmaheart::model
