#include "estimation/sensitivity/sobol_sequence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

namespace sh = sigmaheart::estimation::sensitivity;

namespace {

sh::SobolSequence make(int d, sh::Scrambling s, std::uint64_t seed = 7) {
  sh::SobolSequenceOptions o;
  o.dimension = d;
  o.scrambling = s;
  o.seed = seed;
  return sh::SobolSequence(o);
}

// True when each of the 2^k intervals [j/2^k, (j+1)/2^k) holds exactly one of the 2^k values.
bool one_per_interval(const Eigen::VectorXd& x) {
  const auto n = static_cast<int>(x.size());
  std::vector<int> count(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i) {
    const int j = static_cast<int>(std::floor(x(i) * n));
    if (j < 0 || j >= n) return false;
    ++count[static_cast<size_t>(j)];
  }
  for (int c : count) {
    if (c != 1) return false;
  }
  return true;
}

}  // namespace

TEST(SobolSequence, FirstPointsMatchThePublishedUnscrambledSequence) {
  // Gray-code order (Antonov-Saleev), the order of Joe & Kuo's own generator:
  // (0,0,0), (1/2,1/2,1/2), (3/4,1/4,1/4), (1/4,3/4,3/4), (3/8,3/8,5/8), (7/8,7/8,1/8).
  const auto seq = make(3, sh::Scrambling::kNone);
  const Eigen::MatrixXd P = seq.points(0, 6);
  Eigen::MatrixXd expected(6, 3);
  expected << 0, 0, 0,  //
      0.5, 0.5, 0.5,    //
      0.75, 0.25, 0.25, //
      0.25, 0.75, 0.75, //
      0.375, 0.375, 0.625, //
      0.875, 0.875, 0.125;
  EXPECT_LT((P - expected).cwiseAbs().maxCoeff(), 1e-15) << P;
}

TEST(SobolSequence, JoeKuoTableHasOddInitialNumbersBelowTwoToTheK) {
  for (int d = 2; d <= sh::kMaxSobolDimension; ++d) {
    const auto e = sh::joe_kuo_entry(d);
    ASSERT_EQ(static_cast<int>(e.m.size()), e.s) << "dimension " << d;
    EXPECT_LT(e.a, 1u << (e.s - 1)) << "dimension " << d;
    for (int k = 0; k < e.s; ++k) {
      EXPECT_EQ(e.m[static_cast<size_t>(k)] % 2, 1u) << "dimension " << d << " k " << k + 1;
      EXPECT_LT(e.m[static_cast<size_t>(k)], 1u << (k + 1)) << "dimension " << d;
    }
  }
}

TEST(SobolSequence, EveryCoordinateOfAPowerOfTwoPrefixStratifiesTheUnitInterval) {
  for (auto s : {sh::Scrambling::kNone, sh::Scrambling::kLinearMatrixAndShift}) {
    const auto seq = make(40, s);
    for (int n : {16, 256, 1024}) {
      const Eigen::MatrixXd P = seq.points(0, static_cast<std::uint64_t>(n));
      for (int j = 0; j < 40; ++j) {
        EXPECT_TRUE(one_per_interval(P.col(j))) << "n " << n << " dim " << j << " " << to_string(s);
      }
    }
  }
}

TEST(SobolSequence, FirstTwoCoordinatesFormAZeroQualityNetEvenWhenScrambled) {
  // Dimensions 1 and 2 of Sobol' are a (0, m, 2)-net: every elementary box of area 2^-m with
  // sides 2^-a x 2^-(m-a) holds exactly one of the first 2^m points.
  for (auto s : {sh::Scrambling::kNone, sh::Scrambling::kLinearMatrixAndShift}) {
    const auto seq = make(2, s, 11);
    const int m = 8, n = 1 << m;
    const Eigen::MatrixXd P = seq.points(0, n);
    for (int a = 0; a <= m; ++a) {
      std::set<std::pair<int, int>> boxes;
      for (int i = 0; i < n; ++i) {
        boxes.insert({static_cast<int>(P(i, 0) * (1 << a)), static_cast<int>(P(i, 1) * (1 << (m - a)))});
      }
      EXPECT_EQ(static_cast<int>(boxes.size()), n) << "a " << a << " " << to_string(s);
    }
  }
}

TEST(SobolSequence, ScrambledPointsAreReproducibleAndDependOnTheSeed) {
  const auto a = make(6, sh::Scrambling::kLinearMatrixAndShift, 3);
  const auto b = make(6, sh::Scrambling::kLinearMatrixAndShift, 3);
  const auto c = make(6, sh::Scrambling::kLinearMatrixAndShift, 4);
  const Eigen::MatrixXd Pa = a.points(0, 64), Pb = b.points(0, 64), Pc = c.points(0, 64);
  EXPECT_EQ((Pa - Pb).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT((Pa - Pc).cwiseAbs().maxCoeff(), 0.01);
  // Points computed from their index equal the block computation.
  std::vector<double> x(6);
  a.point(37, x.data());
  for (int j = 0; j < 6; ++j) EXPECT_EQ(x[static_cast<size_t>(j)], Pa(37, j));
  // Coordinate j's scramble does not depend on the dimension.
  const auto wide = make(12, sh::Scrambling::kLinearMatrixAndShift, 3);
  EXPECT_EQ((wide.points(0, 64).leftCols(6) - Pa).cwiseAbs().maxCoeff(), 0.0);
}

TEST(SobolSequence, IntegratesASmoothProductFasterThanOneOverSqrtN) {
  // f(x) = prod_j (1 + 2 (x_j - 1/2)^2) in d = 10, exact mean (7/6)^10: the quasi-Monte Carlo
  // error is well under a tenth of the Monte Carlo scale mean / sqrt(N).
  const auto seq = make(10, sh::Scrambling::kLinearMatrixAndShift, 5);
  const int n = 4096;
  const Eigen::MatrixXd P = seq.points(0, n);
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += (1.0 + (P.row(i).array() - 0.5) * 2.0 * (P.row(i).array() - 0.5)).prod();
  // Exact mean of 1 + 2 (x - 1/2)^2 is 1 + 1/6 per coordinate.
  const double exact = std::pow(1.0 + 1.0 / 6.0, 10);
  EXPECT_NEAR(sum / n, exact, 0.1 * exact / std::sqrt(static_cast<double>(n)));
}

TEST(SobolSequence, RejectsDimensionsBeyondTheTable) {
  sh::SobolSequenceOptions o;
  o.dimension = sh::kMaxSobolDimension + 1;
  EXPECT_FALSE(o.validate().empty());
  EXPECT_THROW(sh::SobolSequence{o}, std::invalid_argument);
}
