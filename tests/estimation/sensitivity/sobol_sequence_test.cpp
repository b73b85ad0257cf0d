#include "estimation/sensitivity/sobol_sequence.h"

#include <boost/random/sobol.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <set>
#include <sstream>
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

// ---------------------------------------------------------------------------------------------
// An independent reference generator, written from the published recurrence and not from
// estimation/sensitivity/sobol_sequence.cpp: it works on the integers m_k (Bratley & Fox 1988,
// ACM TOMS 14:88, eq. 2; Joe & Kuo 2008, SIAM J Sci Comput 30:2635, section 2) where the
// production code shifts 32-bit direction numbers, and it produces points in natural order
// (the production code uses the Gray-code order of Antonov & Saleev 1979).
//
// For the primitive polynomial x^s + a_1 x^(s-1) + ... + a_(s-1) x + 1 over GF(2),
//   m_k = 2 a_1 m_(k-1) ^ 2^2 a_2 m_(k-2) ^ ... ^ 2^(s-1) a_(s-1) m_(k-s+1) ^ 2^s m_(k-s) ^ m_(k-s),
// the direction numbers are v_k = m_k / 2^k and point i (natural order) is the XOR of the v_k of
// the set bits k of i.
//
// The rows of Joe & Kuo's table "new-joe-kuo-6.21201" for dimensions 2..53, each as
// "s a m_1 ... m_s" (a holds a_1 .. a_(s-1), a_1 the most significant bit), typed from the
// published file. These were the generator's own table until it read Boost.Random's copy of the
// full table; they stay here as the independent check that the first 53 dimensions are unchanged.
const char* const kJoeKuoRows[] = {
    "1 0 1", "2 1 1 3", "3 1 1 3 1", "3 2 1 1 1", "4 1 1 1 3 3", "4 4 1 3 5 13",
    "5 2 1 1 5 5 17", "5 4 1 1 5 5 5", "5 7 1 1 7 11 19", "5 11 1 1 5 1 1", "5 13 1 1 1 3 11",
    "5 14 1 3 5 5 31", "6 1 1 3 3 9 7 49", "6 13 1 1 1 15 21 21", "6 16 1 3 1 13 27 49",
    "6 19 1 1 1 15 7 5", "6 22 1 3 1 15 13 25", "6 25 1 1 5 5 19 61", "7 1 1 3 7 11 23 15 103",
    "7 4 1 3 7 13 13 15 69", "7 7 1 1 3 13 7 35 63", "7 8 1 3 5 9 1 25 53",
    "7 14 1 3 1 13 9 35 107", "7 19 1 3 1 5 27 61 31", "7 21 1 1 5 11 19 41 61",
    "7 28 1 3 5 3 3 13 69", "7 31 1 1 7 13 1 19 1", "7 32 1 3 7 5 13 19 59",
    "7 37 1 1 3 9 25 29 41", "7 41 1 3 5 13 23 1 55", "7 42 1 3 7 3 13 59 17",
    "7 50 1 3 1 3 5 53 69", "7 55 1 1 5 5 23 33 13", "7 56 1 1 7 7 1 61 123",
    "7 59 1 1 7 9 13 61 49", "7 62 1 3 3 5 3 55 33", "8 14 1 3 1 15 31 13 49 245",
    "8 21 1 3 5 15 31 59 63 97", "8 22 1 3 1 11 11 11 77 249", "8 38 1 3 1 11 27 43 71 9",
    "8 47 1 1 7 15 21 11 81 45", "8 49 1 3 7 3 25 31 65 79", "8 50 1 3 1 1 19 11 3 205",
    "8 52 1 1 5 9 19 21 29 157", "8 56 1 3 7 11 1 33 89 185", "8 67 1 3 3 3 15 9 79 71",
    "8 70 1 3 7 11 15 39 119 27", "8 84 1 1 3 1 11 31 97 225", "8 97 1 1 1 3 23 43 57 177",
    "8 103 1 3 7 7 17 17 37 71", "8 115 1 3 1 5 27 63 123 213", "8 122 1 1 3 5 11 43 53 133",
};
constexpr int kReferenceDimensions = 1 + static_cast<int>(std::size(kJoeKuoRows));  // 53
constexpr int kBits = 32;  // the production generator's precision: points are multiples of 2^-32

struct ReferenceRow {
  int s = 0;
  std::uint64_t a = 0;
  std::vector<std::uint64_t> m;
};

