#include "estimation/sigma_points.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace sigmaheart::estimation {
namespace {

std::vector<SigmaOptions> all_rules() {
  return {
      SigmaOptions{SigmaRule::kSimplex},
      SigmaOptions{SigmaRule::kCanonical},
      SigmaOptions{SigmaRule::kStar, 0.5},
      SigmaOptions{SigmaRule::kStar, 2.0},
      SigmaOptions{SigmaRule::kScaled, 0.0, 1e-3, 2.0},
      SigmaOptions{SigmaRule::kScaled, 1.0, 0.5, 2.0},
  };
}

TEST(SigmaPoints, EveryRuleHasUnitMomentsForOneToEightParameters) {
  for (const auto& opt : all_rules()) {
    for (int p = 1; p <= 8; ++p) {
      const SigmaPoints sp = make_sigma_points(p, opt);
      const double scale = std::max(1.0, sp.wm.cwiseAbs().maxCoeff());
      EXPECT_NEAR(sp.wm.sum(), 1.0, 1e-12 * scale) << to_string(opt.rule) << " p=" << p;
      EXPECT_LT((sp.unit * sp.wm).norm(), 1e-12 * scale);
      const Eigen::MatrixXd second = sp.unit * sp.wc.asDiagonal() * sp.unit.transpose();
      EXPECT_LT((second - Eigen::MatrixXd::Identity(p, p)).norm(), 1e-12 * scale)
          << to_string(opt.rule) << " p=" << p;
    }
  }
}

TEST(SigmaPoints, RulesHaveTheDocumentedCountsAndWeights) {
  const int p = 5;
  EXPECT_EQ(make_sigma_points(p, {SigmaRule::kSimplex}).count(), 6);
  EXPECT_EQ(make_sigma_points(p, {SigmaRule::kCanonical}).count(), 10);
  const SigmaPoints star = make_sigma_points(p, {SigmaRule::kStar, 0.5});
  EXPECT_EQ(star.count(), 11);
  EXPECT_NEAR(star.wm(0), 0.5 / 5.5, 1e-15);
  EXPECT_NEAR(star.unit.col(1).norm(), std::sqrt(5.5), 1e-14);
  const SigmaPoints scaled = make_sigma_points(p, {SigmaRule::kScaled, 0.0, 0.5, 2.0});
  const double lambda = 0.25 * 5 - 5;
  EXPECT_NEAR(scaled.wm(0), lambda / (5 + lambda), 1e-14);
  EXPECT_NEAR(scaled.wc(0), lambda / (5 + lambda) + 1 - 0.25 + 2, 1e-14);
}

TEST(SigmaPoints, SimplexIsRegularWithRadiusSqrtPAndEqualWeights) {
  for (int p = 1; p <= 8; ++p) {
    const SigmaPoints sp = make_sigma_points(p, {SigmaRule::kSimplex});
    ASSERT_EQ(sp.count(), p + 1);
    const double side = std::sqrt(2.0 * (p + 1));  // |u_i - u_j|^2 = 2p + 2 (u_i . u_j = -1)
    for (int i = 0; i <= p; ++i) {
      EXPECT_NEAR(sp.wm(i), 1.0 / (p + 1), 1e-15);
      EXPECT_NEAR(sp.unit.col(i).norm(), std::sqrt(static_cast<double>(p)), 1e-13);
      for (int j = i + 1; j <= p; ++j) {
        EXPECT_NEAR((sp.unit.col(i) - sp.unit.col(j)).norm(), side, 1e-13);
      }
    }
  }
}

// y = x^2, x ~ N(m, s^2): E y = m^2 + s^2, Var y = 4 m^2 s^2 + 2 s^4 (docs/estimation.md s.2).
struct Moments {
  double mean;
  double var;
};
Moments square_moments(const SigmaOptions& opt, double m, double s) {
  const SigmaPoints sp = make_sigma_points(1, opt);
  const Eigen::MatrixXd x = place_points(Eigen::VectorXd::Constant(1, m),
                                         Eigen::MatrixXd::Constant(1, 1, s), sp);
  const Eigen::VectorXd y = x.row(0).transpose().array().square();
  const double mean = sp.wm.dot(y);
  const double var = sp.wc.dot((y.array() - mean).square().matrix());
  return {mean, var};
}

TEST(SigmaPoints, ScaledRuleWithKappaThreeMinusNIsExactForTheSquare) {
  const double m = 1.7, s = 0.6;
  const Moments mo = square_moments({SigmaRule::kScaled, 2.0, 1.0, 0.0}, m, s);
  EXPECT_NEAR(mo.mean, m * m + s * s, 1e-12);
  EXPECT_NEAR(mo.var, 4 * m * m * s * s + 2 * std::pow(s, 4), 1e-12);
}

TEST(SigmaPoints, ScaledRuleWithSmallAlphaAndBetaTwoIsExactForTheSquare) {
  const double m = 1.7, s = 0.6;
  const Moments mo = square_moments({SigmaRule::kScaled, 0.0, 1e-3, 2.0}, m, s);
  // Weights of order 1/alpha^2 = 1e6 cancel: round-off ~ 1e6 * eps.
  EXPECT_NEAR(mo.mean, m * m + s * s, 1e-8);
  EXPECT_NEAR(mo.var, 4 * m * m * s * s + 2 * std::pow(s, 4), 1e-8);
}

TEST(SigmaPoints, ScaledRuleWithAlphaOneAndBetaTwoOverstatesTheVarianceByTwoS4) {
  const double m = 1.7, s = 0.6;
  const Moments mo = square_moments({SigmaRule::kScaled, 2.0, 1.0, 2.0}, m, s);
  EXPECT_NEAR(mo.mean, m * m + s * s, 1e-12);
  EXPECT_NEAR(mo.var - (4 * m * m * s * s + 2 * std::pow(s, 4)), 2 * std::pow(s, 4), 1e-12);
}

TEST(SigmaPoints, StarRuleWithKappaTwoIsExactForTheSquareInOneDimension) {
  const double m = -0.4, s = 1.3;
  const Moments mo = square_moments({SigmaRule::kStar, 2.0}, m, s);
  EXPECT_NEAR(mo.mean, m * m + s * s, 1e-12);
  EXPECT_NEAR(mo.var, 4 * m * m * s * s + 2 * std::pow(s, 4), 1e-12);
}

TEST(SigmaPoints, PlacedPointsReproduceMeanAndCovariance) {
  Eigen::MatrixXd A(3, 3);
  A << 2.0, 0.3, -0.1, 0.3, 1.0, 0.2, -0.1, 0.2, 0.5;
  const Eigen::VectorXd mean = (Eigen::VectorXd(3) << 1.0, -2.0, 0.5).finished();
  for (const auto& opt : all_rules()) {
    const SigmaPoints sp = make_sigma_points(3, opt);
    const Eigen::MatrixXd X = place_points(mean, covariance_sqrt(A), sp);
    const Eigen::VectorXd xm = X * sp.wm;
    const Eigen::MatrixXd D = X.colwise() - xm;
    const double scale = std::max(1.0, sp.wm.cwiseAbs().maxCoeff());
    EXPECT_LT((xm - mean).norm(), 1e-11 * scale) << to_string(opt.rule);
    EXPECT_LT((D * sp.wc.asDiagonal() * D.transpose() - A).norm(), 1e-11 * scale)
        << to_string(opt.rule);
  }
}

TEST(CovarianceSqrt, FallsBackToEigenForASemiDefiniteMatrix) {
  Eigen::MatrixXd P(2, 2);
  P << 1.0, 1.0, 1.0, 1.0;  // rank one
  bool fallback = false;
  const Eigen::MatrixXd S = covariance_sqrt(P, &fallback);
  EXPECT_TRUE(fallback);
  EXPECT_LT((S * S.transpose() - P).norm(), 1e-14);

  Eigen::MatrixXd Q(2, 2);
  Q << 4.0, 1.0, 1.0 + 1e-13, 2.0;  // slightly asymmetric: symmetrised, Cholesky works
  const Eigen::MatrixXd L = covariance_sqrt(Q, &fallback);
  EXPECT_FALSE(fallback);
  EXPECT_NEAR(L(0, 1), 0.0, 0.0);
  EXPECT_LT((L * L.transpose() - 0.5 * (Q + Q.transpose())).norm(), 1e-14);
}

TEST(SigmaPoints, InvalidOptionsAreRejectedWithAMessage) {
  EXPECT_FALSE((SigmaOptions{SigmaRule::kStar, -3.0}).validate(2).empty());
  EXPECT_FALSE((SigmaOptions{SigmaRule::kScaled, 0.0, 0.0, 2.0}).validate(2).empty());
  EXPECT_FALSE((SigmaOptions{}).validate(0).empty());
  EXPECT_THROW(make_sigma_points(2, {SigmaRule::kStar, -3.0}), std::invalid_argument);
  EXPECT_EQ(parse_sigma_rule("scaled"), SigmaRule::kScaled);
}

}  // namespace
}  // namespace sigmaheart::estimation
