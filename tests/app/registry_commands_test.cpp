// The real commands on a model registered from tests/ (tests/support/two_segment_model.h): the
// registry handed to run_cli is the only thing that makes "test-two-segment" known, and the
// commands find its segments by tags. The contract suite runs on it unchanged.
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "tests/app/test_support.h"
#include "tests/app/two_segment_config.h"
#include "tests/model/simulator_contract.h"
#include "tests/support/two_segment_model.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <sstream>

namespace sigmaheart::testing {
namespace {

// The built-in models plus the two-segment test model.
const model::ModelRegistry& models() {
  static const model::ModelRegistry registry = with_models(model::builtin_models(), {register_two_segment_model});
  return registry;
}

// The two-segment model alone, for the contract suite.
const model::ModelRegistry& test_model_only() {
  static const model::ModelRegistry registry = with_models(model::ModelRegistry{}, {register_two_segment_model});
  return registry;
}

INSTANTIATE_TEST_SUITE_P(TestModel, SimulatorContract, ::testing::ValuesIn(contract_cases(test_model_only())),
                         contract_case_name);

CliRun run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, models());
  return {code, out.str(), err.str()};
}

nlohmann::json read_json(const std::filesystem::path& p) { return nlohmann::json::parse(read_file(p)); }

// `command` on `config`, quiet, with results in dir/r.h5 and the JSON summary in dir/r.json;
// `extra` follows.
CliRun run_with_summary(const std::string& command, const std::filesystem::path& config,
                        const std::filesystem::path& dir, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {"--log-level", "off", command, config.string(), "-o", (dir / "r.h5").string(),
                                   "--summary", (dir / "r.json").string()};
  args.insert(args.end(), extra.begin(), extra.end());
  return run(args);
}

// Hidden truth: segment 1 hypokinetic, segment 2 normal, a raised peripheral resistance.
constexpr double kSigma1 = 3.5e4, kSigma2 = 6.0e4, kRd = 1.6e8;

TEST(RegistryCommands, TheBuiltinRegistryDoesNotKnowTheTestModel) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "m.yaml", std::string("name: m\n") + kTwoSegmentSimulator);
  std::ostringstream out, err;
  EXPECT_EQ(app::run_cli({"validate", cfg.string()}, out, err), app::kExitBadInput);
  EXPECT_NE(err.str().find("unknown value 'test-two-segment'"), std::string::npos) << err.str();
  const CliRun r = run({"validate", cfg.string()});
  EXPECT_EQ(r.code, app::kExitOk) << r.err;
}

TEST(RegistryCommands, ParamsShowsTheTagsOfEveryParameter) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "m.yaml", std::string("name: m\n") + kTwoSegmentSimulator);
  const CliRun r = run({"params", cfg.string()});
  ASSERT_EQ(r.code, app::kExitOk) << r.err;
  EXPECT_NE(r.out.find("name       unit"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("family"), std::string::npos) << r.out;
  std::istringstream lines(r.out);
  std::string line;
  int tagged = 0;
  while (std::getline(lines, line)) {
    if (line.rfind("sigma0_02", 0) == 0) {
      EXPECT_NE(line.find("contractility         2"), std::string::npos) << line;
    }
    if (line.rfind("R_d", 0) == 0) {
      EXPECT_NE(line.find("afterload_resistance  -"), std::string::npos) << line;
    }
    for (const auto& f : model::parameter_families()) tagged += line.find("  " + f + " ") != std::string::npos;
  }
  EXPECT_EQ(tagged, 6) << r.out;
}

TEST(RegistryCommands, CalibrateRecoversSegmentContractilitiesFromSynthesizedCurves) {
  const auto dir = scratch_dir();
  const auto truth = write_file(dir / "truth.yaml", std::string("name: truth\n") + kTwoSegmentSimulator);
  const auto csv = dir / "obs.csv";
  const CliRun s = run({"--log-level", "off", "synthesize", truth.string(), "-o", csv.string(), "--frames", "30",
                        "--channels", "V_lv,P_lv,V_seg01,V_seg02", "--noise", "V_seg01=0.5 mL", "--noise",
                        "V_seg02=0.5 mL", "--noise", "P_lv=1 mmHg", "--seed", "3", "--set",
                        "sigma0_01=" + std::to_string(kSigma1), "--set", "sigma0_02=" + std::to_string(kSigma2),
                        "--set", "R_d=" + std::to_string(kRd)});
  ASSERT_EQ(s.code, app::kExitOk) << s.err;
  const auto cfg = write_file(dir / "cal.yaml", std::string("name: cal\n") + kTwoSegmentSimulator + R"(observations:
  file: obs.csv
  curves: [V_seg01, V_seg02, P_lv]
  noise: {V_seg01: 0.5 mL, V_seg02: 0.5 mL, P_lv: 1 mmHg}
estimate:
  sigma0_01: {spread: 30 %}
  sigma0_02: {spread: 30 %}
  R_d: {spread: 20 %}
calibration: {mode: iterate-keep-spread, max_iterations: 15, tolerance: 1.0e-3}
)");
  const CliRun r = run_with_summary("calibrate", cfg, dir, {"--threads", "2"});
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  const auto j = read_json(dir / "r.json");
  const auto& p = j["parameters"];
  for (const auto& [name, value] : std::vector<std::pair<std::string, double>>{
           {"sigma0_01", kSigma1}, {"sigma0_02", kSigma2}, {"R_d", kRd}}) {
    const double estimate = p[name]["value"].get<double>();
    EXPECT_NEAR(estimate, value, 0.03 * value) << name;
    EXPECT_LT(std::abs(estimate - value), 3.0 * p[name]["std"].get<double>()) << name;
  }
  EXPECT_LT(j["rms_normalised_residual"].get<double>(), 1.3);
  EXPECT_GT(j["rms_normalised_residual_prior"].get<double>(), 3.0);
  EXPECT_EQ(j["failures"].get<int>(), 0);
}

