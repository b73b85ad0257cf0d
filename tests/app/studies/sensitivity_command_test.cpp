// `sigmaheart sensitivity` end to end (app/commands/sensitivity.cpp): exact indices of the Ishigami
// function through the command, clinical units in the results, located config errors (exit 2),
// and the documented report of a Sobol' design with failed runs (exit 1, results file listing them).
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "app/sensitivity_setup.h"
#include "../test_support.h"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <hdf5_hl.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

namespace sigmaheart::app {
namespace {

using namespace sigmaheart::testing;

nlohmann::json read_json(const std::filesystem::path& p) { return nlohmann::json::parse(read_file(p)); }

// Writes `yaml` to dir/<file> and runs `sensitivity` on it with results in dir/r.h5 (and, with
// `summary`, dir/r.json); `extra` arguments are appended.
CliRun run_study(const std::filesystem::path& dir, const std::string& file, const std::string& yaml,
                 bool summary, std::vector<std::string> extra = {}) {
  const auto config = write_file(dir / file, yaml);
  std::vector<std::string> args = {"--log-level", "off", "sensitivity", config.string(), "-o",
                                   (dir / "r.h5").string()};
  if (summary) {
    args.push_back("--summary");
    args.push_back((dir / "r.json").string());
  }
  args.insert(args.end(), extra.begin(), extra.end());
  return cli(args);
}

const char* kIshigami =
    "name: ishigami\n"
    "simulator: {model: test-beat}\n"
    "sensitivity:\n"
    "  method: sobol\n"
    "  model: ishigami\n"
    "  seed: 11\n"
    "  sobol: {N: 2048, bootstrap: 300, convergence_levels: 3}\n"
    "  ensemble: {threads: 2}\n";

TEST(SensitivityCommand, IshigamiSobolReproducesExactIndicesWithinIntervals) {
  const auto dir = scratch_dir();
  const CliRun r = run_study(dir, "ishigami.yaml", kIshigami, true);
  ASSERT_EQ(r.code, kExitOk) << r.err << r.out;
  // Exact values (Ishigami & Homma 1990, a = 7, b = 0.1).
  const double S1[] = {0.3139, 0.4424, 0.0};
  const double ST[] = {0.5576, 0.4424, 0.2437};
  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.string_attribute("/", "kind"), "sensitivity");
  EXPECT_EQ(f.string_attribute("/analysis", "method"), "sobol");
  EXPECT_NE(f.string_attribute("/analysis/sobol", "estimators").find("Jansen"), std::string::npos);
  const Eigen::MatrixXd s1 = f.read_matrix("/analysis/sobol/S1"), st = f.read_matrix("/analysis/sobol/ST");
  const Eigen::MatrixXd s1l = f.read_matrix("/analysis/sobol/S1_percentile_low");
  const Eigen::MatrixXd s1h = f.read_matrix("/analysis/sobol/S1_percentile_high");
  const Eigen::MatrixXd stl = f.read_matrix("/analysis/sobol/ST_percentile_low");
  const Eigen::MatrixXd sth = f.read_matrix("/analysis/sobol/ST_percentile_high");
  // SALib's names: S1_conf / ST_conf, half-widths of the 95 % bootstrap interval.
  const Eigen::MatrixXd s1c = f.read_matrix("/analysis/sobol/S1_conf"), stc = f.read_matrix("/analysis/sobol/ST_conf");
  EXPECT_FALSE(f.exists("/analysis/sobol/S1_low"));
  ASSERT_EQ(s1.rows(), 3);
  ASSERT_EQ(s1.cols(), 1);
  for (int i = 0; i < 3; ++i) {
    // Within 0.005 of the 95 % bootstrap interval (the interval itself is a random quantity) and
    // within 0.05 of the exact value.
    EXPECT_GE(S1[i], s1l(i, 0) - 0.005) << "S1 x" << i + 1;
    EXPECT_LE(S1[i], s1h(i, 0) + 0.005) << "S1 x" << i + 1;
    EXPECT_GE(ST[i], stl(i, 0) - 0.005) << "ST x" << i + 1;
    EXPECT_LE(ST[i], sth(i, 0) + 0.005) << "ST x" << i + 1;
    EXPECT_NEAR(s1(i, 0), S1[i], 0.05);
    EXPECT_NEAR(st(i, 0), ST[i], 0.05);
    EXPECT_LT(s1h(i, 0) - s1l(i, 0), 0.2);  // the intervals are informative
    EXPECT_GT(s1c(i, 0), 0.0);
    EXPECT_NEAR(s1c(i, 0), 0.5 * (s1h(i, 0) - s1l(i, 0)), 0.3 * s1c(i, 0)) << "S1_conf x" << i + 1;
    EXPECT_NEAR(stc(i, 0), 0.5 * (sth(i, 0) - stl(i, 0)), 0.3 * stc(i, 0)) << "ST_conf x" << i + 1;
    EXPECT_LE(std::abs(s1(i, 0) - S1[i]), s1c(i, 0) + 0.005) << "S1 x" << i + 1;
    EXPECT_LE(std::abs(st(i, 0) - ST[i]), stc(i, 0) + 0.005) << "ST x" << i + 1;
  }
  const Eigen::VectorXd exact = f.read_vector("/analysis/exact/ST");
  EXPECT_NEAR(exact(2), 0.2437, 1e-4);
  // Convergence tables at N, N/2, N/4, zero-padded to the width of N so they sort as text.
  EXPECT_TRUE(f.exists("/analysis/sobol/convergence/n0512/ST_conf"));
  EXPECT_TRUE(f.exists("/analysis/sobol/convergence/n2048/S1"));
  EXPECT_FALSE(f.exists("/analysis/sobol/convergence/n512"));
  std::vector<std::string> members = f.members("/analysis/sobol/convergence");
  std::sort(members.begin(), members.end());  // as h5py lists them: by name
  EXPECT_EQ(members, (std::vector<std::string>{"n", "n0512", "n1024", "n2048"}));
  EXPECT_EQ(f.read_matrix("/analysis/design/z").rows(), 2048 * 5);
  EXPECT_EQ(f.read_strings("/analysis/design/block")[2 * 2048], "AB_1 (x1)");

