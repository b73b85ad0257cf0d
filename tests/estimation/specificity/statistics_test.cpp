#include "estimation/specificity/statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace sp = sigmaheart::estimation::specificity;

namespace {
Eigen::VectorXd vec(std::initializer_list<double> v) {
  Eigen::VectorXd x(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double d : v) x(i++) = d;
  return x;
}
}  // namespace

TEST(Statistics, IncompleteBetaMatchesClosedForms) {
  for (double x : {0.01, 0.2, 0.5, 0.77, 0.99}) {
    EXPECT_NEAR(sp::regularized_incomplete_beta(1.0, 1.0, x), x, 1e-14);
    EXPECT_NEAR(sp::regularized_incomplete_beta(3.0, 1.0, x), x * x * x, 1e-14);
    EXPECT_NEAR(sp::regularized_incomplete_beta(1.0, 4.5, x), 1.0 - std::pow(1.0 - x, 4.5), 1e-13);
    EXPECT_NEAR(sp::regularized_incomplete_beta(2.5, 7.0, x),
                1.0 - sp::regularized_incomplete_beta(7.0, 2.5, 1.0 - x), 1e-14);
  }
  EXPECT_NEAR(sp::regularized_incomplete_beta(17.3, 17.3, 0.5), 0.5, 1e-13);
  EXPECT_EQ(sp::regularized_incomplete_beta(2.0, 3.0, 0.0), 0.0);
  EXPECT_EQ(sp::regularized_incomplete_beta(2.0, 3.0, 1.0), 1.0);
}

TEST(Statistics, StudentTDistributionMatchesCauchyClosedFormsAndTables) {
  for (double t : {-5.0, -1.0, -0.3, 0.0, 0.4, 2.0, 30.0}) {
    // df = 1 is the Cauchy distribution; df = 2 has F(t) = 1/2 + t / (2 sqrt(2 + t^2)).
    EXPECT_NEAR(sp::student_t_cdf(t, 1.0), 0.5 + std::atan(t) / std::numbers::pi, 1e-13) << t;
    EXPECT_NEAR(sp::student_t_cdf(t, 2.0), 0.5 + t / (2.0 * std::sqrt(2.0 + t * t)), 1e-13) << t;
  }
  // Table quantiles t_{0.975}: df 3 -> 3.182446305, df 10 -> 2.228138852, df 30 -> 2.042272456.
  EXPECT_NEAR(sp::student_t_cdf(3.182446305, 3.0), 0.975, 1e-9);
  EXPECT_NEAR(sp::student_t_cdf(2.228138852, 10.0), 0.975, 1e-9);
  EXPECT_NEAR(sp::student_t_cdf(-2.042272456, 30.0), 0.025, 1e-9);
  // Large df tends to the normal: Phi(1.959963985) = 0.975.
  EXPECT_NEAR(sp::student_t_cdf(1.959963985, 1e7), 0.975, 1e-6);
  EXPECT_NEAR(sp::normal_cdf(1.959963985), 0.975, 1e-9);
}

TEST(Statistics, WelchTestAndEffectSizesMatchAHandComputation) {
  // x = (1, 2, 3, 4): mean 2.5, s^2 = 5/3.  y = (3, 5, 7): mean 5, s^2 = 4.
  // s_x^2/n_x = 5/12, s_y^2/n_y = 4/3, se^2 = 21/12 = 1.75, t = -2.5/sqrt(1.75) = -1.8898224.
  // df = 1.75^2 / ((5/12)^2/3 + (4/3)^2/2) = 3.0625 / 0.9467593 = 3.2347188.
  // p = 2 P(T_3.2347 > 1.8898) = 0.1484713 (numerical quadrature of the t density).
  // Pooled s^2 = (3 * 5/3 + 2 * 4)/5 = 2.6: Cohen d = -2.5/sqrt(2.6) = -1.5504342;
  // Hedges g = d (1 - 3/(4*7 - 9)) = d 16/19 = -1.3056288.
  const Eigen::VectorXd x = vec({1, 2, 3, 4}), y = vec({3, 5, 7});
  const auto w = sp::welch_t_test(x, y);
  EXPECT_NEAR(w.t, -1.8898224, 1e-7);
  EXPECT_NEAR(w.df, 3.2347188, 1e-7);
  EXPECT_NEAR(w.p_value, 0.1484713, 1e-6);
  EXPECT_NEAR(w.mean_difference, -2.5, 1e-15);
  const auto e = sp::effect_size(x, y);
  EXPECT_NEAR(e.cohen_d, -1.5504342, 1e-7);
  EXPECT_NEAR(e.hedges_g, -1.3056288, 1e-7);
  // Symmetric in the groups up to sign.
  const auto w2 = sp::welch_t_test(y, x);
  EXPECT_NEAR(w2.t, -w.t, 1e-14);
  EXPECT_NEAR(w2.p_value, w.p_value, 1e-14);
}

