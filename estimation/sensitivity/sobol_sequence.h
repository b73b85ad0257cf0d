// Sobol' low-discrepancy sequence in base 2 with Joe-Kuo direction numbers (Joe & Kuo 2008,
// SIAM J Sci Comput 30:2635, table "new-joe-kuo-6.21201", read from Boost.Random's copy), optionally scrambled by a random
// linear matrix scramble plus a random digital shift (Matousek 1998, J Complexity 14:527).
//
// Points are indexed: point(i) is computed directly from i (Gray-code order, Antonov & Saleev
// 1979), so any block of points can be produced on any thread with the same bits. The first 2^k
// points of the sequence form a (t, k, d)-net in base 2; the scramble keeps that property (it is
// a nonsingular lower-triangular map of the digits of each coordinate followed by an XOR), and
// makes each point uniformly distributed on [0, 1)^d, so the estimators built on it are unbiased
// and can be replicated with different seeds.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation::sensitivity {

// Dimensions for which direction numbers are tabulated: dimension 1 is the van der Corput
// sequence, dimensions 2..3667 come from the Joe-Kuo table as Boost.Random ships it (the
// polynomials below 2^16). A Saltelli design needs 2p (up to 1833 parameters).
inline constexpr int kMaxSobolDimension = 3667;

enum class Scrambling {
  kNone,                  // the plain sequence; point 0 is the origin
  kLinearMatrixAndShift,  // Matousek 1998 random linear scramble + random digital shift
};
const char* to_string(Scrambling scrambling);
std::optional<Scrambling> parse_scrambling(const std::string& text);  // "none", "lms"

struct SobolSequenceOptions {
  int dimension = 2;  // 1..kMaxSobolDimension
  Scrambling scrambling = Scrambling::kLinearMatrixAndShift;
  std::uint64_t seed = 0;  // scramble of coordinate j drawn from make_stream(seed, j)
  std::string validate() const;
};

class SobolSequence {
 public:
  // Throws std::invalid_argument when options.validate() fails.
  explicit SobolSequence(const SobolSequenceOptions& options);

  int dimension() const { return dimension_; }
  // Point `index` (0-based, index < 2^32) in [0, 1)^dimension.
  void point(std::uint64_t index, double* out) const;
  // Points first, ..., first + n - 1 as rows (n x dimension).
  Eigen::MatrixXd points(std::uint64_t first, std::uint64_t n) const;

 private:
  int dimension_;
  std::vector<std::array<std::uint32_t, 32>> v_;  // per coordinate: 32 direction numbers
  std::vector<std::uint32_t> shift_;              // per coordinate: digital shift
};

// The Joe-Kuo primitive polynomial data of dimension d (2..kMaxSobolDimension): degree s,
// coefficient word a, initial direction integers m_1..m_s. Exposed for the table's tests.
struct JoeKuoEntry {
  int s;
  std::uint32_t a;
  std::vector<std::uint32_t> m;
};
JoeKuoEntry joe_kuo_entry(int d);

bool is_power_of_two(std::uint64_t n);

}  // namespace sigmaheart::estimation::sensitivity
