// Item 1 of issue 44: every value that crosses a black-box adapter is converted by its declared
// unit, and a returned curve's time axis is the model's own. One model, the test beat with a
// period, in clinical units on purpose (umbridge_models.py "units": inputs mL, 1, kPa, ms; outputs
// mL, mmHg, kPa, times in ms), run as an external program and behind UM-Bridge (times returned,
// or the period taken from theta), must give the in-process SI curves at every theta, also when
// the period is moved.
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/config.h"
#include "app/errors.h"
#include "tests/app/blackbox/python_server.h"
#include "tests/app/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <tuple>

namespace sigmaheart::testing {
namespace {

namespace fs = std::filesystem;

// The model in SI, in-process: (times [s], V_lv [m^3], P_lv [Pa]) at 21 frames of one period.
model::Trajectory in_process(const Eigen::VectorXd& theta) {
  const int n = 21;
  model::Trajectory t;
  t.times.resize(n);
  t.values.resize(n, 3);
  for (int k = 0; k < n; ++k) {
    const double period = theta(3);
    const double tk = k == n - 1 ? period : period * k / (n - 1);
    const double phi = 2.0 * M_PI * tk / period;
    t.times(k) = tk;
    t.values(k, 0) = theta(0) * (1.0 - theta(1) * 0.5 * (1.0 - std::cos(phi)));
    t.values(k, 1) = 1000.0 + (theta(2) - 1000.0) * std::pow(std::sin(phi / 2.0), 4);
    t.values(k, 2) = t.values(k, 1);
  }
  return t;
}

const std::string kParameters =
    "    parameters:\n"
    "      - {name: V_ed, unit: mL, nominal: 140, lower: 50, upper: 300}\n"
    "      - {name: EF, unit: \"1\", nominal: 0.6, lower: 0.1, upper: 0.9}\n"
    "      - {name: P_peak, unit: kPa, nominal: 16, lower: 5, upper: 40}\n"
    "      - {name: period, unit: ms, nominal: 800, lower: 400, upper: 1500, family: period}\n"
    "    channels:\n"
    "      - {name: V_lv, unit: mL}\n"
    "      - {name: P_lv, unit: mmHg}\n"
    "      - {name: P_kpa, unit: kPa}\n";

fs::path external_config(const fs::path& dir) {
  return write_file(dir / "ext.yaml", "name: ext\nsimulator:\n  model: external\n  numerics:\n"
                                      "    command: \"/usr/bin/python3 " + benchmark_script() +
                                          " --params {params} --out {output}\"\n"
                                          "    workdir: runs\n    output: curves.csv\n    timeout: 30 s\n" +
                                          kParameters);
}

fs::path umbridge_config(const fs::path& dir, const std::string& url, const std::string& time_axis) {
  return write_file(dir / "umb.yaml", "name: umb\nsimulator:\n  model: umbridge\n  numerics:\n    url: " + url +
                                          "\n    name: forward\n    timeout: 30 s\n    frames: 21\n" + time_axis +
                                          kParameters);
}

void expect_in_process_curves(model::Simulator& sim, const std::string& what) {
  // Nominal; another volume and pressure; the period moved both ways (a study of it).
  for (const auto& [v_ed, p_peak, period] : std::vector<std::tuple<double, double, double>>{
           {140e-6, 16e3, 0.8}, {123.456e-6, 21.5e3, 0.8}, {140e-6, 16e3, 0.56}, {140e-6, 16e3, 1.1}}) {
    const Eigen::VectorXd theta = (Eigen::VectorXd(4) << v_ed, 0.6, p_peak, period).finished();
    const model::RunResult r = sim.run(theta);
    ASSERT_TRUE(r.status.ok()) << what << ": " << r.status.message;
    const model::Trajectory want = in_process(theta);
    ASSERT_EQ(r.trajectory.samples(), 21) << what;
    EXPECT_NEAR(r.info.period, period, 1e-12 * period) << what;
    for (int k = 0; k < 21; ++k) {
      EXPECT_NEAR(r.trajectory.times(k), want.times(k), 1e-12 * period) << what << " frame " << k;
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(r.trajectory.values(k, c), want.values(k, c), 1e-12 * std::abs(want.values(k, c)))
            << what << " frame " << k << " channel " << c;
      }
    }
  }
}

TEST(UnitsAndTime, BothAdaptersGiveTheInProcessCurvesInSiAtTheModelsOwnTimes) {
  const auto dir = scratch_dir();
  const app::Config ext = app::load_config(external_config(dir), {}, app::blackbox::cli_models());
  EXPECT_EQ(ext.simulator.parameters[0].unit, "m^3");  // declared in mL, held in SI
  EXPECT_DOUBLE_EQ(ext.simulator.parameters[3].nominal, 0.8);
  expect_in_process_curves(*ext.simulator.make(), "external");

  const PythonServer server(benchmark_script(), {"--model", "units", "--port", "0"});
  ASSERT_FALSE(server.url().empty());
  const app::Config returned = app::load_config(
      umbridge_config(dir, server.url(), "    times: returned\n    time_unit: ms\n"), {}, app::blackbox::cli_models());
  expect_in_process_curves(*returned.simulator.make(), "umbridge, returned times");
  const app::Config from_theta =
      app::load_config(umbridge_config(dir, server.url(), "    period: period\n"), {}, app::blackbox::cli_models());
  expect_in_process_curves(*from_theta.simulator.make(), "umbridge, period from theta");
}

TEST(UnitsAndTime, AMissingOrUnknownUnitOrAFixedPeriodBesideAPeriodParameterIsBadInput) {
  const auto dir = scratch_dir();
  const PythonServer server(benchmark_script(), {"--model", "units", "--port", "0"});
  ASSERT_FALSE(server.url().empty());
  const auto expect_bad = [&](const std::string& time_axis, const std::string& from, const std::string& to,
                              const std::string& message) {
    std::string text = read_file(umbridge_config(dir, server.url(), time_axis));
    text.replace(text.find(from), from.size(), to);
    const auto cfg = write_file(dir / "bad.yaml", text);
    std::ostringstream out, err;
    EXPECT_EQ(app::run_cli({"validate", cfg.string()}, out, err, app::blackbox::cli_models()), app::kExitBadInput)
        << message;
    EXPECT_NE(err.str().find(message), std::string::npos) << err.str();
  };
  expect_bad("    period: period\n", "unit: mmHg", "unit: mmHG", "unknown unit 'mmHG'");
  expect_bad("    period: period\n", "{name: P_kpa, unit: kPa}", "{name: P_kpa}", "missing required key 'unit'");
  expect_bad("    period: period\n", "unit: ms, nominal", "unit: mss, nominal", "unknown unit 'mss'");
  expect_bad("    period: 0.8 s\n", "name: umb", "name: umb", "the period is parameter 'period' of the table");
  expect_bad("    times: returned\n    time_unit: mL\n", "name: umb", "name: umb", "expected a time unit");
}

}  // namespace
}  // namespace sigmaheart::testing
