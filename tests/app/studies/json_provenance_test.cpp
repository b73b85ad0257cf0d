// Every command that writes a JSON summary (simulate, calibrate, personalize, sensitivity,
// specificity) puts the provenance of its results file under a `provenance` key: the same fields
// as the HDF5 root attributes (app/io/results.h, docs/architecture.md s.6). The commands run on the
// "test-beat" stand-in and the two-segment test model, so the whole file takes about a second.
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "app/io/observation_file.h"
#include "tests/app/test_support.h"
#include "tests/app/two_segment_config.h"
#include "tests/support/two_segment_model.h"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <hdf5_hl.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace sigmaheart::testing {
namespace {

// The built-in models, the stand-in and the two-segment test model.
const model::ModelRegistry& models() {
  static const model::ModelRegistry registry =
      with_models(model::builtin_models(), {register_stand_in, register_two_segment_model});
  return registry;
}

// `command CONFIG -o dir/r.h5 --summary dir/r.json extra...`, quiet.
CliRun run_with_summary(const std::string& command, const std::filesystem::path& config,
                        const std::filesystem::path& dir, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {"--log-level", "off", command, config.string(), "-o",
                                   (dir / "r.h5").string(), "--summary", (dir / "r.json").string()};
  args.insert(args.end(), extra.begin(), extra.end());
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, models());
  return {code, out.str(), err.str()};
}

// The JSON provenance equals the HDF5 root attributes of the same run, field by field.
void expect_provenance(const std::filesystem::path& dir, const std::string& kind,
                       const std::filesystem::path& config, bool seeded) {
  SCOPED_TRACE(kind);
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  ASSERT_TRUE(j.contains("provenance")) << j.dump(2).substr(0, 2000);
  const auto& p = j["provenance"];
  app::io::Hdf5Reader f(dir / "r.h5");
  for (const char* key : {"kind", "name", "sigmaheart_version", "git_describe", "config_file",
                          "command_line", "start_utc", "units_convention"}) {
    ASSERT_TRUE(p.contains(key)) << key;
    EXPECT_EQ(p[key].get<std::string>(), f.string_attribute("/", key)) << key;
  }
  EXPECT_EQ(p["kind"], kind);
  EXPECT_EQ(p["config"].get<std::string>(), read_file(config));
  EXPECT_EQ(p["config"].get<std::string>(), f.read_text("/config"));
  EXPECT_EQ(p["config_file"].get<std::string>(), config.string());
  EXPECT_NE(p["command_line"].get<std::string>().find(kind), std::string::npos);
  EXPECT_EQ(p["overrides"].get<std::vector<std::string>>(), f.strings_attribute("/", "overrides"));
  EXPECT_EQ(p["threads"].get<double>(), f.double_attribute("/", "threads"));
  EXPECT_EQ(p["ranks"].get<int>(), 1);
  const std::regex iso(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)");
  EXPECT_TRUE(std::regex_match(p["start_utc"].get<std::string>(), iso)) << p["start_utc"];
  EXPECT_TRUE(std::regex_match(p["end_utc"].get<std::string>(), iso)) << p["end_utc"];
  EXPECT_LE(p["start_utc"].get<std::string>(), p["end_utc"].get<std::string>());
  if (seeded) {
    ASSERT_TRUE(f.has_attribute("/", "seed"));
    EXPECT_EQ(p["seed"].get<double>(), f.double_attribute("/", "seed"));
  } else {
    EXPECT_TRUE(p["seed"].is_null());
  }
}

TEST(JsonProvenance, SimulateSummaryCarriesTheProvenance) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "sim.yaml", "name: sim\nsimulator: {model: test-beat}\n");
  const CliRun r = run_with_summary("simulate", cfg, dir, {"--set", "EF=0.55"});
  ASSERT_EQ(r.code, app::kExitOk) << r.err;
  expect_provenance(dir, "simulate", cfg, false);
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["provenance"]["overrides"].size(), 1u);
  EXPECT_NEAR(j["EF"]["value"].get<double>(), 55.0, 1e-6);  // the indicators are unchanged
}

