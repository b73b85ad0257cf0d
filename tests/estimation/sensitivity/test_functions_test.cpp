#include "estimation/sensitivity/test_functions.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace sh = sigmaheart::estimation::sensitivity;

TEST(TestFunctions, ExactIshigamiFormulasGiveThePublishedValues) {
  const auto e = sh::ishigami_exact(7.0, 0.1);
  EXPECT_NEAR(e.S1(0), 0.3139, 5e-5);
  EXPECT_NEAR(e.S1(1), 0.4424, 5e-5);
  EXPECT_NEAR(e.S1(2), 0.0, 1e-15);
  EXPECT_NEAR(e.ST(0), 0.5576, 5e-5);
  EXPECT_NEAR(e.ST(1), 0.4424, 5e-5);
  EXPECT_NEAR(e.ST(2), 0.2437, 5e-5);
}

TEST(TestFunctions, ExactGFunctionFormulasGiveThePublishedValues) {
  const auto e = sh::g_function_exact(sh::g_function_default_a());
  const double S1[] = {0.7162, 0.1790, 0.0237, 0.0072, 0.0001, 0.0001, 0.0001, 0.0001};
  const double ST[] = {0.7871, 0.2422, 0.0343, 0.0105, 0.0001, 0.0001, 0.0001, 0.0001};
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(e.S1(i), S1[i], 5e-5) << i;
    EXPECT_NEAR(e.ST(i), ST[i], 5e-5) << i;
  }
}

TEST(TestFunctions, ModelsEvaluateToTheirFormulas) {
  sh::IshigamiModel ishigami(7.0, 0.1);
  Eigen::VectorXd z(1);
  // x = (pi/2, pi/2, 2): 1 + 7 + 0.1 * 16 * 1 = 9.6.
  ASSERT_TRUE(ishigami.evaluate(Eigen::Vector3d(std::numbers::pi / 2, std::numbers::pi / 2, 2.0), z).ok());
  EXPECT_NEAR(z(0), 9.6, 1e-12);
  sh::GFunctionModel g(Eigen::Vector2d(0.0, 1.0));
  // x = (0, 0.5): (|0 - 2| + 0)/1 * (|2 - 2| + 1)/2 = 2 * 0.5 = 1.
  ASSERT_TRUE(g.evaluate(Eigen::Vector2d(0.0, 0.5), z).ok());
  EXPECT_NEAR(z(0), 1.0, 1e-15);
  EXPECT_FALSE(g.evaluate(Eigen::Vector3d(0.0, 0.5, 0.1), z).ok());  // wrong size is a Status
  EXPECT_THROW(sh::GFunctionModel(Eigen::Vector2d(-1.0, 0.0)), std::invalid_argument);
}

TEST(TestFunctions, ExactIndicesOfAnAdditiveGFunctionSumToOne) {
  // With a single input S1 = ST = 1. With five a_i = 50, V_i = 1/(3 * 51^2) = 1.2816e-4 and the
  // interactions carry 1 - 5 V_i / ((1 + V_i)^5 - 1) = 2.563e-4 of the variance.
  const auto one = sh::g_function_exact(Eigen::VectorXd::Constant(1, 2.0));
  EXPECT_NEAR(one.S1(0), 1.0, 1e-14);
  EXPECT_NEAR(one.ST(0), 1.0, 1e-14);
  const auto e = sh::g_function_exact(Eigen::VectorXd::Constant(5, 50.0));
  EXPECT_NEAR(1.0 - e.S1.sum(), 2.563e-4, 1e-6);
  EXPECT_GE(e.ST.sum(), e.S1.sum());
}
