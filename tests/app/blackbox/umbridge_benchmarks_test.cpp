// Item 2 of issue 44: models that are not hearts. The UM-Bridge analytic banana (served as the
// official benchmark serves it, by our python3 server umbridge_models.py) in a Sobol' study of its
// log density with the model's `config` passed through, against the exact indices; a calibration
// of named output elements of a model with two input and two output vectors, against the exact
// Kalman posterior (the model is linear in what is observed).
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/sensitivity_setup.h"
#include "tests/app/blackbox/python_server.h"
#include "tests/app/test_support.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <sstream>
#include <variant>

namespace sigmaheart::testing {
namespace {

namespace fs = std::filesystem;

// The banana's log density (UM-Bridge benchmark "Analytic Banana": Z ~ N((0, 4), scale [[1, .5],
// [.5, 1]]), T(x) = (x1 / a, a x2 + a b (x1^2 + a^2)), log pi = log f_Z(T(x))).
double banana(double x1, double x2, double a, double b, double scale) {
  const double y1 = x1 / a, y2 = a * x2 + a * b * (x1 * x1 + a * a) - 4.0;
  const double det = 0.75 * scale * scale;
  const double q = scale * (y1 * y1 - y1 * y2 + y2 * y2) / det;
  return -std::log(2.0 * M_PI) - 0.5 * std::log(det) - 0.5 * q;
}

// Exact first-order and total Sobol' indices of f on the box (x1, x2 uniform): log pi is a
// polynomial of degree 4, so an 8-point Gauss-Legendre rule per axis integrates every moment used
// (degree <= 8) exactly.
struct Exact {
  std::array<double, 2> S1, ST;
};
Exact exact_indices(double l1, double u1, double l2, double u2, double a, double b, double scale) {
  static const double xg[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                               0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
  static const double wg[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                               0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
  double f[8][8], mean = 0.0;
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j) {
      f[i][j] = banana(l1 + (u1 - l1) * (xg[i] + 1) / 2, l2 + (u2 - l2) * (xg[j] + 1) / 2, a, b, scale);
      mean += wg[i] * wg[j] / 4 * f[i][j];
    }
  }
  double var = 0.0, v1 = 0.0, v2 = 0.0;
  for (int i = 0; i < 8; ++i) {
    double m1 = 0.0, m2 = 0.0;  // E[f | x1 = node i], E[f | x2 = node i]
    for (int j = 0; j < 8; ++j) {
      m1 += wg[j] / 2 * f[i][j];
      m2 += wg[j] / 2 * f[j][i];
      var += wg[i] * wg[j] / 4 * (f[i][j] - mean) * (f[i][j] - mean);
    }
    v1 += wg[i] / 2 * (m1 - mean) * (m1 - mean);
    v2 += wg[i] / 2 * (m2 - mean) * (m2 - mean);
  }
  // Two inputs: ST1 = 1 - S2 (first order of the other), and the reverse.
  return {{v1 / var, v2 / var}, {1.0 - v2 / var, 1.0 - v1 / var}};
}

TEST(UmbridgeBenchmarks, OurBananaServerGivesTheOfficialTestValues) {
  // benchmarks/analytic-banana/test_output.py of the UM-Bridge benchmarks: log pi(0, 0) and
  // log pi(2, 0) with the default config.
  EXPECT_NEAR(banana(0.0, 0.0, 2.0, 0.2, 1.0), -5.534036030183454, 1e-13);
  EXPECT_NEAR(banana(2.0, 0.0, 2.0, 0.2, 1.0), -3.3207026968501214, 1e-13);
  const PythonServer server(benchmark_script(), {"--model", "banana", "--port", "0"});
  ASSERT_FALSE(server.url().empty());
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "b.yaml", "name: b\nsimulator:\n  model: umbridge\n  numerics:\n    url: " +
                                                  server.url() + "\n    name: posterior\n"
                                                  "    outputs: [{name: log_density, unit: \"1\", size: 1}]\n"
                                                  "    parameters:\n"
                                                  "      - {name: x1, unit: \"1\", nominal: 0, lower: -3, upper: 3, input: 0}\n"
                                                  "      - {name: x2, unit: \"1\", nominal: 0, lower: -1, upper: 4, input: 0}\n");
  const app::Config config = app::load_config(cfg, {}, app::blackbox::cli_models());
  auto sim = config.simulator.make();
  ASSERT_EQ(sim->channels().size(), 1u);
  for (const auto& [x1, want] : {std::pair{0.0, -5.534036030183454}, std::pair{2.0, -3.3207026968501214}}) {
    const model::RunResult r = sim->run((Eigen::VectorXd(2) << x1, 0.0).finished());
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    ASSERT_EQ(r.trajectory.samples(), 1);
    EXPECT_EQ(r.trajectory.values(0, 0), want);  // bit for bit through JSON
  }
}

TEST(UmbridgeBenchmarks, SobolIndicesOfTheBananaWithItsConfigMatchTheExactOnes) {
  const PythonServer server(benchmark_script(), {"--model", "banana", "--port", "0"});
  ASSERT_FALSE(server.url().empty());
  const auto dir = scratch_dir();
  // A config other than the default (a, b, scale): the indices below hold only if it arrives.
  const double a = 1.5, b = 0.5, scale = 2.0;
  const auto cfg = write_file(
      dir / "s.yaml", "name: s\nsimulator:\n  model: umbridge\n  numerics:\n    url: " + server.url() +
                          "\n    name: posterior\n    config: {a: 1.5, b: 0.5, scale: 2.0}\n"
                          "    outputs: [{name: log_density, unit: \"1\", size: 1}]\n"
                          "    parameters:\n"
                          "      - {name: x1, unit: \"1\", nominal: 0, lower: -3, upper: 3}\n"
                          "      - {name: x2, unit: \"1\", nominal: 0, lower: -2, upper: 2}\n"
                          "sensitivity:\n  method: sobol\n  seed: 11\n  model_outputs: [log_density]\n"
                          "  parameters:\n    x1: {lower: -2.5, upper: 2.5}\n    x2: {lower: -1.5, upper: 1.5}\n"
                          "  sobol: {N: 512, bootstrap: 200, convergence_levels: 1}\n"
                          "  ensemble: {backend: threads, threads: 2}\n");
  const app::Config config = app::load_config(cfg, {}, app::blackbox::cli_models());
  const app::SensitivitySetup setup = app::parse_sensitivity(config);
  const auto summary = std::get<estimation::sensitivity::SobolSummary>(app::run_sensitivity_study(setup));
  ASSERT_TRUE(summary.ok()) << summary.message;
  const Exact exact = exact_indices(-2.5, 2.5, -1.5, 1.5, a, b, scale);
  const Exact other = exact_indices(-2.5, 2.5, -1.5, 1.5, 2.0, 0.2, 1.0);  // the default config
  const auto& e = summary.estimate;
  for (int i = 0; i < 2; ++i) {
    EXPECT_LE(std::abs(e.S1(i, 0) - exact.S1[static_cast<size_t>(i)]), e.S1_conf(i, 0)) << summary.report();
    EXPECT_LE(std::abs(e.ST(i, 0) - exact.ST[static_cast<size_t>(i)]), e.ST_conf(i, 0)) << summary.report();
  }
  // Had the config not arrived, x2's first-order index (0.763 instead of 0.241) would be outside.
  EXPECT_GT(std::abs(e.S1(1, 0) - other.S1[1]), e.S1_conf(1, 0)) << summary.report();
}

// [[x], [y]] -> [[x + y], [x y, x - y]]: observe s = x + y and v[1] = x - y (linear in x and y);
// prior x ~ N(1, 1), y ~ N(0.5, 1), noise 0.5 each: the posterior is exactly Gaussian,
// mean mu0 + C H^T R^-1 (y - H mu0) = (17/9, 17/18), C = (I + H^T R^-1 H)^-1 = I / 9.
TEST(UmbridgeBenchmarks, CalibratingNamedOutputsOfSeveralVectorsGivesTheExactPosterior) {
  const PythonServer server(benchmark_script(), {"--model", "split", "--port", "0"});
  ASSERT_FALSE(server.url().empty());
  const auto dir = scratch_dir();
  const auto cfg = write_file(
      dir / "c.yaml", "name: c\nsimulator:\n  model: umbridge\n  numerics:\n    url: " + server.url() +
                          "\n    name: forward\n"
                          "    outputs: [{name: s, unit: \"1\"}, {name: v, unit: \"1\", size: 2}]\n"
                          "    parameters:\n"
                          "      - {name: x, unit: \"1\", nominal: 1, lower: -100, upper: 100, input: 0}\n"
                          "      - {name: y, unit: \"1\", nominal: 0.5, lower: -100, upper: 100, input: 1}\n"
                          "observations:\n  outputs:\n    s: {value: 3, noise: 0.5}\n    \"v[1]\": {value: 1, noise: 0.5}\n"
                          "estimate:\n  x: {spread: 100 %, transform: identity}\n  y: {spread: 200 %, transform: identity}\n");
  std::ostringstream out, err;
  ASSERT_EQ(app::run_cli({"--log-level", "off", "calibrate", cfg.string(), "-o", (dir / "c.h5").string(),
                          "--summary", (dir / "c.json").string()},
                         out, err, app::blackbox::cli_models()),
            app::kExitOk)
      << err.str() << out.str();
  const auto j = nlohmann::json::parse(read_file(dir / "c.json"));
  EXPECT_NEAR(j["parameters"]["x"]["value"].get<double>(), 17.0 / 9.0, 1e-9) << j.dump(1);
  EXPECT_NEAR(j["parameters"]["y"]["value"].get<double>(), 17.0 / 18.0, 1e-9);
  EXPECT_NEAR(j["parameters"]["x"]["std"].get<double>(), 1.0 / 3.0, 1e-9);
  EXPECT_NEAR(j["parameters"]["y"]["std"].get<double>(), 1.0 / 3.0, 1e-9);
  // Correlated noise (covariance: replaces the noises): the exact posterior with that R.
  std::string correlated = read_file(cfg);
  correlated.replace(correlated.find("estimate:"), 0, "  covariance: [[0.25, 0.125], [0.125, 0.25]]\n");
  std::ostringstream out3, err3;
  ASSERT_EQ(app::run_cli({"--log-level", "off", "calibrate", write_file(dir / "r.yaml", correlated).string(), "-o",
                          (dir / "r.h5").string(), "--summary", (dir / "r.json").string()},
                         out3, err3, app::blackbox::cli_models()),
            app::kExitOk)
      << err3.str();
  const Eigen::Matrix2d H = (Eigen::Matrix2d() << 1, 1, 1, -1).finished();
  const Eigen::Matrix2d Rinv = (Eigen::Matrix2d() << 0.25, 0.125, 0.125, 0.25).finished().inverse();
  const Eigen::Matrix2d C = (Eigen::Matrix2d::Identity() + H.transpose() * Rinv * H).inverse();
  const Eigen::Vector2d mu0(1.0, 0.5), y(3.0, 1.0);
  const Eigen::Vector2d mean = mu0 + C * H.transpose() * Rinv * (y - H * mu0);
  const auto jr = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_NEAR(jr["parameters"]["x"]["value"].get<double>(), mean(0), 1e-9) << jr.dump(1);
  EXPECT_NEAR(jr["parameters"]["y"]["value"].get<double>(), mean(1), 1e-9);
  EXPECT_NEAR(jr["parameters"]["x"]["std"].get<double>(), std::sqrt(C(0, 0)), 1e-9);
  EXPECT_NEAR(jr["parameters"]["y"]["std"].get<double>(), std::sqrt(C(1, 1)), 1e-9);
  // An output the model does not have is bad input at its key.
  std::string text = read_file(cfg);
  text.replace(text.find("\"v[1]\""), 6, "\"v[2]\"");
  std::ostringstream out2, err2;
  EXPECT_EQ(app::run_cli({"validate", write_file(dir / "d.yaml", text).string()}, out2, err2,
                         app::blackbox::cli_models()),
            app::kExitBadInput);
  EXPECT_NE(err2.str().find("unknown model output 'v[2]'"), std::string::npos) << err2.str();
}

}  // namespace
}  // namespace sigmaheart::testing
