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

// The 15 p-values of Benjamini & Hochberg 1995 (J R Stat Soc B 57:289, s.4.2). Adjusted by hand:
// BH p~_(i) = min_{j >= i} 15 p_(j) / j; Holm p~_(i) = max_{j <= i} (16 - j) p_(j), capped at 1.
// The paper: at level 0.05 the FDR procedure rejects the 4 smallest, Bonferroni 3 (Holm too).
const Eigen::VectorXd& bh1995() {
  static const Eigen::VectorXd p = vec({0.0201, 0.0001, 0.0278, 0.0004, 0.0298, 0.0019, 0.0344, 0.0095,
                                        0.0459, 0.3240, 0.4262, 0.5719, 0.6528, 0.7590, 1.0000});
  return p;  // deliberately not sorted: the adjustment must keep the input order
}

TEST(Statistics, BenjaminiHochbergMatchesThe1995Example) {
  const Eigen::VectorXd q = sp::adjust_p_values(bh1995(), sp::PAdjust::kBenjaminiHochberg);
  const Eigen::VectorXd expected =
      vec({0.0603, 0.0015, 15 * 0.0298 / 7, 0.003, 15 * 0.0298 / 7, 0.0095, 0.0645, 0.035625, 0.0765,
           0.486, 15 * 0.4262 / 11, 15 * 0.5719 / 12, 15 * 0.6528 / 13, 15 * 0.7590 / 14, 1.0});
  for (Eigen::Index i = 0; i < 15; ++i) EXPECT_NEAR(q(i), expected(i), 1e-12) << i;
  EXPECT_EQ((q.array() < 0.05).count(), 4);
}

TEST(Statistics, HolmMatchesTheStepDownByHand) {
  const Eigen::VectorXd q = sp::adjust_p_values(bh1995(), sp::PAdjust::kHolm);
  // Sorted: 15 x 0.0001, 14 x 0.0004, 13 x 0.0019, 12 x 0.0095, 11 x 0.0201, 10 x 0.0278, then the
  // running maximum holds 0.278 over 9 x 0.0298 and 8 x 0.0344, 7 x 0.0459 = 0.3213, then 1.
  const Eigen::VectorXd expected =
      vec({0.2211, 0.0015, 0.278, 0.0056, 0.278, 0.0247, 0.278, 0.114, 0.3213, 1, 1, 1, 1, 1, 1});
  for (Eigen::Index i = 0; i < 15; ++i) EXPECT_NEAR(q(i), expected(i), 1e-12) << i;
  EXPECT_EQ((q.array() < 0.05).count(), 3);
}

TEST(Statistics, AdjustmentSkipsNaNAndLeavesOneTestAlone) {
  const Eigen::VectorXd q = sp::adjust_p_values(vec({0.01, NAN, 0.04}), sp::PAdjust::kHolm);
  EXPECT_NEAR(q(0), 0.02, 1e-15);  // m = 2
  EXPECT_TRUE(std::isnan(q(1)));
  EXPECT_NEAR(q(2), 0.04, 1e-15);
  const Eigen::VectorXd one = sp::adjust_p_values(vec({0.03}), sp::PAdjust::kBenjaminiHochberg);
  EXPECT_DOUBLE_EQ(one(0), 0.03);
}

TEST(Statistics, PosteriorWelchIsWelchWithoutPosteriorSpread) {
  const Eigen::VectorXd x = vec({1.1, 2.3, 2.9, 4.2, 3.3}), y = vec({4.0, 5.5, 6.1, 5.2});
  const auto w = sp::welch_t_test(x, y);
  const auto v = sp::posterior_welch_test(x, Eigen::VectorXd::Zero(5), y, vec({NAN, 0, 0, 0}));
  EXPECT_NEAR(v.t, w.t, 1e-12);
  EXPECT_NEAR(v.df, w.df, 1e-12);
  EXPECT_NEAR(v.p_value, w.p_value, 1e-12);
}

