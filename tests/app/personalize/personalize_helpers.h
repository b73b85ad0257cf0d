// Shared pieces of the personalize command tests: running the CLI in-process and the bundled
// LAD-infarct twin (configs/personalize-lad-infarct.yaml, configs/data/regional-lad-infarct.csv).
#pragma once

#include "app/cli.h"
#include "../test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace sigmaheart::app::personalize_testing {

using sigmaheart::testing::CliRun;
using sigmaheart::testing::cli;

inline std::string twin_config() {
  return std::string(SIGMAHEART_SOURCE_DIR) + "/configs/personalize-lad-infarct.yaml";
}
inline std::string twin_data() {
  return std::string(SIGMAHEART_SOURCE_DIR) + "/configs/data/regional-lad-infarct.csv";
}

const std::set<int> kInfarct = {1, 2, 7, 8, 13, 14, 17};  // LAD territory of the twin's truth
constexpr double kPrior = 6.0e4;                           // uniform prior sigma0 [Pa]

inline std::string seg(int s) { return std::string("sigma0_") + (s < 10 ? "0" : "") + std::to_string(s); }

// The infarcted segments are exactly the ones estimated below 70 % of the uniform prior.
inline void expect_infarct_marked_low(const nlohmann::json& summary) {
  for (int s = 1; s <= 17; ++s) {
    const double ratio = summary["parameters"][seg(s)]["value"].get<double>() / kPrior;
    if (kInfarct.count(s)) {
      EXPECT_LT(ratio, 0.7) << "segment " << s;
    } else {
      EXPECT_GT(ratio, 0.7) << "segment " << s;
    }
  }
}

}  // namespace sigmaheart::app::personalize_testing