ReferenceRow reference_row(int d) {  // d = 2..53
  std::istringstream in(kJoeKuoRows[d - 2]);
  ReferenceRow r;
  in >> r.s >> r.a;
  r.m.resize(static_cast<size_t>(r.s));
  for (auto& mk : r.m) in >> mk;
  return r;
}

// m_1 .. m_kBits of dimension d (1 is van der Corput: every m_k = 1).
std::vector<std::uint64_t> reference_m(int d) {
  std::vector<std::uint64_t> m(kBits + 1, 1);  // m[k], k = 1..kBits; m[0] unused
  if (d == 1) return m;
  const ReferenceRow r = reference_row(d);
  for (int k = 1; k <= r.s; ++k) m[static_cast<size_t>(k)] = r.m[static_cast<size_t>(k - 1)];
  for (int k = r.s + 1; k <= kBits; ++k) {
    std::uint64_t mk = (m[static_cast<size_t>(k - r.s)] << r.s) ^ m[static_cast<size_t>(k - r.s)];
    for (int l = 1; l < r.s; ++l) {
      const std::uint64_t a_l = (r.a >> (r.s - 1 - l)) & 1u;
      if (a_l) mk ^= m[static_cast<size_t>(k - l)] << l;
    }
    m[static_cast<size_t>(k)] = mk;
  }
  return m;
}

// Coordinate of dimension d of point i in natural order, as an integer numerator over 2^kBits.
std::uint64_t reference_numerator(const std::vector<std::uint64_t>& m, std::uint64_t i) {
  std::uint64_t x = 0;
  for (int k = 1; i != 0; ++k, i >>= 1) {
    if (i & 1u) x ^= m[static_cast<size_t>(k)] << (kBits - k);  // v_k = m_k 2^-k
  }
  return x;
}

// Order of x modulo the GF(2) polynomial p (bit j = coefficient of x^j) of degree s: p is
// primitive iff it is 2^s - 1.
std::uint64_t order_of_x(std::uint64_t p, int s) {
  std::uint64_t r = 1;
  for (std::uint64_t n = 1; n <= (1u << s); ++n) {
    r <<= 1;
    if (r >> s & 1u) r ^= p;
    if (r == 1) return n;
  }
  return 0;
}

}  // namespace

// The first 53 dimensions (the generator's own table before it read Boost's), not only the first
// three: the first 4096 unscrambled points equal the reference generator's, taken in Gray-code
// order (point i is the natural-order point i ^ (i >> 1)). Both are exact binary fractions, so
// they must agree to the last bit.
TEST(SobolSequence, First53DimensionsMatchAnIndependentJoeKuoReferenceGenerator) {
  const int d_max = kReferenceDimensions;
  ASSERT_EQ(d_max, 53);
  const auto seq = make(d_max, sh::Scrambling::kNone);
  const int n = 4096;
  const Eigen::MatrixXd P = seq.points(0, n);
  for (int d = 1; d <= d_max; ++d) {
    const std::vector<std::uint64_t> m = reference_m(d);
    int mismatches = 0;
    for (std::uint64_t i = 0; i < static_cast<std::uint64_t>(n); ++i) {
      const double expected = std::ldexp(static_cast<double>(reference_numerator(m, i ^ (i >> 1))),
                                         -kBits);
      if (P(static_cast<Eigen::Index>(i), d - 1) != expected && mismatches++ < 3) {
        ADD_FAILURE() << "dimension " << d << " point " << i << ": " << P(static_cast<Eigen::Index>(i), d - 1)
                      << " != " << expected;
      }
    }
    EXPECT_EQ(mismatches, 0) << "dimension " << d;
  }
  // Hand check of the recurrence on dimension 3 (x^2 + x + 1, m = 1, 3): m_3 = 2 m_2 ^ 4 m_1 ^
  // m_1 = 6 ^ 4 ^ 1 = 3 and m_4 = 2 m_3 ^ 4 m_2 ^ m_2 = 6 ^ 12 ^ 3 = 9.
  EXPECT_EQ(reference_m(3)[3], 3u);
  EXPECT_EQ(reference_m(3)[4], 9u);
}

