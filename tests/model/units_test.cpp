#include "model/units.h"

#include <gtest/gtest.h>

namespace sigmaheart::model::units {
namespace {

TEST(Units, ConvertsClinicalUnitsToSi) {
  EXPECT_DOUBLE_EQ(convert(120.0, "mmHg", "Pa"), 120.0 * 133.322);
  EXPECT_DOUBLE_EQ(convert(150.0, "mL", "m^3"), 150e-6);
  EXPECT_DOUBLE_EQ(convert(1.0, "L", "mL"), 1000.0);
  EXPECT_NEAR(convert(16.0, "kPa", "mmHg"), 120.0096, 1e-3);
  EXPECT_DOUBLE_EQ(convert(10.0, "MPa", "Pa"), 1e7);
  EXPECT_DOUBLE_EQ(convert(850.0, "ms", "s"), 0.85);
  EXPECT_DOUBLE_EQ(convert(60.0, "%", "1"), 0.6);
  EXPECT_NEAR(convert(5.0, "L/min", "mL/s"), 83.3333333, 1e-6);
}

TEST(Units, ReadsAHeartRateInBeatsPerMinute) {
  EXPECT_DOUBLE_EQ(convert(72.0, "bpm", "1/s"), 1.2);
  EXPECT_DOUBLE_EQ(convert(90.0, "1/min", "Hz"), 1.5);
  EXPECT_FALSE(compatible("bpm", "s"));
}

TEST(Units, RefusesUnknownOrIncompatibleUnits) {
  EXPECT_THROW(convert(1.0, "furlong", "m"), std::invalid_argument);
  EXPECT_THROW(convert(1.0, "mL", "mmHg"), std::invalid_argument);
  EXPECT_TRUE(compatible("kPa", "mmHg"));
  EXPECT_FALSE(compatible("kPa", "mL"));
}

}  // namespace
}  // namespace sigmaheart::model::units
