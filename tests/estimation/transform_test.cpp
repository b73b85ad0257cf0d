#include "estimation/transform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace sigmaheart::estimation {
namespace {

std::vector<Transform> all_transforms() {
  return {
      Transform{TransformKind::kIdentity},
      Transform{TransformKind::kLog, 2.5e4},
      Transform{TransformKind::kLogit, 1.0, 0.0, 1.0},
      // Non-zero lower bound: a sigmoid mapped to the wrong interval fails here.
      Transform{TransformKind::kLogit, 1.0, 2.0, 7.0},
      Transform{TransformKind::kLogit, 1.0, -3.0, -1.0},
  };
}

TEST(Transform, RoundTripsEtaThetaEta) {
  for (const auto& t : all_transforms()) {
    ASSERT_TRUE(t.validate().empty()) << t.validate();
    for (double eta : {-6.0, -1.3, 0.0, 0.4, 2.0, 6.0}) {
      EXPECT_NEAR(t.to_eta(t.to_theta(eta)), eta, 1e-9) << to_string(t.kind);
    }
  }
}

TEST(Transform, LogitMapsOntoItsInterval) {
  const Transform t{TransformKind::kLogit, 1.0, 2.0, 7.0};
  EXPECT_NEAR(t.to_theta(0.0), 4.5, 1e-14);  // midpoint
  EXPECT_NEAR(t.to_theta(-40.0), 2.0, 1e-12);
  EXPECT_NEAR(t.to_theta(40.0), 7.0, 1e-12);
  for (double eta = -30; eta <= 30; eta += 0.5) {
    const double theta = t.to_theta(eta);
    EXPECT_GE(theta, 2.0);
    EXPECT_LE(theta, 7.0);
  }
  EXPECT_NEAR(t.to_eta(2.0 + 5.0 * 0.25), std::log(1.0 / 3.0), 1e-14);
}

TEST(Transform, InverseRejectsValuesOutsideTheRange) {
  const Transform logit{TransformKind::kLogit, 1.0, 2.0, 7.0};
  EXPECT_THROW(logit.to_eta(1.9), std::domain_error);
  EXPECT_THROW(logit.to_eta(7.0), std::domain_error);
  const Transform log{TransformKind::kLog, 3.0};
  EXPECT_THROW(log.to_eta(0.0), std::domain_error);
  EXPECT_NEAR(log.to_eta(3.0), 0.0, 1e-15);
}

TEST(Transform, DerivativeMatchesCentralFiniteDifferences) {
  for (const auto& t : all_transforms()) {
    for (double eta : {-4.0, -0.7, 0.0, 1.1, 3.5}) {
      const double h = 1e-5;
      const double fd = (t.to_theta(eta + h) - t.to_theta(eta - h)) / (2 * h);
      EXPECT_NEAR(t.dtheta_deta(eta), fd, 1e-7 * std::max(1.0, std::abs(fd)))
          << to_string(t.kind) << " at eta " << eta;
    }
  }
}

TEST(Transform, ValidateReportsInconsistentFields) {
  EXPECT_FALSE((Transform{TransformKind::kLog, -1.0}).validate().empty());
  EXPECT_FALSE((Transform{TransformKind::kLogit, 1.0, 3.0, 3.0}).validate().empty());
  EXPECT_EQ(parse_transform_kind("logit"), TransformKind::kLogit);
  EXPECT_FALSE(parse_transform_kind("sigmoid").has_value());
}

}  // namespace
}  // namespace sigmaheart::estimation
