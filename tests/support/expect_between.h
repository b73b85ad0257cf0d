// lo < value < hi as two GoogleTest expectations: the range checks of the model and bench tests
// (phenotype ranges of a simulated beat, timings, noise levels).
#pragma once

#include <gtest/gtest.h>

#include <string>

namespace sigmaheart::testing {

// EXPECT_GT(value, lo) and EXPECT_LT(value, hi), each failure reported under `what`.
inline void expect_between(double value, double lo, double hi, const std::string& what) {
  EXPECT_GT(value, lo) << what;
  EXPECT_LT(value, hi) << what;
}

}  // namespace sigmaheart::testing
