// `sigmaheart specificity` end to end (app/commands/specificity.cpp) on a synthetic cohort of the
// "test-beat" stand-in in which only the ejection fraction differs between the groups: the study
// must name EF first, recover each case's EF, and write the documented files. Plus located errors.
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "app/io/observation_file.h"
#include "../test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sstream>

namespace sigmaheart::app {
namespace {

using namespace sigmaheart::testing;

struct Truth {
  const char* name;
  const char* group;
  double V_ed_mL, EF, P_peak_mmHg;
};

// EF separates the groups (0.57-0.63 vs 0.30-0.36); V_ed and P_peak overlap completely.
const Truth kCohort[] = {
    {"h1", "healthy", 140, 0.60, 115}, {"h2", "healthy", 155, 0.57, 125}, {"h3", "healthy", 165, 0.63, 118},
    {"h4", "healthy", 150, 0.59, 121}, {"f1", "failing", 160, 0.33, 117}, {"f2", "failing", 145, 0.30, 124},
    {"f3", "failing", 150, 0.36, 119}, {"f4", "failing", 158, 0.32, 116},
};

// Writes one observation file per case (the stand-in's curves at 41 samples) and the config.
std::filesystem::path write_cohort(const std::filesystem::path& dir, const std::string& extra = "") {
  std::filesystem::create_directories(dir / "data");
  std::string cases = "cases:\n";
  for (const auto& c : kCohort) {
    BeatStandIn sim(BeatStandIn::defaults(), 41);
    Eigen::VectorXd theta(4);
    theta << c.V_ed_mL * 1e-6, c.EF, c.P_peak_mmHg * 133.322387415, 0.0;
    const auto run = sim.run(theta);
    model::Trajectory t = run.trajectory;
    // Volume and pressure only (a measured file has no phase channel).
    t.channels.resize(2);
    t.values.conservativeResize(Eigen::NoChange, 2);
    io::write_observation_csv(dir / "data" / (std::string(c.name) + ".csv"), t, "ms", {"mL", "mmHg"});
    std::ostringstream s;
    s << "  - {name: " << c.name << ", file: data/" << c.name << ".csv, group: " << c.group
      << ", truth: {EF: " << c.EF << "}}\n";
    cases += s.str();
  }
  const std::string yaml =
      "name: cohort\n"
      "simulator:\n"
      "  model: test-beat\n"
      "  numerics: {samples: 41}\n"
      "  parameters: {V_ed: 150 mL, EF: 0.5, P_peak: 120 mmHg}\n" +
      cases +
      "observations:\n"
      "  indices: [EDV, EF, P_max]\n"
      "  noise: {EDV: 3 mL, EF: 0.02, P_max: 3 mmHg}\n"
      "estimate:\n"
      "  V_ed: {spread: 20 %}\n"
      "  EF: {spread: 40 %, transform: logit, bounds: [0.05, 0.9]}\n"
      "  P_peak: {spread: 20 %}\n"
      "calibration: {mode: iterate-keep-spread, max_iterations: 10, tolerance: 1.0e-4}\n" + extra;
  return write_file(dir / "cohort.yaml", yaml);
}

TEST(SpecificityCommand, CohortWhereOnlyEfDiffersNamesEfFirst) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir, "specificity: {groups: [healthy, failing], parallel: cases, threads: 2}\n");
  const CliRun r = cli({"--log-level", "off", "specificity", config.string(), "-o", (dir / "r.h5").string(),
                        "--summary", (dir / "r.json").string()});
  ASSERT_EQ(r.code, kExitOk) << r.err << r.out;

  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["kind"], "specificity");
  ASSERT_EQ(j["ranking"].size(), 3u);
  EXPECT_EQ(j["ranking"][0], "EF") << r.out;
  const auto& ef = j["statistics"]["EF"];
  EXPECT_DOUBLE_EQ(ef["auc"].get<double>(), 0.0);  // AUC(failing > healthy): every failing EF below
  EXPECT_EQ(ef["direction"], "lower");
  EXPECT_TRUE(ef["different"].get<bool>());
  EXPECT_EQ(j["adjust"], "holm");
  EXPECT_FALSE(j["statistics"]["V_ed"]["different"].get<bool>());
  EXPECT_NEAR(ef["mann_whitney_p"].get<double>(), 2.0 / 70.0, 1e-9);  // exact, 4 vs 4: 2 / C(8, 4)
  EXPECT_LT(ef["welch_p"].get<double>(), 1e-4);
  EXPECT_NEAR(ef["mean_a"].get<double>(), 0.5975, 0.01);
  EXPECT_NEAR(ef["mean_b"].get<double>(), 0.3275, 0.01);
  EXPECT_GT(j["statistics"]["V_ed"]["mann_whitney_p"].get<double>(), 0.2);  // no separation
  EXPECT_DOUBLE_EQ(j["classifier"]["accuracy"].get<double>(), 1.0);
  for (const auto& c : j["cases"]) {
    EXPECT_NEAR(c["estimate"]["EF"]["value"].get<double>(), c["estimate"]["EF"]["truth"].get<double>(), 0.01)
        << c["name"];
    EXPECT_LT(c["relative_error_percent"].get<double>(), 2.0) << c["name"];
  }

  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.string_attribute("/", "kind"), "specificity");
  EXPECT_EQ(f.read_strings("/statistics/ranking").front(), "EF");
  EXPECT_EQ(f.string_attribute("/statistics", "group_a"), "healthy");
  const Eigen::MatrixXd mean = f.read_matrix("/cases/mean"), sd = f.read_matrix("/cases/std");
  ASSERT_EQ(mean.rows(), 8);
  ASSERT_EQ(mean.cols(), 3);
  EXPECT_NEAR(mean(4, 1), 0.33, 0.01);
  EXPECT_GT(sd.minCoeff(), 0.0);
  EXPECT_EQ(f.read_strings("/cases/observation_units"), (std::vector<std::string>{"mL", "%", "mmHg"}));
  EXPECT_NEAR(f.read_matrix("/cases/observed")(0, 0), 140.0, 0.5);
  EXPECT_NE(r.out.find("leave-one-out LDA accuracy 100 % (8/8)"), std::string::npos) << r.out;
}

