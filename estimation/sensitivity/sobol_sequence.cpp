#include "estimation/sensitivity/sobol_sequence.h"

#include "estimation/sensitivity/design.h"
#include "estimation/enum_names.h"

#include <boost/random/sobol.hpp>

#include <array>
#include <bit>
#include <stdexcept>

namespace sigmaheart::estimation::sensitivity {

namespace {

// Joe & Kuo (2008), direction numbers "new-joe-kuo-6.21201" (search criterion D(6)), as Boost.Random
// ships them (boost/random/detail/sobol_table.hpp, the table of boost::random::sobol, cut at the
// 3667 polynomials below 2^16): polynomial(n) is the whole primitive polynomial of dimension n + 2
// (bit j = coefficient of x^j, so both end bits are set) and minit(n, k) its initial direction
// integer m_(k+1). The table is read through Boost's accessors, never copied into this tree.
using BoostSobolTable = boost::random::default_sobol_table;
static_assert(BoostSobolTable::max_dimension == static_cast<unsigned>(kMaxSobolDimension));

// Direction numbers v_k = m_k 2^(32-k), k = 1..32, of coordinate d (1-based), by the recurrence
// of Bratley & Fox (1988, ACM TOMS 14:88, eq. 2) as written in Joe & Kuo (2003, ACM TOMS 29:49):
// v_k = v_{k-s} xor (v_{k-s} >> s) xor sum_{l=1}^{s-1} a_l v_{k-l}.
std::array<std::uint32_t, 32> direction_numbers(int d) {
  std::array<std::uint32_t, 32> v{};
  if (d == 1) {
    for (int k = 0; k < 32; ++k) v[static_cast<size_t>(k)] = 1u << (31 - k);
    return v;
  }
  const JoeKuoEntry row = joe_kuo_entry(d);
  const int s = row.s;
  for (int k = 0; k < 32; ++k) {
    if (k < s) {
      v[static_cast<size_t>(k)] = row.m[static_cast<size_t>(k)] << (31 - k);
      continue;
    }
    std::uint32_t x = v[static_cast<size_t>(k - s)];
    x ^= x >> s;
    for (int l = 1; l < s; ++l) {
      if ((row.a >> (s - 1 - l)) & 1u) x ^= v[static_cast<size_t>(k - l)];
    }
    v[static_cast<size_t>(k)] = x;
  }
  return v;
}

// Matousek's (1998) linear scramble of one coordinate: y = L x over GF(2) on the binary digits,
// L lower-triangular with unit diagonal and uniform random entries below it (digit 1 is the most
// significant bit). Row r of L is stored as a mask over the input bits.
std::array<std::uint32_t, 32> random_lower_triangular(std::mt19937_64& rng) {
  std::array<std::uint32_t, 32> rows{};
  for (int r = 0; r < 32; ++r) {
    const std::uint32_t own = 1u << (31 - r);
    // Bits more significant than `own` are the earlier digits.
    const std::uint32_t above = r == 0 ? 0u : ~((own << 1) - 1u);
    rows[static_cast<size_t>(r)] = (static_cast<std::uint32_t>(rng() >> 32) & above) | own;
  }
  return rows;
}

std::uint32_t apply(const std::array<std::uint32_t, 32>& rows, std::uint32_t x) {
  std::uint32_t y = 0;
  for (int r = 0; r < 32; ++r) {
    if (std::popcount(rows[static_cast<size_t>(r)] & x) & 1) y |= 1u << (31 - r);
  }
  return y;
}

}  // namespace

SIGMAHEART_ENUM_TEXT(Scrambling, parse_scrambling,
    {Scrambling::kNone, "none"}, {Scrambling::kLinearMatrixAndShift, "lms"},
    {Scrambling::kNone, "off"}, {Scrambling::kLinearMatrixAndShift, "matousek"},
    {Scrambling::kLinearMatrixAndShift, "linear-matrix-shift"})

std::string SobolSequenceOptions::validate() const {
  if (dimension < 1 || dimension > kMaxSobolDimension) {
    return "Sobol' sequence dimension must be in [1, " + std::to_string(kMaxSobolDimension) +
           "], got " + std::to_string(dimension);
  }
  return {};
}

SobolSequence::SobolSequence(const SobolSequenceOptions& options) : dimension_(options.dimension) {
  if (const std::string m = options.validate(); !m.empty()) throw std::invalid_argument(m);
  v_.resize(static_cast<size_t>(dimension_));
  shift_.assign(static_cast<size_t>(dimension_), 0u);
  for (int j = 0; j < dimension_; ++j) {
    auto v = direction_numbers(j + 1);
    if (options.scrambling == Scrambling::kLinearMatrixAndShift) {
      // Stream j of the seed: the scramble of coordinate j does not depend on the dimension.
      std::mt19937_64 rng = make_stream(options.seed, static_cast<std::uint64_t>(j));
      const auto L = random_lower_triangular(rng);
      for (auto& vk : v) vk = apply(L, vk);  // L (xor of v) = xor of (L v)
      shift_[static_cast<size_t>(j)] = static_cast<std::uint32_t>(rng() >> 32);
    }
    v_[static_cast<size_t>(j)] = v;
  }
}

void SobolSequence::point(std::uint64_t index, double* out) const {
  if (index >> 32) throw std::out_of_range("Sobol' point index beyond 2^32");
  const std::uint64_t gray = index ^ (index >> 1);
  constexpr double kScale = 1.0 / 4294967296.0;  // 2^-32
  for (int j = 0; j < dimension_; ++j) {
    const auto& v = v_[static_cast<size_t>(j)];
    std::uint32_t x = shift_[static_cast<size_t>(j)];
    for (std::uint64_t g = gray; g != 0; g &= g - 1) {
      x ^= v[static_cast<size_t>(std::countr_zero(g))];
    }
    out[j] = static_cast<double>(x) * kScale;
  }
}

Eigen::MatrixXd SobolSequence::points(std::uint64_t first, std::uint64_t n) const {
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> P(
      static_cast<Eigen::Index>(n), dimension_);
  for (std::uint64_t i = 0; i < n; ++i) point(first + i, P.row(static_cast<Eigen::Index>(i)).data());
  return P;
}

JoeKuoEntry joe_kuo_entry(int d) {
  if (d < 2 || d > kMaxSobolDimension) {
    throw std::out_of_range("Joe-Kuo table covers dimensions 2.." +
                            std::to_string(kMaxSobolDimension));
  }
  const auto n = static_cast<std::size_t>(d - 2);
  const unsigned poly = BoostSobolTable::polynomial(n);
  const int s = std::bit_width(poly) - 1;  // degree
  JoeKuoEntry e;
  e.s = s;
  // Joe & Kuo's a: the interior coefficients a_1..a_(s-1), a_1 (of x^(s-1)) the most significant.
  e.a = (poly >> 1) & ((1u << (s - 1)) - 1u);
  for (int k = 0; k < s; ++k) e.m.push_back(BoostSobolTable::minit(n, static_cast<std::size_t>(k)));
  return e;
}

bool is_power_of_two(std::uint64_t n) { return n != 0 && (n & (n - 1)) == 0; }

}  // namespace sigmaheart::estimation::sensitivity