TEST(Statistics, PosteriorWelchAddsEachSubjectsPosteriorVariance) {
  // x = (1, 2, 3), y = (4, 5, 6), every posterior sd 1. tau^2 = 1 in each group, so each subject
  // has variance 2, weight 1/2, V = 1 / 1.5 = 2/3; t = -3 / sqrt(4/3) = -2.5980762,
  // df = (4/3)^2 / (2 (2/3)^2 / 2) = 4; with df = 4, P(T <= t) = 1/2 + 3/8 u (1 - u^2/12) with
  // u = t / sqrt(1 + t^2/4): p = 0.0601698 (plain Welch: t = -3.6742346, p = 0.0213116).
  const Eigen::VectorXd x = vec({1, 2, 3}), y = vec({4, 5, 6}), one = Eigen::VectorXd::Ones(3);
  const auto v = sp::posterior_welch_test(x, one, y, one);
  EXPECT_NEAR(v.t, -2.5980762, 1e-7);
  EXPECT_NEAR(v.df, 4.0, 1e-12);
  EXPECT_NEAR(v.mean_difference, -3.0, 1e-12);
  EXPECT_NEAR(v.p_value, 0.0601698, 1e-7);
  EXPECT_NEAR(sp::welch_t_test(x, y).p_value, 0.0213116, 1e-7);
  // Unequal posterior spread: the precise subject weighs more. x: v = (1 + 0, 1 + 9, 1 + 0).
  const auto u = sp::posterior_welch_test(x, vec({0, 3, 0}), y, Eigen::VectorXd::Zero(3));
  EXPECT_NEAR(u.mean_difference, 2.0 - 5.0, 1e-12);  // symmetric weights keep the mean at 2
  EXPECT_NEAR(u.t, -3.0 / std::sqrt(1.0 / 2.1 + 1.0 / 3.0), 1e-12);
}

TEST(Statistics, LargePosteriorSpreadMakesADifferenceNonSignificant) {
  // Two groups 2.8 between-subject sds apart (sd 0.0717): different on the posterior means alone
  // (Welch t = 4.83, df 10, p = 6.5e-4), but not when every subject's posterior sd is 5 times the
  // between-subject sd (t = 0.2 / sqrt(2 x 26 tau^2 / 6) = 0.95).
  const Eigen::VectorXd x = vec({0.9, 1.1, 1.0, 0.95, 1.05, 1.02}), y = x.array() + 0.2;
  const double tau = std::sqrt((x.array() - x.mean()).square().sum() / 5.0);
  EXPECT_NEAR(sp::welch_t_test(x, y).p_value, 6.5e-4, 0.1e-4);
  const Eigen::VectorXd sd = Eigen::VectorXd::Constant(6, 5.0 * tau);
  const auto v = sp::posterior_welch_test(x, sd, y, sd);
  EXPECT_NEAR(v.t, -0.2 / std::sqrt(2.0 * 26.0 * tau * tau / 6.0), 1e-12);
  EXPECT_GT(v.p_value, 0.3);
}

TEST(Statistics, AucDirectionSaysWhichWayGroupBLies) {
  // B = (3, 5, 7) over A = (1, 2, 3, 4) by hand: 3 beats 1 and 2 and ties 3 (2.5 pairs), 5 and 7
  // beat all four: U = 10.5 of 12, AUC(B > A) = 0.875 = 1 - AUC(A > B).
  const auto r = sp::mann_whitney(vec({3, 5, 7}), vec({1, 2, 3, 4}));
  EXPECT_DOUBLE_EQ(r.U, 10.5);
  EXPECT_DOUBLE_EQ(r.auc, 0.875);
  EXPECT_EQ(sp::auc_direction(r.auc), "higher");
  EXPECT_EQ(sp::auc_direction(1.0 - r.auc), "lower");
  EXPECT_EQ(sp::auc_direction(0.5), "none");
}