// Every polynomial of the table (all 3667 dimensions, read from Boost) is primitive over GF(2)
// (the Sobol' construction requires it) and no two dimensions share one (which would repeat a
// coordinate); the first 53 rows equal the typed reference rows above.
TEST(SobolSequence, EveryTabulatedPolynomialIsPrimitiveAndDistinctAndTheFirst53AreUnchanged) {
  ASSERT_EQ(sh::kMaxSobolDimension, 3667);
  std::set<std::uint64_t> seen;
  for (int d = 2; d <= sh::kMaxSobolDimension; ++d) {
    const auto e = sh::joe_kuo_entry(d);
    const std::uint64_t p = (std::uint64_t{1} << e.s) | (std::uint64_t{e.a} << 1) | 1u;  // x^s + ... + 1
    EXPECT_EQ(order_of_x(p, e.s), (std::uint64_t{1} << e.s) - 1u) << "dimension " << d << " polynomial " << p;
    EXPECT_TRUE(seen.insert(p).second) << "dimension " << d << " repeats polynomial " << p;
    if (d > kReferenceDimensions) continue;
    const ReferenceRow r = reference_row(d);
    EXPECT_EQ(e.s, r.s) << "dimension " << d;
    EXPECT_EQ(e.a, r.a) << "dimension " << d;
    EXPECT_EQ(std::vector<std::uint64_t>(e.m.begin(), e.m.end()), r.m) << "dimension " << d;
  }
  // The last polynomial of Boost's table has degree 15 (it is below 2^16).
  EXPECT_EQ(sh::joe_kuo_entry(sh::kMaxSobolDimension).s, 15);
}

// Every aligned block of 2^k consecutive points (not only the prefix) is a (t, k, s)-net, so in
// every one-dimensional projection each of the 2^k intervals [j 2^-k, (j + 1) 2^-k) holds exactly
// one point; scrambled or not, in every dimension.
TEST(SobolSequence, EveryAlignedPowerOfTwoBlockStratifiesEveryCoordinate) {
  const int d_max = sh::kMaxSobolDimension;
  for (auto s : {sh::Scrambling::kNone, sh::Scrambling::kLinearMatrixAndShift}) {
    const auto seq = make(d_max, s);
    const Eigen::MatrixXd P = seq.points(0, 2048);
    for (int k : {1, 4, 8, 11}) {
      const int block = 1 << k;
      for (int first = 0; first + block <= P.rows(); first += block) {
        for (int j = 0; j < d_max; ++j) {
          EXPECT_TRUE(one_per_interval(P.col(j).segment(first, block)))
              << to_string(s) << " block of " << block << " at " << first << ", dimension " << j + 1;
        }
      }
    }
  }
}

// No two coordinates repeat each other: the columns of the first 1024 points are pairwise
// distinct in all 3667 dimensions (identical direction numbers would give identical columns).
TEST(SobolSequence, AllDimensionsDiffer) {
  const int d_max = sh::kMaxSobolDimension;
  const Eigen::MatrixXd P = make(d_max, sh::Scrambling::kNone).points(0, 1024);
  std::set<std::vector<double>> columns;
  for (int a = 0; a < d_max; ++a) {
    const Eigen::VectorXd c = P.col(a);
    EXPECT_TRUE(columns.insert(std::vector<double>(c.data(), c.data() + c.size())).second)
        << "dimension " << a + 1 << " repeats an earlier one";
  }
}

// Every one of the 3667 dimensions against Boost.Random's own generator on the same table
// (boost::random::sobol_engine, Gray-code order, which starts at point 1: it skips the origin):
// the direction-number recurrence and the indexed point(i) agree with an independent
// implementation to the last of the 32 bits.
TEST(SobolSequence, EveryDimensionMatchesBoostsSobolEngine) {
  const int d = sh::kMaxSobolDimension;
  const auto seq = make(d, sh::Scrambling::kNone);
  boost::random::sobol_engine<std::uint32_t, 32> boost_engine(static_cast<std::size_t>(d));
  std::vector<double> x(static_cast<size_t>(d));
  int mismatches = 0;
  for (std::uint64_t i = 1; i <= 256; ++i) {
    seq.point(i, x.data());
    for (int j = 0; j < d; ++j) {
      const std::uint32_t expected = boost_engine();
      const auto ours = static_cast<std::uint32_t>(std::ldexp(x[static_cast<size_t>(j)], 32));
      if (ours != expected && mismatches++ < 5) {
        ADD_FAILURE() << "point " << i << " dimension " << j + 1 << ": " << ours << " != " << expected;
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
}

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