  const auto j = read_json(dir / "r.json");
  EXPECT_EQ(j["kind"], "sensitivity");
  EXPECT_EQ(j["method"], "sobol");
  EXPECT_TRUE(j["valid"].get<bool>());
  EXPECT_EQ(j["runs"], 2048 * 5);
  EXPECT_EQ(j["indices"]["y"]["ranking"][0], "x1");  // ST: 0.56 > 0.44 > 0.24
  EXPECT_NEAR(j["indices"]["y"]["parameters"]["x2"]["S1"].get<double>(), 0.4424, 0.05);
  EXPECT_NEAR(j["indices"]["y"]["parameters"]["x2"]["S1_conf"].get<double>(), s1c(1, 0), 1e-12);
  EXPECT_NEAR(j["indices"]["y"]["parameters"]["x3"]["ST_conf"].get<double>(), stc(2, 0), 1e-12);
  EXPECT_EQ(j["indices"]["y"]["parameters"]["x1"]["S1_percentile_interval"].size(), 2u);
  EXPECT_FALSE(j["indices"]["y"]["parameters"]["x1"].contains("S1_low"));
  EXPECT_EQ(j["confidence"].get<double>(), 0.95);
  EXPECT_FALSE(j["second_order"].get<bool>());
  EXPECT_NEAR(j["exact"]["S1"][1].get<double>(), 0.4424, 1e-4);
  EXPECT_NE(r.out.find("exact indices"), std::string::npos);
}

// Second-order indices through the command (sobol: {second_order: true}): S2 / S2_conf per output
// as p x p matrices in HDF5 and per pair in JSON; Ishigami's only interaction is x1 x3, exact
// S13 = 0.2437 (Ishigami & Homma 1990; Sobol' & Levitan 1999), S12 = S23 = 0.
TEST(SensitivityCommand, SecondOrderIndicesGoToHdf5AndJson) {
  const auto dir = scratch_dir();
  std::string yaml = kIshigami;
  yaml.replace(yaml.find("convergence_levels: 3}"), 22, "convergence_levels: 2, second_order: true}");
  const CliRun r = run_study(dir, "ishigami2.yaml", yaml, true);
  ASSERT_EQ(r.code, kExitOk) << r.err << r.out;
  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.read_matrix("/analysis/design/z").rows(), 2048 * 8);  // N (2p + 2)
  EXPECT_EQ(f.read_strings("/analysis/design/block")[5 * 2048], "BA_1 (x1)");
  const Eigen::MatrixXd S2 = f.read_matrix("/analysis/sobol/S2/y");
  const Eigen::MatrixXd conf = f.read_matrix("/analysis/sobol/S2_conf/y");
  ASSERT_EQ(S2.rows(), 3);
  ASSERT_EQ(S2.cols(), 3);
  EXPECT_TRUE(std::isnan(S2(0, 0)) && std::isnan(S2(2, 0)) && std::isnan(S2(1, 1)));
  EXPECT_NEAR(S2(0, 2), 0.2437, 0.05);
  EXPECT_NEAR(S2(0, 1), 0.0, 0.05);
  EXPECT_NEAR(S2(1, 2), 0.0, 0.05);
  EXPECT_GT(conf(0, 2), 0.0);
  EXPECT_LT(conf(0, 2), 0.1);
  EXPECT_TRUE(f.exists("/analysis/sobol/convergence/n1024/S2/y"));
  EXPECT_NEAR(f.read_matrix("/analysis/exact/S2")(0, 2), 0.2437, 1e-4);
  const Eigen::MatrixXd s1 = f.read_matrix("/analysis/sobol/S1");
  EXPECT_NEAR(s1(0, 0), 0.3139, 0.05);  // first order from the same design
  EXPECT_NEAR(s1(1, 0), 0.4424, 0.05);