TEST(Statistics, MannWhitneyWithTiesUsesTheCorrectedNormalApproximation) {
  // x = (1, 2, 3, 4), y = (3, 5, 7): pairs x > y: (4 > 3) = 1; tie (3 = 3) = 1/2: U = 1.5,
  // AUC = 1.5 / 12 = 0.125. Pooled sample 1 2 3 3 4 5 7: one tie group of 2 (t^3 - t = 6).
  // var U = 12/12 (8 - 6/(7*6)) = 7.8571429; mean 6; |U - 6| - 1/2 = 4: z = -4/2.8030596 = -1.4270121,
  // p = erfc(1.4270121/sqrt 2) = 0.1535764.
  // Hanley-McNeil: Q1 = 0.125/1.875, Q2 = 2*0.015625/1.125,
  // SE^2 = (0.109375 + 3 (Q1 - 0.015625) + 2 (Q2 - 0.015625))/12: SE = 0.1545977.
  const auto r = sp::mann_whitney(vec({1, 2, 3, 4}), vec({3, 5, 7}));
  EXPECT_FALSE(r.exact);
  EXPECT_DOUBLE_EQ(r.U, 1.5);
  EXPECT_DOUBLE_EQ(r.auc, 0.125);
  EXPECT_NEAR(r.z, -1.4270121, 1e-7);
  EXPECT_NEAR(r.p_value, 0.1535764, 1e-7);
  EXPECT_NEAR(r.auc_se, 0.1545977, 1e-7);
}

TEST(Statistics, MannWhitneyWithoutTiesIsExactForSmallSamples) {
  // x = (1, 3, 8), y = (2, 4, 5, 6): U = (3 > 2) + (8 > all four) = 5. Under H0 the 35 orderings
  // give U = 0..12 with counts 1 1 2 3 4 4 5 4 4 3 2 1 1 (partitions of u into at most 3 parts
  // <= 4): P(U <= 5) = 15/35, P(U >= 5) = 24/35, p = 2 * 15/35 = 0.8571429.
  const auto r = sp::mann_whitney(vec({1, 3, 8}), vec({2, 4, 5, 6}));
  EXPECT_TRUE(r.exact);
  EXPECT_DOUBLE_EQ(r.U, 5.0);
  EXPECT_NEAR(r.p_value, 30.0 / 35.0, 1e-12);
  EXPECT_NEAR(r.auc, 5.0 / 12.0, 1e-15);
  // Complete separation x < y, n = (4, 3): P(U = 0) = 1/35, p = 2/35.
  const auto s = sp::mann_whitney(vec({1, 2, 3, 4}), vec({5, 6, 7}));
  EXPECT_DOUBLE_EQ(s.U, 0.0);
  EXPECT_DOUBLE_EQ(s.auc, 0.0);
  EXPECT_NEAR(s.p_value, 2.0 / 35.0, 1e-12);
}

TEST(Statistics, MannWhitneyExactAndNormalAgreeForModerateSamples) {
  // 15 vs 15 without ties: exact, and the normal approximation is within 0.01 of it.
  Eigen::VectorXd x(15), y(15);
  for (int i = 0; i < 15; ++i) {
    x(i) = 2.0 * i + 0.5 * (i % 3);
    y(i) = 2.0 * i + 3.1 + 0.01 * i;
  }
  const auto r = sp::mann_whitney(x, y);
  ASSERT_TRUE(r.exact);
  // Normal approximation by hand from U.
  const double mu = 112.5, sd = std::sqrt(15.0 * 15.0 * 31.0 / 12.0);
  const double z = (std::abs(r.U - mu) - 0.5) / sd;
  EXPECT_NEAR(r.p_value, std::erfc(z / std::sqrt(2.0)), 0.01);
}