TEST(SpecificityCommand, CasesInParallelAndInOrderGiveTheSameNumbers) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir);
  const CliRun a = cli({"--log-level", "off", "specificity", config.string(), "-o", (dir / "a.h5").string(),
                        "--set", "specificity.parallel=cases", "--threads", "2"});
  const CliRun b = cli({"--log-level", "off", "specificity", config.string(), "-o", (dir / "b.h5").string(),
                        "--set", "specificity.parallel=ensemble", "--threads", "1"});
  ASSERT_EQ(a.code, kExitOk) << a.err;
  ASSERT_EQ(b.code, kExitOk) << b.err;
  io::Hdf5Reader fa(dir / "a.h5"), fb(dir / "b.h5");
  EXPECT_EQ(fa.read_matrix("/cases/mean"), fb.read_matrix("/cases/mean"));
  EXPECT_EQ(fa.read_vector("/statistics/welch_p"), fb.read_vector("/statistics/welch_p"));
}

TEST(SpecificityCommand, ValidateChecksTheCasesAndTheCalibrationSections) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir);
  const CliRun ok = cli({"validate", config.string()});
  EXPECT_EQ(ok.code, kExitOk) << ok.err;
  EXPECT_NE(ok.out.find("cases"), std::string::npos) << ok.out;
}

