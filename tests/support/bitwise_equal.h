// Bit-for-bit equality of two matrices: the determinism tests (same numbers whatever the thread or
// rank count, a checkpoint read back).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstring>

namespace sigmaheart::testing {

// Same shape and the same bits in every entry (NaN payloads included; -0.0 differs from 0.0).
inline bool bitwise_equal(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

}  // namespace sigmaheart::testing