TEST(JsonProvenance, CalibrateSummaryCarriesTheProvenance) {
  const auto dir = scratch_dir();
  // Observations of the stand-in's own curves (EF 0.5 instead of the nominal 0.6).
  BeatStandIn sim(BeatStandIn::defaults(), 41);
  Eigen::VectorXd theta(4);
  theta << 1.4e-4, 0.5, 16000.0, 0.0;
  model::Trajectory t = sim.run(theta).trajectory;
  t.channels.resize(2);
  t.values.conservativeResize(Eigen::NoChange, 2);
  app::io::write_observation_csv(dir / "obs.csv", t, "ms", {"mL", "mmHg"});
  const auto cfg = write_file(dir / "cal.yaml",
                              "name: cal\nseed: 5\nsimulator: {model: test-beat, numerics: {samples: 41}}\n"
                              "observations:\n  file: obs.csv\n  indices: [EDV, EF]\n"
                              "  noise: {EDV: 3 mL, EF: 0.02}\n"
                              "estimate:\n  EF: {spread: 30 %}\n"
                              "calibration: {mode: iterate-keep-spread, max_iterations: 5, tolerance: 1.0e-3}\n");
  const CliRun r = run_with_summary("calibrate", cfg, dir, {"--threads", "1"});
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  expect_provenance(dir, "calibrate", cfg, true);

  // The same results file for h5py/xarray users: iteration groups zero-padded to the width of the
  // last iteration, and the name lists and time attached as HDF5 dimension scales (H5DS).
  std::vector<std::string> iterations;
  {
    app::io::Hdf5Reader f(dir / "r.h5");
    iterations = f.members("/ensemble");
  }
  ASSERT_FALSE(iterations.empty());
  for (const auto& it : iterations) EXPECT_EQ(it.size(), std::to_string(iterations.size() - 1).size()) << it;
  const hid_t file = H5Fopen((dir / "r.h5").string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hid_t params = H5Dopen2(file, "/estimate/names", H5P_DEFAULT);
  const hid_t obs = H5Dopen2(file, "/observations/names", H5P_DEFAULT);
  const hid_t time = H5Dopen2(file, "/trajectories/calibrated/time", H5P_DEFAULT);
  auto attached = [&](const std::string& path, hid_t scale, unsigned dim) {
    const hid_t d = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
    if (d < 0) return false;
    const bool yes = H5DSis_attached(d, scale, dim) > 0;
    H5Dclose(d);
    return yes;
  };
  EXPECT_TRUE(attached("/estimate/mean", params, 0));
  EXPECT_TRUE(attached("/estimate/eta_covariance", params, 1));
  EXPECT_TRUE(attached("/observations/y", obs, 0));
  EXPECT_TRUE(attached("/fit/after", obs, 0));
  EXPECT_TRUE(attached("/ensemble/" + iterations.front() + "/theta", params, 1));
  EXPECT_TRUE(attached("/ensemble/" + iterations.front() + "/z", obs, 1));
  EXPECT_TRUE(attached("/trajectories/calibrated/V_lv", time, 0));
  EXPECT_FALSE(attached("/trajectories/calibrated/V_lv", params, 0));
  H5Dclose(time);
  H5Dclose(obs);
  H5Dclose(params);
  H5Fclose(file);
}

TEST(JsonProvenance, PersonalizeSummaryCarriesTheProvenance) {
  const auto dir = scratch_dir();
  const auto truth = write_file(dir / "truth.yaml", std::string("name: truth\n") + kTwoSegmentSimulator);
  std::ostringstream out, err;
  ASSERT_EQ(app::run_cli({"--log-level", "off", "synthesize", truth.string(), "-o", (dir / "regional.csv").string(),
                          "--frames", "20", "--channels", "V_seg01,V_seg02", "--seed", "4"},
                         out, err, models()),
            app::kExitOk)
      << err.str();
  const auto cfg = write_file(dir / "pers.yaml", two_segment_personalize("pers", "  filter: {beats: 1, threads: 1}\n"));
  const CliRun r = run_with_summary("personalize", cfg, dir);
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  expect_provenance(dir, "personalize", cfg, false);
}

TEST(JsonProvenance, SensitivitySummaryCarriesTheProvenance) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "s.yaml",
                              "name: s\nsimulator: {model: test-beat}\n"
                              "sensitivity:\n  method: sobol\n  model: ishigami\n  seed: 3\n"
                              "  sobol: {N: 64, bootstrap: 20, convergence_levels: 1}\n");
  const CliRun r = run_with_summary("sensitivity", cfg, dir, {"--threads", "1"});
  ASSERT_EQ(r.code, app::kExitOk) << r.err;
  expect_provenance(dir, "sensitivity", cfg, true);
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["provenance"]["seed"], 3);
}

TEST(JsonProvenance, SpecificitySummaryCarriesTheProvenance) {
  const auto dir = scratch_dir();
  std::filesystem::create_directories(dir / "data");
  std::string cases = "cases:\n";
  const double ef[] = {0.60, 0.58, 0.33, 0.31};
  for (int c = 0; c < 4; ++c) {
    BeatStandIn sim(BeatStandIn::defaults(), 41);
    Eigen::VectorXd theta(4);
    theta << 1.5e-4, ef[c], 16000.0, 0.0;
    model::Trajectory t = sim.run(theta).trajectory;
    t.channels.resize(2);
    t.values.conservativeResize(Eigen::NoChange, 2);
    const std::string name = "c" + std::to_string(c);
    app::io::write_observation_csv(dir / "data" / (name + ".csv"), t, "ms", {"mL", "mmHg"});
    cases += "  - {name: " + name + ", file: data/" + name + ".csv, group: " + (c < 2 ? "a" : "b") + "}\n";
  }
  const auto cfg = write_file(dir / "cohort.yaml",
                              "name: cohort\nsimulator: {model: test-beat, numerics: {samples: 41}}\n" + cases +
                                  "observations:\n  indices: [EDV, EF]\n  noise: {EDV: 3 mL, EF: 0.02}\n"
                                  "estimate:\n  EF: {spread: 40 %, transform: logit, bounds: [0.05, 0.9]}\n"
                                  "calibration: {mode: iterate-keep-spread, max_iterations: 5, tolerance: 1.0e-3}\n"
                                  "specificity: {groups: [a, b], threads: 1}\n");
  const CliRun r = run_with_summary("specificity", cfg, dir);
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  expect_provenance(dir, "specificity", cfg, false);
}

}  // namespace
}  // namespace sigmaheart::testing