TEST(RegistryCommands, SobolStudyOfTheTestModelSeesTheSymmetryOfItsSegments) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "sobol.yaml",
                              std::string("name: sobol\n") + kTwoSegmentSimulator +
                                  "sensitivity:\n"
                                  "  method: sobol\n"
                                  "  seed: 7\n"
                                  "  outputs: [EF, P_max]\n"
                                  "  parameters:\n"
                                  "    sigma0_01: {relative: 0.3}\n"
                                  "    sigma0_02: {relative: 0.3}\n"
                                  "    R_d: {relative: 0.1}\n"
                                  "  sobol: {N: 128, bootstrap: 50, convergence_levels: 2}\n"
                                  "  ensemble: {threads: 2}\n");
  const CliRun r = run_with_summary("sensitivity", cfg, dir);
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  const auto j = read_json(dir / "r.json");
  EXPECT_TRUE(j["valid"].get<bool>());
  EXPECT_EQ(j["runs"], 128 * 5);
  const auto& ef = j["indices"]["EF"]["parameters"];
  const double s1 = ef["sigma0_01"]["S1"].get<double>(), s2 = ef["sigma0_02"]["S1"].get<double>();
  // The two segments enter the model symmetrically with equal ranges: equal first-order indices.
  EXPECT_NEAR(s1, s2, 0.1);
  EXPECT_GT(s1 + s2, 0.6);  // contractility drives EF over a 30 % range, R_d over 10 % less so
  EXPECT_LT(ef["R_d"]["ST"].get<double>(), std::min(s1, s2));
  double sum = 0.0;
  for (const char* name : {"sigma0_01", "sigma0_02", "R_d"}) sum += ef[name]["S1"].get<double>();
  EXPECT_NEAR(sum, 1.0, 0.1);  // nearly additive over these ranges
}

// Personalisation of the two segments with the ROUKF from their regional volumes: the personalize
// command finds the segments by their tags (family "contractility", "regional_volume" channels)
// and the period by the tag "period", with no change to app/ or estimation/ for this model.
TEST(RegistryCommands, PersonalizeFindsTheSegmentsOfTheTestModelByTags) {
  const auto dir = scratch_dir();
  const auto truth = write_file(dir / "truth.yaml", std::string("name: truth\n") + kTwoSegmentSimulator);
  const auto csv = dir / "regional.csv";
  const CliRun s = run({"--log-level", "off", "synthesize", truth.string(), "-o", csv.string(), "--frames", "30",
                        "--channels", "V_seg01,V_seg02", "--noise", "V_seg01=0.3 mL", "--noise", "V_seg02=0.3 mL",
                        "--seed", "4", "--set", "sigma0_01=" + std::to_string(kSigma1), "--set",
                        "sigma0_02=" + std::to_string(kSigma2)});
  ASSERT_EQ(s.code, app::kExitOk) << s.err;
  const auto cfg = write_file(dir / "pers.yaml", two_segment_personalize("pers", R"(
  filter: {beats: 3, forgetting: 0.9, r_inflation: 2, threads: 2}
  truth:
    sigma0: [35 kPa, 60 kPa]
)"));
  const CliRun r = run_with_summary("personalize", cfg, dir);
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  const auto j = read_json(dir / "r.json");
  EXPECT_EQ(j["termination"], "completed");
  EXPECT_EQ(j["members"], 3);  // simplex: 2 parameters + 1
  const double s1 = j["parameters"]["sigma0_01"]["value"].get<double>();
  const double s2 = j["parameters"]["sigma0_02"]["value"].get<double>();
  EXPECT_EQ(j["parameters"]["sigma0_02"]["segment"], 2);
  EXPECT_NEAR(s1, kSigma1, 0.1 * kSigma1);
  EXPECT_NEAR(s2, kSigma2, 0.1 * kSigma2);
  EXPECT_LT(j["parameters"]["sigma0_01"]["std"].get<double>(), j["parameters"]["sigma0_01"]["prior_std"].get<double>());
}

}  // namespace
}  // namespace sigmaheart::testing