TEST(SpecificityCommand, BadCohortsGiveLocatedErrorsAndExitTwo) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir);
  const std::string text = read_file(config);
  struct Bad {
    std::string from, to, words;
  };
  const std::vector<Bad> bad = {
      {"file: data/h2.csv", "file: data/missing.csv", "does not exist"},
      {"name: h3,", "name: h1,", "appears twice"},
      {"group: healthy, truth: {EF: 0.6}", "group: healthy, truth: {EFF: 0.6}", "did you mean 'EF'"},
      {"estimate:\n  V_ed", "estimate:\n  V_edd", "V_edd"},
      {"observations:\n", "observations:\n  file: data/h1.csv\n", "remove observations.file"},
      {"  indices: [EDV, EF, P_max]", "  indices: [EDV, EF, P_max]\n  curvs: [V_lv]", "curves"},
      {"calibration:", "specificity: {adjust: bonferroni}\ncalibration:", "benjamini-hochberg"},
      {"calibration:", "specificity: {alpha: 1.5}\ncalibration:", "expected a level in (0, 1)"},
      {"calibration:", "specificity: {min_cases_per_group: 1}\ncalibration:", "at least 2"},
  };
  for (const auto& b : bad) {
    std::string t = text;
    const auto at = t.find(b.from);
    ASSERT_NE(at, std::string::npos) << b.from;
    t.replace(at, b.from.size(), b.to);
    const auto path = write_file(dir / "bad.yaml", t);
    const CliRun r = cli({"--log-level", "off", "specificity", path.string(), "-o", (dir / "r.h5").string()});
    EXPECT_EQ(r.code, kExitBadInput) << b.to << "\n" << r.err;
    EXPECT_NE(r.err.find("bad.yaml:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(b.words), std::string::npos) << b.to << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "r.h5"));
  }
}

// The exclusion policy's floor: with more cases required per group than calibrate, the study
// writes every case's results and the status, and exits 1.
TEST(SpecificityCommand, TooFewCalibratedCasesPerGroupExitsOneWithTheStatusWritten) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir, "specificity: {groups: [healthy, failing], min_cases_per_group: 5}\n");
  const CliRun r = cli({"--log-level", "off", "specificity", config.string(), "-o", (dir / "r.h5").string(),
                        "--summary", (dir / "r.json").string(), "--threads", "1"});
  EXPECT_EQ(r.code, kExitRuntimeFailure) << r.err << r.out;
  EXPECT_NE(r.err.find("need at least 5 each"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["status"], "no-statistics");
  EXPECT_FALSE(j["valid"].get<bool>());
  EXPECT_EQ(j["cases"].size(), 8u);
  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.string_attribute("/summary", "status"), "no-statistics");
  EXPECT_EQ(f.read_matrix("/cases/mean").rows(), 8);
  EXPECT_NE(r.out.find("no statistics"), std::string::npos) << r.out;
}

// A calibration stopped by the iteration limit is a failed case (listed with that reason, left out
// of the statistics): with every case failed there are no statistics and the study exits 1.
TEST(SpecificityCommand, TheIterationLimitIsAFailedCase) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir, "specificity: {groups: [healthy, failing]}\n");
  const CliRun r = cli({"--log-level", "off", "specificity", config.string(), "-o", (dir / "s.h5").string(),
                        "--summary", (dir / "s.json").string(), "--threads", "1", "--set",
                        "calibration.max_iterations=1"});
  EXPECT_EQ(r.code, kExitRuntimeFailure) << r.err;
  const auto j = nlohmann::json::parse(read_file(dir / "s.json"));
  EXPECT_EQ(j["failed_cases"].size(), 8u);
  EXPECT_NE(j["cases"][0]["status"].get<std::string>().find("iteration limit"), std::string::npos) << j["cases"][0];
}

TEST(SpecificityCommand, ReadsTheCasesFromACaseListFile) {
  const auto dir = scratch_dir();
  const auto config = write_cohort(dir);
  std::string text = read_file(config);
  const auto from = text.find("cases:\n"), to = text.find("observations:");
  const std::string cases = text.substr(from, to - from);
  std::string list = cases;
  // In data/list.yaml the files are relative to data/.
  for (size_t at = 0; (at = list.find("file: data/", at)) != std::string::npos;) list.erase(at + 6, 5);
  write_file(dir / "data" / "list.yaml", list);
  text.replace(from, to - from, "cases: data/list.yaml\n");
  const auto path = write_file(dir / "listed.yaml", text);
  const CliRun r = cli({"--log-level", "off", "specificity", path.string(), "-o", (dir / "r.h5").string(),
                        "--threads", "1"});
  ASSERT_EQ(r.code, kExitOk) << r.err;
  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.read_strings("/cases/names").size(), 8u);
  EXPECT_EQ(f.read_strings("/statistics/ranking").front(), "EF");
}

}  // namespace
}  // namespace sigmaheart::app
