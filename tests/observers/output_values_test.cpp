// observers/output_values.h: named outputs of a model that returns single values.
#include "observers/output_values.h"

#include <gtest/gtest.h>

namespace sigmaheart::observers {
namespace {

model::Trajectory values_of(const std::vector<std::pair<std::string, double>>& named) {
  model::Trajectory t;
  t.times = Eigen::VectorXd::Zero(1);
  t.values.resize(1, static_cast<Eigen::Index>(named.size()));
  for (size_t i = 0; i < named.size(); ++i) {
    t.channels.push_back({named[i].first, "1", "", "", 0});
    t.values(0, static_cast<Eigen::Index>(i)) = named[i].second;
  }
  return t;
}

TEST(OutputValues, AVectorNameStandsForItsElementsAndAnElementForItself) {
  const auto t = values_of({{"log_density", -5.5}, {"T[0]", 1.0}, {"T[1]", 2.0}, {"T[2]", 3.0}});
  const OutputValues all({"T", "log_density"}, t.channels);
  ASSERT_EQ(all.size(), 4);
  EXPECT_EQ(all.outputs()[0].name, "T[0]");
  EXPECT_EQ(all.outputs()[3].name, "log_density");
  Eigen::VectorXd z(4);
  ASSERT_TRUE(all.observe(t, z).ok());
  EXPECT_EQ(z, (Eigen::VectorXd(4) << 1.0, 2.0, 3.0, -5.5).finished());
  const OutputValues one({"T[1]"}, t.channels);
  Eigen::VectorXd z1(1);
  ASSERT_TRUE(one.observe(t, z1).ok());
  EXPECT_EQ(z1(0), 2.0);
}

TEST(OutputValues, UnknownOrRepeatedNamesAndCurvesAreRefused) {
  const auto t = values_of({{"log_density", -5.5}, {"T[0]", 1.0}, {"T[1]", 2.0}});
  try {
    OutputValues({"log_densty"}, t.channels);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'log_density'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the model's outputs: T, T[0], T[1], log_density"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(OutputValues({"T", "T[1]"}, t.channels), std::invalid_argument);
  // A curve (several samples) is not a value: a failed observation, never a silent pick.
  model::Trajectory curve = t;
  curve.times = Eigen::VectorXd::LinSpaced(3, 0.0, 1.0);
  curve.values = Eigen::MatrixXd::Zero(3, 3);
  const OutputValues o({"log_density"}, t.channels);
  Eigen::VectorXd z(1);
  const auto s = o.observe(curve, z);
  EXPECT_EQ(s.code, model::StatusCode::kBadOutput);
  EXPECT_NE(s.message.find("returned 3 samples"), std::string::npos) << s.message;
}

}  // namespace
}  // namespace sigmaheart::observers
