// `sigmaheart personalize` end to end, shortened: one pass of the ROUKF over the bundled
// LAD-infarct twin (17 contractilities, LBBB, 30 frames) already marks the infarcted segments low;
// the results file holds every step with units; bad input exits 2 at file:line:column, a filter
// that aborts exits 1 with the steps done written.
#include "app/io/hdf5_writer.h"
#include "personalize_helpers.h"

namespace sigmaheart::app::personalize_testing {
namespace {

using namespace sigmaheart::testing;

TEST(PersonalizeCommand, OnePassMarksTheInfarctedSegmentsLow) {
  const auto dir = scratch_dir();
  const std::string h5 = (dir / "one.h5").string(), json = (dir / "one.json").string();
  const CliRun r = cli({"personalize", twin_config(), "-o", h5, "--summary", json, "--threads", "2",
                        "--set", "personalize.filter.beats=1"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_file(json));
  EXPECT_EQ(j["termination"], "completed");
  EXPECT_EQ(j["members"], 18);
  EXPECT_EQ(j["steps"], 30);
  expect_infarct_marked_low(j);
  for (int s = 1; s <= 17; ++s) {
    const auto& e = j["parameters"][seg(s)];
    EXPECT_EQ(e["segment"], s);
    EXPECT_LT(e["std"].get<double>(), e["prior_std"].get<double>()) << "segment " << s;
    EXPECT_NEAR(e["truth"].get<double>(), kInfarct.count(s) ? 24000.0 : 60000.0, 1e-6);
  }

  io::Hdf5Reader f(h5);
  EXPECT_EQ(f.string_attribute("/", "kind"), "personalize");
  const Eigen::MatrixXd theta = f.read_matrix("/steps/theta");
  EXPECT_EQ(theta.rows(), 30);
  EXPECT_EQ(theta.cols(), 17);
  EXPECT_EQ(f.read_matrix("/steps/fitted").cols(), 17);
  EXPECT_EQ(f.read_vector("/steps/nis").size(), 30);
  EXPECT_EQ(f.string_attribute("/steps/innovation", "units"), "see /observations/units");
  EXPECT_EQ(f.read_strings("/observations/units")[6], "mL");
  EXPECT_EQ(f.string_attribute("/steps/theta", "units"), "per parameter, see /estimate/units");
  EXPECT_EQ(f.read_vector("/truth/values").size(), 17);
  // The spread against the truth (docs/estimation.md s.4.5): JSON and HDF5 agree, the count inside
  // +-2 std is that of the standardised errors, the joint limit is chi2_0.95(17) = 27.587 (tables;
  // Wilson-Hilferty to 0.1 %), and the report states the joint check.
  const Eigen::VectorXd z = f.read_vector("/truth/standardised_error");
  ASSERT_EQ(z.size(), 17);
  for (int s = 1; s <= 17; ++s) {
    EXPECT_EQ(j["parameters"][seg(s)]["truth_standardised_error"].get<double>(), z(s - 1));
  }
  EXPECT_EQ(j["truth_inside_2std"].get<int>(), (z.array().abs() <= 2.0).count());
  const double d2 = j["truth_mahalanobis_squared"].get<double>();
  EXPECT_EQ(f.double_attribute("/truth", "mahalanobis_squared"), d2);
  EXPECT_GE(d2, 0.0);
  EXPECT_NEAR(j["truth_mahalanobis_squared_limit_95"].get<double>(), 27.587, 0.001 * 27.587);
  EXPECT_NE(r.out.find("joint: (eta - truth)^T P^-1 (eta - truth) = "), std::string::npos) << r.out;
  // The MAP refinement after the pass (docs/estimation.md s.4.7): from the one pass, whose
  // estimate is up to 59 % off, Gauss-Newton on the whole-data objective reaches the MAP point;
  // JSON and HDF5 agree and the final errors are those of the refined estimate.
  const auto& m = j["map_refinement"];
  EXPECT_TRUE(m["converged"].get<bool>()) << m["note"];
  EXPECT_GE(m["steps"].get<int>(), 1);
  EXPECT_LT(m["last_step_std"].get<double>(), 0.01);
  EXPECT_LE(m["objective_at_estimate"].get<double>(), m["objective_at_filter_estimate"].get<double>());
  EXPECT_EQ(f.double_attribute("/map_refinement", "steps"), m["steps"].get<double>());
  EXPECT_EQ(f.double_attribute("/map_refinement", "shift_filter_std"), m["shift_filter_std"].get<double>());
  EXPECT_EQ(f.read_vector("/map_refinement/eta_filter").size(), 17);
  const Eigen::VectorXd error = f.read_vector("/truth/error");
  ASSERT_EQ(error.size(), 17);
  for (int s = 1; s <= 17; ++s) {
    EXPECT_EQ(j["parameters"][seg(s)]["error_percent"].get<double>(), error(s - 1));
    EXPECT_LT(error(s - 1), 10.0) << "segment " << s;
  }
  EXPECT_NE(r.out.find("after the MAP refinement: "), std::string::npos) << r.out;
  // The +-2 sigma band contains the estimate at every step.
  const Eigen::MatrixXd lo = f.read_matrix("/steps/theta_lower"), hi = f.read_matrix("/steps/theta_upper");
  EXPECT_TRUE(((lo.array() <= theta.array()) && (theta.array() <= hi.array())).all());
}

std::string config_with(const std::string& estimate, const std::string& filter = "beats: 1") {
  return "name: t\nsimulator:\n  model: lumped-regional\n  numerics: {activation: lbbb}\n"
         "personalize:\n  observations:\n    file: " + twin_data() +
         "\n    noise: 0.05 mL\n    start_beats: 8\n  estimate:\n    " + estimate +
         "\n  filter: {" + filter + "}\n";
}

// personalize on `config` (written to dir/bad.yaml) is bad input: exit 2, a message that names
// `where` (e.g. "bad.yaml:11:28") and says `what`, and no results file.
void expect_bad_input(const std::filesystem::path& dir, const std::string& config, const std::string& where,
                      const std::string& what) {
  const auto cfg = write_file(dir / "bad.yaml", config);
  const CliRun r = cli({"personalize", cfg.string(), "-o", (dir / "x.h5").string()});
  EXPECT_EQ(r.code, 2) << config;
  EXPECT_NE(r.err.find(where), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.h5"));
}

TEST(PersonalizeCommand, ASegmentOutsideTheSeventeenIsReportedAtItsLineAndColumn) {
  const auto dir = scratch_dir();
  expect_bad_input(dir, config_with("sigma0: {segments: [1, 18], spread: 50 %}"), "bad.yaml:11:28",
                   "segment 18 outside 1..17");
}

// The split-pass keys of filter: (docs/estimation.md s.4.2) are checked where they stand.
TEST(PersonalizeCommand, BadSplitPassSettingsAreReportedAtTheirLineAndColumn) {
  const auto dir = scratch_dir();
  const std::string estimate = "sigma0: {segments: all, spread: 50 %}";
  for (const auto& [filter, what] :
       {std::pair<std::string, std::string>{"passes: twice", "expected one of"},
        {"passes: split, first_fraction: 0", "expected a number in (0, 1]"},
        {"passes: split, pass_growth: -1", "expected a positive number"},
        {"sigma_scale: 1.5", "expected a number in (0, 1]"},
        {"tempering: -0.5", "expected a number >= 0"},
        {"map_iterations: -1", "expected an integer >= 0"},
        {"map_tolerance: 0", "expected a positive number of posterior standard deviations"},
        {"map_objective_tolerance: -0.1", "expected a number >= 0 (a fall of Phi per observation"}}) {
    expect_bad_input(dir, config_with(estimate, filter), "bad.yaml:12:", what);
  }
}

TEST(PersonalizeCommand, AnUnknownFamilyGetsADidYouMean) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "bad.yaml", config_with("sigma: {spread: 50 %}"));
  const CliRun r = cli({"personalize", cfg.string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.yaml:11:5"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("did you mean"), std::string::npos) << r.err;
}

TEST(PersonalizeCommand, AFamilyIsNamedByItsTagOrByItsParametersStem) {
  const auto dir = scratch_dir();
  for (const std::string estimate :
       {"contractility: {segments: [1, 7], spread: 20 %}", "sigma0: {segments: all, spread: 20 %}",
        "activation_time: {segments: [2], spread: 0.01 s, transform: identity}",
        "Td: {segments: [2], spread: 0.01 s, transform: identity}"}) {
    const auto cfg = write_file(dir / "family.yaml", config_with(estimate));
    const CliRun r = cli({"validate", cfg.string()});
    EXPECT_EQ(r.code, 0) << estimate << ": " << r.err;
  }
}

// Zones (docs/estimation.md s.4.6): one parameter per zone, 3 members instead of 18; one pass
// already separates the infarcted LAD territory from the rest.
TEST(PersonalizeCommand, ZonesTieTheirSegmentsToOneParameterEach) {
  const auto dir = scratch_dir();
  const std::string json = (dir / "zones.json").string();
  const auto cfg = write_file(
      dir / "zones.yaml",
      config_with("sigma0: {zones: {lad: [1, 2, 7, 8, 13, 14, 17], rest: [3, 4, 5, 6, 9, 10, 11, 12, 15, 16]}, "
                  "prior: 6.0e4, spread: 50 %, transform: log}") +
          "  truth: {sigma0_lad: 24 kPa, sigma0_rest: 60 kPa}\n");
  const CliRun r = cli({"personalize", cfg.string(), "-o", (dir / "zones.h5").string(), "--summary", json,
                        "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_file(json));
  EXPECT_EQ(j["members"], 3);
  EXPECT_FALSE(j["parameters"].contains("sigma0_01"));
  const double lad = j["parameters"]["sigma0_lad"]["value"].get<double>();
  const double rest = j["parameters"]["sigma0_rest"]["value"].get<double>();
  EXPECT_LT(lad / kPrior, 0.7);
  EXPECT_GT(rest / kPrior, 0.7);
  EXPECT_NEAR(j["parameters"]["sigma0_lad"]["truth"].get<double>(), 24000.0, 1e-6);
}

// Noise stated 10 times smaller than the data carry: the NIS lands far above its band and the
// report says what that means for the intervals (the JSON flags it).
TEST(PersonalizeCommand, ANisAboveItsBandIsReportedInWords) {
  const auto dir = scratch_dir();
  std::string text = config_with("sigma0: {zones: {lad: [1, 2, 7, 8, 13, 14, 17], rest: [3, 4, 5, 6, 9, 10, 11, "
                                 "12, 15, 16]}, prior: 6.0e4, spread: 50 %, transform: log}");
  text.replace(text.find("noise: 0.05 mL"), 14, "noise: 0.005 mL");
  const auto cfg = write_file(dir / "tight.yaml", text);
  const std::string json = (dir / "tight.json").string();
  const CliRun r = cli({"personalize", cfg.string(), "-o", (dir / "tight.h5").string(), "--summary", json,
                        "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_file(json));
  EXPECT_GT(j["nis_mean"].get<double>(), j["nis_band_95"][1].get<double>());
  EXPECT_FALSE(j["nis_inside_band"].get<bool>());
  EXPECT_NE(r.out.find("WARNING: the mean NIS"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("too narrow to be credible"), std::string::npos) << r.out;
}

TEST(PersonalizeCommand, BadZonesAreReportedAtTheirLineAndColumn) {
  const auto dir = scratch_dir();
  for (const auto& [estimate, what] :
       {std::pair<std::string, std::string>{"sigma0: {zones: {a: [1, 2], b: [2, 3]}}", "already in another zone"},
        {"sigma0: {zones: {a: [1, 18]}}", "segment 18 outside 1..17"},
        {"sigma0: {segments: all, zones: {a: [1]}}", "either segments: or zones:"},
        {"R_p: {zones: {a: [1]}}", "not a per-segment parameter family"},
        {"sigma0: {zones: [1, 2]}", "expected a map of zone name"}}) {
    expect_bad_input(dir, config_with(estimate), "bad.yaml:11:", what);
  }
}

TEST(PersonalizeCommand, AnAbortedFilterExitsOneAndKeepsTheStepsDone) {
  const auto dir = scratch_dir();
  // One Newton iteration per step cannot converge: every member fails in the first prediction.
  std::string text = config_with("sigma0: {segments: all, spread: 50 %}", "beats: 1, failure_policy: abort");
  text.replace(text.find("{activation: lbbb}"), 18, "{activation: lbbb, newton_max_iterations: 1}");
  const auto cfg = write_file(dir / "abort.yaml", text);
  const std::string h5 = (dir / "abort.h5").string();
  const CliRun r = cli({"personalize", cfg.string(), "-o", h5, "--threads", "1"});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("member 0 failed"), std::string::npos) << r.err;
  io::Hdf5Reader f(h5);
  EXPECT_EQ(f.string_attribute("/summary", "termination"), "member failed");
  EXPECT_EQ(f.read_vector("/steps/time").size(), 1);
}

TEST(PersonalizeCommand, ANonFiniteAnalysisExitsOneWithTheStatusInWordsAndTheStepsDone) {
  const auto dir = scratch_dir();
  // Frame 3 of the bundled data with a value the filter cannot weigh: R^-1 (y - z) overflows.
  std::string csv = read_file(twin_data());
  const size_t row = csv.find("\n56.666");
  ASSERT_NE(row, std::string::npos);
  const size_t from = csv.find(", ", row) + 2, to = csv.find(",", from);
  csv.replace(from, to - from, "1e305");
  const auto data = write_file(dir / "overflow.csv", csv);
  std::string text = config_with("sigma0: {segments: all, spread: 50 %}");
  text.replace(text.find(twin_data()), twin_data().size(), data.string());
  const auto cfg = write_file(dir / "overflow.yaml", text);
  const std::string h5 = (dir / "overflow.h5").string(), json = (dir / "overflow.json").string();
  const CliRun r = cli({"personalize", cfg.string(), "-o", h5, "--summary", json, "--threads", "2"});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("numerical failure"), std::string::npos) << r.err;
  io::Hdf5Reader f(h5);
  EXPECT_EQ(f.string_attribute("/summary", "termination"), "numerical failure");
  EXPECT_EQ(f.read_vector("/steps/time").size(), 2);  // frames 1 and 2 kept
  const auto j = nlohmann::json::parse(read_file(json));
  EXPECT_EQ(j["termination"], "numerical failure");
}

}  // namespace
}  // namespace sigmaheart::app::personalize_testing
