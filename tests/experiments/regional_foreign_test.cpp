// The foreign regional bench of issue 46 (experiments/regional-foreign/README.md): the 17-patch
// lumped model personalised from the regional volumes of 3D hearts (lv-3d, another model family),
// through the same set-up `sigmaheart personalize` runs (alignment on end-diastole, the period and
// volume shares from the data, the ROUKF and its MAP refinement).
//
// - RegionalForeignMini (fast): two cases with the reduced config
//   experiments/regional-foreign/personalize-foreign-mini.yaml (contractility per segment,
//   activation per coronary territory, 4 split passes): the run ends converged, the infarct
//   segments are estimated below the others, no healthy segment of the LBBB heart is estimated as
//   scar, and the NIS is reported. Its thresholds are the measured values with a margin (README.md,
//   "The tests"), not the issue's targets, which the full config does not meet either.
// - RegionalForeignBench (slow, 2-3 min of CPU per case): the shipped config personalize-foreign.yaml
//   on every case of the bench (regional_foreign_cases.h) against the issue's targets. It fails
//   where a target is missed (measured on 2026-12-02: the NIS of all six generated cases, 87-680
//   against at most 36.2; the AUC of lbbb-lad-large 0.70, lbbb-lcx-large 0.85, lbbb-rca-large 0.84;
//   README.md, "Targets of issue 46") and on a case whose data make-data has not generated yet
//   (lbbb-lcx-small, lbbb-rca-small).
#include "app/config.h"
#include "app/personalize_setup.h"
#include "estimation/roukf/roukf.h"
#include "experiments/regional-foreign/regional_foreign_cases.h"
#include "tests/support/case_name.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace sigmaheart {
namespace regional_foreign {
// gtest prints a case by its name (not its bytes) in the test list and in failures.
void PrintTo(const ForeignCase& c, std::ostream* os) { *os << c.name; }
}  // namespace regional_foreign
namespace {

const std::string kDir = std::string(SIGMAHEART_SOURCE_DIR) + "/";

std::string data_file(const std::string& name) { return kDir + "configs/data/regional-foreign/" + name + ".csv"; }

struct Outcome {
  estimation::RoukfSummary summary;
  std::map<int, double> sigma0;  // segments 1-16 [Pa]
  regional_foreign::CaseStatistics stats;
};

// `personalize` of one case with `config` (as the command runs it, 2 threads: the numbers do not
// depend on the count), its contractility map and the statistics of the targets.
Outcome personalize(const std::string& config_file, const regional_foreign::ForeignCase& c) {
  const app::Config config = app::load_config(
      kDir + config_file, {"personalize.observations.file=" + data_file(c.name), "personalize.filter.threads=2"});
  app::PersonalizeProblem problem = app::parse_personalize(config);
  auto simulator = app::prepare_personalize_model(config, problem, model::into_steppable(config.simulator.make()));
  Outcome o;
  o.summary = estimation::run_roukf(*simulator, problem.prior, problem.data, problem.filter);
  const auto& s = o.summary;
  for (size_t j = 0; j < s.parameter_names.size(); ++j) {
    for (int seg = 1; seg <= 16; ++seg) {
      if (s.parameter_names[j] == std::string("sigma0_") + (seg < 10 ? "0" : "") + std::to_string(seg)) {
        o.sigma0[seg] = s.theta(static_cast<Eigen::Index>(j));
      }
    }
  }
  if (o.sigma0.size() == 16) o.stats = regional_foreign::statistics(o.sigma0, c.infarct);
  std::string lowest;
  std::vector<std::pair<double, int>> order;
  for (const auto& [seg, v] : o.sigma0) order.emplace_back(v / o.stats.median, seg);
  std::sort(order.begin(), order.end());
  for (size_t k = 0; k < order.size() && k < 4; ++k) {
    char entry[32];
    std::snprintf(entry, sizeof entry, "%s%d: %.2f", k ? ", " : "", order[k].second, order[k].first);
    lowest += entry;
  }
  std::printf("%s: %s; MAP refinement %d steps, %d runs (%s); NIS %.1f (band %.1f-%.1f); median sigma0 %.1f kPa, "
              "lowest %s; AUC %.2f; min/median %.2f; %d member runs\n",
              c.name.c_str(), estimation::to_string(s.termination), s.map_steps, s.map_runs, s.map_note.c_str(),
              s.nis_mean, s.nis_band_lower, s.nis_band_upper, o.stats.median / 1e3, lowest.c_str(), o.stats.auc,
              o.stats.min_relative, s.member_runs);
  return o;
}

const regional_foreign::ForeignCase& bench_case(const std::string& name) {
  for (const auto& c : regional_foreign::cases()) {
    if (c.name == name) return c;
  }
  throw std::runtime_error("no bench case " + name);
}

// ---- the mini bench (fast) ----

const char* const kMiniConfig = "experiments/regional-foreign/personalize-foreign-mini.yaml";

double parameter(const estimation::RoukfSummary& s, const std::string& name) {
  for (size_t j = 0; j < s.parameter_names.size(); ++j) {
    if (s.parameter_names[j] == name) return s.theta(static_cast<Eigen::Index>(j));
  }
  ADD_FAILURE() << "no estimated parameter " << name;
  return std::nan("");
}

// What both mini cases must show: the MAP refinement converged (exit 0 of the command), a finite
// whole-data NIS with its band reported (measured 368-388 against 13.9-18.3: the model error of a
// 17-patch model on a 3D heart, README.md; a bound at 600 catches a fit gone worse), and the LBBB
// sequence read from the volumes: the lateral wall activated after the septum (measured 92-94
// against 32-35 ms).
void expect_converged_with_the_lbbb_sequence(const Outcome& o) {
  const auto& s = o.summary;
  EXPECT_EQ(s.termination, estimation::RoukfTermination::kCompleted) << s.message;
  EXPECT_TRUE(s.map_converged) << s.map_note;
  EXPECT_TRUE(std::isfinite(s.nis_mean));
  EXPECT_GT(s.nis_band_upper, s.nis_band_lower);
  EXPECT_LT(s.nis_mean, 600.0);
  EXPECT_GT(parameter(s, "Td_lateral") - parameter(s, "Td_septal"), 0.030);
}

// An LBBB heart without infarct (30 frames): no segment is estimated as scar, although the late
// lateral wall empties last (measured: lowest segment 0.78 of the median; 17 s of CPU).
TEST(RegionalForeignMini, AnLbbbHeartHasNoSegmentTakenForScar) {
  const Outcome o = personalize(kMiniConfig, bench_case("lbbb"));
  ASSERT_EQ(o.sigma0.size(), 16u) << o.summary.message;
  expect_converged_with_the_lbbb_sequence(o);
  EXPECT_GE(o.stats.min_relative, regional_foreign::kScarFraction);
  EXPECT_TRUE(o.stats.scar.empty());
}

// An LBBB heart with a small LAD infarct (segments 7, 13, 14 at 40 %; 25 frames): the three
// infarct segments are estimated below every other segment (measured AUC 1.00: 14, 7, 13 the three
// lowest, 0.66-0.87 of the median), no late-activated healthy segment among the lowest.
TEST(RegionalForeignMini, ASmallLadInfarctIsEstimatedBelowTheOtherSegments) {
  const regional_foreign::ForeignCase& c = bench_case("lbbb-lad-small");
  const Outcome o = personalize(kMiniConfig, c);
  ASSERT_EQ(o.sigma0.size(), 16u) << o.summary.message;
  expect_converged_with_the_lbbb_sequence(o);
  EXPECT_GE(o.stats.auc, 0.9);
  EXPECT_TRUE(o.stats.late_healthy_in_scar.empty());
  for (int seg : c.infarct) {
    EXPECT_LT(o.sigma0.at(seg), o.stats.median) << "segment " << seg;
  }
}

// ---- the full bench (slow) ----

class RegionalForeignBench : public ::testing::TestWithParam<regional_foreign::ForeignCase> {};

TEST_P(RegionalForeignBench, ShippedConfigMeetsTheIssueTargets) {
  const regional_foreign::ForeignCase& c = GetParam();
  ASSERT_TRUE(std::filesystem::exists(data_file(c.name)))
      << c.name << ": no data; generate them with experiments/regional-foreign/make-data " << c.name;
  const Outcome o = personalize("experiments/regional-foreign/personalize-foreign.yaml", c);
  const auto& s = o.summary;
  ASSERT_EQ(o.sigma0.size(), 16u) << c.name << ": " << s.message;
  // Every case ends converged (the MAP refinement) or says why.
  EXPECT_EQ(s.termination, estimation::RoukfTermination::kCompleted) << c.name << ": " << s.message;
  EXPECT_TRUE(s.map_converged) << c.name << ": " << s.map_note;
  // The whole-data NIS within twice its 95 % band.
  EXPECT_LE(s.nis_mean, 2.0 * s.nis_band_upper) << c.name << ": NIS " << s.nis_mean << " against the band "
                                                 << s.nis_band_lower << "-" << s.nis_band_upper;
  // No late-activated healthy segment among the estimated scar.
  EXPECT_TRUE(o.stats.late_healthy_in_scar.empty()) << c.name;
  if (!c.infarct.empty()) {
    EXPECT_GE(o.stats.auc, 0.9) << c.name << ": the infarct segments against the others";
  } else {
    EXPECT_GE(o.stats.min_relative, regional_foreign::kScarFraction)
        << c.name << ": a segment below 60 % of the median contractility";
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, RegionalForeignBench, ::testing::ValuesIn(regional_foreign::cases()),
                         [](const ::testing::TestParamInfo<regional_foreign::ForeignCase>& param) {
                           return testing::case_test_name(param.param.name);
                         });

}  // namespace
}  // namespace sigmaheart
