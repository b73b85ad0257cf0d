#include "estimation/sensitivity/sobol_sequence.h"

#include "estimation/sensitivity/design.h"
#include "estimation/enum_names.h"

#include <array>
#include <bit>
#include <stdexcept>

namespace sigmaheart::estimation::sensitivity {

namespace {

// Joe & Kuo (2008), direction numbers "new-joe-kuo-6.21201" (search criterion D(6), from the
// authors' published table), dimensions 2..53: degree s of the primitive polynomial, its interior
// coefficients a (bit s-1-l holds coefficient l), and the initial direction integers m_1..m_s.
struct Row {
  int s;
  std::uint32_t a;
  std::uint32_t m[8];
};
constexpr Row kJoeKuo[] = {
    {1, 0, {1}},                                   // d = 2
    {2, 1, {1, 3}},                                // d = 3
    {3, 1, {1, 3, 1}},                             // d = 4
    {3, 2, {1, 1, 1}},                             // d = 5
    {4, 1, {1, 1, 3, 3}},                          // d = 6
    {4, 4, {1, 3, 5, 13}},                         // d = 7
    {5, 2, {1, 1, 5, 5, 17}},                      // d = 8
    {5, 4, {1, 1, 5, 5, 5}},                       // d = 9
    {5, 7, {1, 1, 7, 11, 19}},                     // d = 10
    {5, 11, {1, 1, 5, 1, 1}},                      // d = 11
    {5, 13, {1, 1, 1, 3, 11}},                     // d = 12
    {5, 14, {1, 3, 5, 5, 31}},                     // d = 13
    {6, 1, {1, 3, 3, 9, 7, 49}},                   // d = 14
    {6, 13, {1, 1, 1, 15, 21, 21}},                // d = 15
    {6, 16, {1, 3, 1, 13, 27, 49}},                // d = 16
    {6, 19, {1, 1, 1, 15, 7, 5}},                  // d = 17
    {6, 22, {1, 3, 1, 15, 13, 25}},                // d = 18
    {6, 25, {1, 1, 5, 5, 19, 61}},                 // d = 19
    {7, 1, {1, 3, 7, 11, 23, 15, 103}},            // d = 20
    {7, 4, {1, 3, 7, 13, 13, 15, 69}},             // d = 21
    {7, 7, {1, 1, 3, 13, 7, 35, 63}},              // d = 22
    {7, 8, {1, 3, 5, 9, 1, 25, 53}},               // d = 23
    {7, 14, {1, 3, 1, 13, 9, 35, 107}},            // d = 24
    {7, 19, {1, 3, 1, 5, 27, 61, 31}},             // d = 25
    {7, 21, {1, 1, 5, 11, 19, 41, 61}},            // d = 26
    {7, 28, {1, 3, 5, 3, 3, 13, 69}},              // d = 27
    {7, 31, {1, 1, 7, 13, 1, 19, 1}},              // d = 28
    {7, 32, {1, 3, 7, 5, 13, 19, 59}},             // d = 29
    {7, 37, {1, 1, 3, 9, 25, 29, 41}},             // d = 30
    {7, 41, {1, 3, 5, 13, 23, 1, 55}},             // d = 31
    {7, 42, {1, 3, 7, 3, 13, 59, 17}},             // d = 32
    {7, 50, {1, 3, 1, 3, 5, 53, 69}},              // d = 33
    {7, 55, {1, 1, 5, 5, 23, 33, 13}},             // d = 34
    {7, 56, {1, 1, 7, 7, 1, 61, 123}},             // d = 35
    {7, 59, {1, 1, 7, 9, 13, 61, 49}},             // d = 36
    {7, 62, {1, 3, 3, 5, 3, 55, 33}},              // d = 37
    {8, 14, {1, 3, 1, 15, 31, 13, 49, 245}},       // d = 38
    {8, 21, {1, 3, 5, 15, 31, 59, 63, 97}},        // d = 39
    {8, 22, {1, 3, 1, 11, 11, 11, 77, 249}},       // d = 40
    {8, 38, {1, 3, 1, 11, 27, 43, 71, 9}},         // d = 41
    {8, 47, {1, 1, 7, 15, 21, 11, 81, 45}},        // d = 42
    {8, 49, {1, 3, 7, 3, 25, 31, 65, 79}},         // d = 43
    {8, 50, {1, 3, 1, 1, 19, 11, 3, 205}},         // d = 44
    {8, 52, {1, 1, 5, 9, 19, 21, 29, 157}},        // d = 45
    {8, 56, {1, 3, 7, 11, 1, 33, 89, 185}},        // d = 46
    {8, 67, {1, 3, 3, 3, 15, 9, 79, 71}},          // d = 47
    {8, 70, {1, 3, 7, 11, 15, 39, 119, 27}},       // d = 48
    {8, 84, {1, 1, 3, 1, 11, 31, 97, 225}},        // d = 49
    {8, 97, {1, 1, 1, 3, 23, 43, 57, 177}},        // d = 50
    {8, 103, {1, 3, 7, 7, 17, 17, 37, 71}},        // d = 51
    {8, 115, {1, 3, 1, 5, 27, 63, 123, 213}},      // d = 52
    {8, 122, {1, 1, 3, 5, 11, 43, 53, 133}},       // d = 53
};
static_assert(sizeof(kJoeKuo) / sizeof(kJoeKuo[0]) == kMaxSobolDimension - 1);

// Direction numbers v_k = m_k 2^(32-k), k = 1..32, of coordinate d (1-based), by the recurrence
// of Bratley & Fox (1988, ACM TOMS 14:88, eq. 2) as written in Joe & Kuo (2003, ACM TOMS 29:49):
// v_k = v_{k-s} xor (v_{k-s} >> s) xor sum_{l=1}^{s-1} a_l v_{k-l}.
std::array<std::uint32_t, 32> direction_numbers(int d) {
  std::array<std::uint32_t, 32> v{};
  if (d == 1) {
    for (int k = 0; k < 32; ++k) v[static_cast<size_t>(k)] = 1u << (31 - k);
    return v;
  }
  const Row& row = kJoeKuo[d - 2];
  const int s = row.s;
  for (int k = 0; k < 32; ++k) {
    if (k < s) {
      v[static_cast<size_t>(k)] = row.m[k] << (31 - k);
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

constexpr std::array<EnumName<Scrambling>, 5> kScramblingNames{{
    {Scrambling::kNone, "none"}, {Scrambling::kLinearMatrixAndShift, "lms"},
    {Scrambling::kNone, "off"}, {Scrambling::kLinearMatrixAndShift, "matousek"},
    {Scrambling::kLinearMatrixAndShift, "linear-matrix-shift"},
}};
const char* to_string(Scrambling scrambling) { return enum_to_string(kScramblingNames, scrambling); }
std::optional<Scrambling> parse_scrambling(const std::string& text) {
  return enum_from_string(kScramblingNames, text);
}

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
  const Row& row = kJoeKuo[d - 2];
  return {row.s, row.a, std::vector<std::uint32_t>(row.m, row.m + row.s)};
}

bool is_power_of_two(std::uint64_t n) { return n != 0 && (n & (n - 1)) == 0; }

}  // namespace sigmaheart::estimation::sensitivity