  const auto j = read_json(dir / "r.json");
  EXPECT_TRUE(j["second_order"].get<bool>());
  EXPECT_EQ(j["runs"], 2048 * 8);
  EXPECT_NEAR(j["indices"]["y"]["S2"]["x1"]["x3"].get<double>(), S2(0, 2), 1e-12);
  EXPECT_NEAR(j["indices"]["y"]["S2_conf"]["x1"]["x3"].get<double>(), conf(0, 2), 1e-12);
  EXPECT_FALSE(j["indices"]["y"]["S2"].contains("x3"));  // pairs i < k only
  EXPECT_NEAR(j["exact"]["S2"]["x1"]["x3"].get<double>(), 0.2437, 1e-4);
  EXPECT_NE(r.out.find("largest interaction S2(x1, x3)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("S2(x1, x3) 0.2437 ("), std::string::npos) << r.out;  // the exact table
}

// The parameter and output name lists are HDF5 dimension scales attached to the axes of the
// tables they index (what h5py's `dims` and xarray read as coordinates); checked with the HDF5
// C API (H5DS, hdf5_hl).
TEST(SensitivityCommand, NameListsAreDimensionScalesOfTheTables) {
  const auto dir = scratch_dir();
  std::string yaml = kIshigami;
  yaml.replace(yaml.find("N: 2048, bootstrap: 300"), 23, "N: 64, bootstrap: 20   ");
  const CliRun r = run_study(dir, "ishigami.yaml", yaml, false);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  {
    io::Hdf5Reader probe(dir / "r.h5");  // readable by our own reader with the scales attached
    EXPECT_EQ(probe.read_strings("/analysis/parameters/names").size(), 3u);
  }
  const hid_t file = H5Fopen((dir / "r.h5").string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hid_t params = H5Dopen2(file, "/analysis/parameters/names", H5P_DEFAULT);
  const hid_t outputs = H5Dopen2(file, "/analysis/outputs/names", H5P_DEFAULT);
  EXPECT_GT(H5DSis_scale(params), 0);
  EXPECT_GT(H5DSis_scale(outputs), 0);
  char label[64] = {};
  EXPECT_GT(H5DSget_scale_name(params, label, sizeof(label)), 0);
  EXPECT_STREQ(label, "parameter");
  for (const char* table : {"/analysis/sobol/S1", "/analysis/sobol/ST_conf", "/analysis/sobol/convergence/n64/S1_conf"}) {
    const hid_t d = H5Dopen2(file, table, H5P_DEFAULT);
    ASSERT_GE(d, 0) << table;
    EXPECT_GT(H5DSis_attached(d, params, 0), 0) << table << " rows: parameters";
    EXPECT_GT(H5DSis_attached(d, outputs, 1), 0) << table << " columns: outputs";
    EXPECT_EQ(H5DSis_attached(d, outputs, 0), 0) << table;
    H5Dclose(d);
  }
  const hid_t theta = H5Dopen2(file, "/analysis/design/theta", H5P_DEFAULT);
  EXPECT_GT(H5DSis_attached(theta, params, 1), 0);
  EXPECT_EQ(H5DSget_num_scales(theta, 0), 0);  // the run axis has no names
  H5Dclose(theta);
  const hid_t exact = H5Dopen2(file, "/analysis/exact/S1", H5P_DEFAULT);
  EXPECT_GT(H5DSis_attached(exact, params, 0), 0);
  H5Dclose(exact);
  H5Dclose(params);
  H5Dclose(outputs);
  H5Fclose(file);
}

const char* kStandInOat =
    "name: oat\n"
    "simulator:\n"
    "  model: test-beat\n"
    "  numerics: {samples: 81}\n"
    "  parameters: {V_ed: 150 mL, EF: 0.6}\n"
    "sensitivity:\n"
    "  method: oat\n"
    "  outputs: [EDV, EF, P_max]\n"
    "  parameters:\n"
    "    V_ed: {relative: 0.1}\n"
    "    EF: {relative: 0.1}\n"
    "  oat: {mode: range}\n";

TEST(SensitivityCommand, OatReportsClinicalUnits) {
  const auto dir = scratch_dir();
  const CliRun r = run_study(dir, "oat.yaml", kStandInOat, true, {"--threads", "1"});
  ASSERT_EQ(r.code, kExitOk) << r.err;
  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.read_strings("/analysis/outputs/units"), (std::vector<std::string>{"mL", "%", "mmHg"}));
  const Eigen::VectorXd z = f.read_vector("/analysis/oat/z_nominal");
  EXPECT_NEAR(z(0), 150.0, 1e-6);  // EDV = V_ed
  EXPECT_NEAR(z(1), 60.0, 1e-6);   // EF in %
  EXPECT_NEAR(z(2), 16000.0 / 133.322387415, 1e-3);
  // V_ed +-10 % moves EDV by -+15 mL and leaves EF alone; EF +-10 % moves EF by -+6 points.
  const Eigen::MatrixXd dl = f.read_matrix("/analysis/oat/delta_low"), dh = f.read_matrix("/analysis/oat/delta_high");
  EXPECT_NEAR(dl(0, 0), -15.0, 1e-6);
  EXPECT_NEAR(dh(0, 0), 15.0, 1e-6);
  EXPECT_NEAR(dh(0, 1), 0.0, 1e-9);
  EXPECT_NEAR(dl(1, 1), -6.0, 1e-6);
  EXPECT_NEAR(f.read_matrix("/analysis/oat/normalised")(0, 0), 1.0, 1e-9);  // EDV proportional to V_ed
  const auto j = read_json(dir / "r.json");
  EXPECT_EQ(j["indices"]["EDV"]["unit"], "mL");
  EXPECT_EQ(j["indices"]["EDV"]["ranking"][0], "V_ed");
  EXPECT_NEAR(j["indices"]["EF"]["parameters"]["EF"]["swing"].get<double>(), 12.0, 1e-6);
  EXPECT_NE(r.out.find("EDV (nominal 150 mL)"), std::string::npos) << r.out;
}

// A study whose `fail` parameter exceeds 0.5 in 1/6 of the design: the stand-in reports kDiverged.
std::string failing_sobol(const std::string& policy) {
  return "name: failing\n"
         "simulator: {model: test-beat, numerics: {samples: 41}}\n"
         "sensitivity:\n"
         "  method: sobol\n"
         "  outputs: [EDV, EF]\n"
         "  parameters:\n"
         "    V_ed: {relative: 0.2}\n"
         "    fail: {lower: 0.0, upper: 0.6}\n"
         "  sobol: {N: 64, bootstrap: 50, convergence_levels: 2, failure_policy: " + policy + "}\n";
}

TEST(SensitivityCommand, SobolDesignWithFailedRunsWritesTheReportAndExitsOne) {
  const auto dir = scratch_dir();
  const CliRun r = run_study(dir, "failing.yaml", failing_sobol("stop"), true);
  ASSERT_EQ(r.code, kExitRuntimeFailure) << r.err << r.out;
  EXPECT_NE(r.err.find("/analysis/failed"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("failed run"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("diverged"), std::string::npos) << r.out;

  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.double_attribute("/analysis/sobol", "valid"), 0.0);
  EXPECT_FALSE(f.exists("/analysis/sobol/S1"));  // no silent numbers
  const Eigen::MatrixXd theta = f.read_matrix("/analysis/design/theta");
  const Eigen::MatrixXd z = f.read_matrix("/analysis/design/z");
  int expected = 0;
  for (Eigen::Index i = 0; i < theta.rows(); ++i) {
    const bool fails = theta(i, 1) > 0.5;
    expected += fails;
    EXPECT_EQ(std::isnan(z(i, 0)), fails) << "run " << i;
  }
  EXPECT_GT(expected, 0);
  const int count = static_cast<int>(f.double_attribute("/analysis/failed", "count"));
  EXPECT_EQ(count, expected);
  const Eigen::MatrixXd failed_theta = f.read_matrix("/analysis/failed/theta");
  ASSERT_EQ(failed_theta.rows(), expected);
  EXPECT_GT(failed_theta.col(1).minCoeff(), 0.5);
  const auto codes = f.read_strings("/analysis/failed/code");
  EXPECT_EQ(codes.front(), "diverged");
  const auto j = read_json(dir / "r.json");
  EXPECT_FALSE(j["valid"].get<bool>());
  EXPECT_EQ(j["failed_runs"].size(), static_cast<size_t>(expected));
  EXPECT_NE(j["failed_runs"][0]["message"].get<std::string>().find("Newton diverged"), std::string::npos);
  EXPECT_EQ(j["status"], "failed-runs");
}

TEST(SensitivityCommand, SobolImputeMeanPolicyFlagsTheResultAndExitsZero) {
  const auto dir = scratch_dir();
  const CliRun r = run_study(dir, "failing.yaml", failing_sobol("impute-mean"), false);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  io::Hdf5Reader f(dir / "r.h5");
  EXPECT_EQ(f.double_attribute("/analysis/sobol", "imputed"), 1.0);
  EXPECT_GT(f.double_attribute("/analysis/failed", "count"), 0.0);
  EXPECT_NE(f.string_attribute("/analysis/sobol", "message").find("imput"), std::string::npos);
}

struct BadConfig {
  std::string yaml;
  std::string location;  // "file:line:column" suffix expected in the message
  std::string words;     // expected in the message
};

TEST(SensitivityCommand, BadConfigsGiveLocatedErrorsAndExitTwo) {
  const auto dir = scratch_dir();
  const std::string head = "name: bad\nsimulator: {model: test-beat}\nsensitivity:\n";
  const std::vector<BadConfig> cases = {
      {head + "  method: sobbol\n", "bad.yaml:4:11", "sobol"},
      {head + "  method: sobol\n  sobl: {N: 64}\n", "bad.yaml:5:3", "did you mean 'sobol'"},
      {head + "  method: sobol\n  model: ishigami\n  sobol: {N: 100}\n", "bad.yaml:6:", "power of two"},
      {head + "  method: oat\n  parameters:\n    V_edd: {relative: 0.1}\n", "bad.yaml:6:5", "V_ed"},
      {head + "  method: oat\n  parameters:\n    V_ed: {relative: 1.5}\n", "bad.yaml:6:", "(0, 1)"},
      {head + "  method: oat\n  outputs: [EDV, EFF]\n  parameters:\n    V_ed: {relative: 0.1}\n", "bad.yaml:5:",
       "EFF"},
      // N = 2^30 with the 3 Ishigami inputs: 5.4e9 runs, beyond an int (it overflowed before).
      {head + "  method: sobol\n  model: ishigami\n  sobol: {N: 1073741824}\n", "bad.yaml:6:",
       "the design would run 5368709120 simulations, more than 100000000; choose a smaller N"},
  };
  for (const auto& c : cases) {
    const CliRun r = run_study(dir, "bad.yaml", c.yaml, false);
    EXPECT_EQ(r.code, kExitBadInput) << c.yaml << r.err;
    EXPECT_NE(r.err.find(c.location), std::string::npos) << c.yaml << "\n" << r.err;
    EXPECT_NE(r.err.find(c.words), std::string::npos) << c.yaml << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "r.h5"));
  }
}

TEST(SensitivityCommand, MorrisDropsTrajectoriesWithFailedRunsAndSaysSo) {
  const auto dir = scratch_dir();
  const CliRun r = run_study(dir, "m.yaml",
                             "name: m\nsimulator: {model: test-beat, numerics: {samples: 41}}\n"
                             "sensitivity:\n  method: morris\n  outputs: [EDV]\n  parameters:\n"
                             "    V_ed: {relative: 0.2}\n    fail: {lower: 0.0, upper: 0.6}\n"
                             "  morris: {trajectories: 20, bootstrap: 100}\n",
                             true);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const auto j = read_json(dir / "r.json");
  const size_t dropped = j["trajectories_dropped"].size();
  EXPECT_GT(dropped, 0u);
  EXPECT_EQ(j["trajectories_used"].get<size_t>() + dropped, 20u);
  // EDV = V_ed: mu* of V_ed is the EDV change over the whole range, 0.4 x 140 mL (the stand-in's
  // default V_ed) = 56 mL, and sigma is 0 (a linear effect).
  EXPECT_NEAR(j["indices"]["EDV"]["parameters"]["V_ed"]["mu_star"].get<double>(), 56.0, 1e-6);
  EXPECT_NEAR(j["indices"]["EDV"]["parameters"]["V_ed"]["sigma"].get<double>(), 0.0, 1e-9);
  EXPECT_NE(r.out.find("dropped for failed runs"), std::string::npos);
}

TEST(SensitivitySetup, ParametersBecomeAUniformPriorInTheModelInputOrder) {
  const auto dir = scratch_dir();
  const auto path = write_file(dir / "s.yaml",
                               "name: s\nsimulator: {model: test-beat}\nsensitivity:\n  method: morris\n"
                               "  outputs: [EDV]\n  parameters:\n    EF: {lower: 0.4, upper: 0.8}\n"
                               "    V_ed: {relative: 0.5, space: eta, transform: log}\n"
                               "  morris: {trajectories: 7}\n");
  const SensitivitySetup s = parse_sensitivity(load_config(path, {}, sigmaheart::testing::stand_in_models()));
  ASSERT_EQ(s.prior.size(), 2);
  EXPECT_EQ(s.prior.names(), (std::vector<std::string>{"EF", "V_ed"}));
  EXPECT_EQ(s.model->input_names(), s.prior.names());
  EXPECT_EQ(s.prior[0].kind, estimation::PriorKind::kUniform);
  EXPECT_DOUBLE_EQ(s.prior[0].lower, 0.4);
  EXPECT_DOUBLE_EQ(s.prior[0].theta_nominal, 0.6);  // the stand-in's EF
  EXPECT_EQ(s.prior[1].space, estimation::SamplingSpace::kEta);
  EXPECT_DOUBLE_EQ(s.prior[1].upper, 1.5 * 1.4e-4);
  EXPECT_EQ(s.method, SensitivityMethod::kMorris);
  EXPECT_EQ(s.runs(), 7 * 3);
}

}  // namespace
}  // namespace sigmaheart::app
