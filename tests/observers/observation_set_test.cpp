#include "observers/observer.h"

#include <gtest/gtest.h>

namespace sigmaheart::observers {
namespace {

// EDV, ESV and P_max with correlated volume noise.
ObservationSet three() {
  Eigen::Matrix3d R = Eigen::Vector3d(25e-12, 16e-12, 4e4).asDiagonal();
  R(0, 1) = R(1, 0) = 10e-12;
  return {.names = {"EDV", "ESV", "P_max"},
          .units = {"m^3", "m^3", "Pa"},
          .display_units = {"mL", "mL", "mmHg"},
          .y = Eigen::Vector3d(150e-6, 60e-6, 16e3),
          .R = R};
}

TEST(ObservationSet, SelectKeepsTheRequestedOrderAndTheCovarianceBlock) {
  const auto s = three().select({"P_max", "EDV"});
  ASSERT_EQ(s.size(), 2);
  EXPECT_EQ(s.names[0], "P_max");
  EXPECT_EQ(s.display_units[1], "mL");
  EXPECT_DOUBLE_EQ(s.y(1), 150e-6);
  EXPECT_DOUBLE_EQ(s.R(0, 0), 4e4);
  EXPECT_DOUBLE_EQ(s.R(1, 1), 25e-12);
  EXPECT_DOUBLE_EQ(s.R(0, 1), 0.0);
  const auto pair = three().select({"ESV", "EDV"});
  EXPECT_DOUBLE_EQ(pair.R(0, 1), 10e-12);
  EXPECT_TRUE(s.validate().empty());
}

TEST(ObservationSet, SelectNamesAMissingObservationWithDidYouMean) {
  try {
    three().select({"EDV", "ESVV"});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'ESVV'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("did you mean 'ESV'"), std::string::npos) << e.what();
  }
}

TEST(ObservationSet, ValidateCatchesEachInconsistency) {
  EXPECT_TRUE(three().validate().empty());
  auto s = three();
  s.names.pop_back();
  EXPECT_NE(s.validate().find("names"), std::string::npos);
  s = three();
  s.y(1) = std::nan("");
  EXPECT_NE(s.validate().find("'ESV' is not finite"), std::string::npos);
  s = three();
  s.R(0, 2) = 1.0;
  EXPECT_NE(s.validate().find("not symmetric"), std::string::npos);
  s = three();
  s.R(2, 2) = 0.0;
  EXPECT_NE(s.validate().find("positive definite"), std::string::npos);
  s = three();
  s.R = Eigen::Matrix2d::Identity();
  EXPECT_NE(s.validate().find("wrong size"), std::string::npos);
}

}  // namespace
}  // namespace sigmaheart::observers
