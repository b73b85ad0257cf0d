// The shrunk foreign-cohort experiment (experiments/specificity/README.md, "Foreign cohort"): 5
// healthy and 5 reduced-contractility subjects of configs/data/foreign-cohort (curves made by no
// BCS code), calibrated with configs/specificity-foreign.yaml (UT, mode: map). Every one of these
// ten converges (the one failure of the full study, healthy-el2, is not among them). Reduced
// contractility and raised filling pressure must come out in their directions with complete
// separation, and afterload, which the cohort keeps at the healthy value, must not be called
// different. About 3 s (10 calibrations).
#include "app/cli.h"
#include "app/errors.h"
#include "../test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>

namespace sigmaheart::app {
namespace {

using namespace sigmaheart::testing;

TEST(SpecificityForeign, ReducedGroupHasLowerContractilityAndUnchangedAfterload) {
  const std::filesystem::path source(SIGMAHEART_SOURCE_DIR);
  const auto dir = scratch_dir();
  std::string text = read_file(source / "configs/specificity-foreign.yaml");
  std::string cases = "cases:\n";
  for (const char* id : {"healthy-el1", "healthy-el3", "healthy-of1", "healthy-of2", "healthy-of3",
                         "reduced-el1", "reduced-el2", "reduced-el3", "reduced-of1", "reduced-of4"}) {
    const std::string name(id);
    cases += "  - {name: " + name + ", file: " + (source / "configs/data/foreign-cohort" / (name + ".csv")).string() +
             ", group: " + name.substr(0, name.find('-')) + "}\n";
  }
  const std::string list = "cases: data/foreign-cohort/cases.yaml\n";
  const auto at = text.find(list);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, list.size(), cases);
  const auto config = write_file(dir / "foreign.yaml", text);

  std::ostringstream out, err;
  const int code = run_cli({"--log-level", "off", "specificity", config.string(), "-o", (dir / "r.h5").string(),
                            "--summary", (dir / "r.json").string(), "--threads", "2"},
                           out, err);
  ASSERT_EQ(code, kExitOk) << err.str() << out.str();
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["group_a"], "healthy");
  EXPECT_EQ(j["group_b"], "reduced");
  EXPECT_TRUE(j["failed_cases"].empty()) << out.str();
  for (const auto& c : j["cases"]) {
    EXPECT_EQ(c["status"], "ok") << c["name"];
  }
  EXPECT_EQ(j["statistics"]["sigma0"]["n_a"], 5);
  EXPECT_EQ(j["statistics"]["sigma0"]["n_b"], 5);
  const auto& s = j["statistics"];
  EXPECT_DOUBLE_EQ(s["sigma0"]["auc"].get<double>(), 0.0) << out.str();  // every reduced below every healthy
  EXPECT_EQ(s["sigma0"]["direction"], "lower");
  EXPECT_DOUBLE_EQ(s["P_at0"]["auc"].get<double>(), 1.0) << out.str();
  EXPECT_EQ(s["P_at0"]["direction"], "higher");
  // Exact Mann-Whitney, 5 vs 5, complete separation: 2 / C(10, 5).
  EXPECT_NEAR(s["sigma0"]["mann_whitney_p"].get<double>(), 2.0 / 252.0, 1e-12);
  const double auc_rd = s["R_d"]["auc"].get<double>();
  EXPECT_GT(auc_rd, 0.2) << out.str();
  EXPECT_LT(auc_rd, 0.8) << out.str();
  EXPECT_FALSE(s["R_d"]["different"].get<bool>());
  EXPECT_GT(s["R_d"]["p_adjusted"].get<double>(), 0.3);
  // Holm over 4 parameters never lowers a p-value.
  for (const char* p : {"sigma0", "R_d", "P_at0", "c_exp"}) {
    EXPECT_GE(s[p]["p_adjusted"].get<double>(), s[p]["posterior_welch_p"].get<double>()) << p;
  }
}

}  // namespace
}  // namespace sigmaheart::app
