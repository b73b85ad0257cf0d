// The shrunk specificity experiment (experiments/specificity/README.md) on the lumped BCS sphere:
// a synthetic cohort of 3 + 3 cases in which only the contractility sigma0 differs between the
// groups (R_d varies within both), observed through the volume and pressure curves; calibrating
// sigma0 and R_d for every case, the study must name sigma0 first. About 1 s (6 calibrations).
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "app/io/observation_file.h"
#include "model/lumped/sphere.h"
#include "../test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sstream>

namespace sigmaheart::app {
namespace {

using namespace sigmaheart::testing;

TEST(SpecificityCohort, OnlySigma0DiffersAndTheStudyNamesSigma0First) {
  const auto dir = scratch_dir();
  std::filesystem::create_directories(dir / "data");
  struct Case {
    const char* name;
    const char* group;
    double sigma0, R_d;
  };
  const Case cohort[] = {{"v1", "healthy", 5.3e4, 0.90e8}, {"v2", "healthy", 5.6e4, 1.00e8},
                         {"v3", "healthy", 5.0e4, 1.10e8}, {"f1", "failing", 3.6e4, 1.00e8},
                         {"f2", "failing", 3.9e4, 1.10e8}, {"f3", "failing", 3.4e4, 0.90e8}};
  std::string cases = "cases:\n";
  for (const auto& c : cohort) {
    model::lumped::LumpedSphere sim;
    Eigen::VectorXd theta = sim.parameters().nominal();
    theta(sim.parameters().index_or_throw("sigma0")) = c.sigma0;
    theta(sim.parameters().index_or_throw("R_d")) = c.R_d;
    const auto run = sim.run(theta);
    ASSERT_TRUE(run.status.ok()) << run.status.message;
    // V_lv and P_lv of the periodic beat, every 10th sample (~85 frames).
    const model::Trajectory& full = run.trajectory;
    model::Trajectory t;
    std::vector<Eigen::Index> cols;
    for (size_t k = 0; k < full.channels.size(); ++k) {
      if (full.channels[k].name == "V_lv" || full.channels[k].name == "P_lv") {
        t.channels.push_back(full.channels[k]);
        cols.push_back(static_cast<Eigen::Index>(k));
      }
    }
    const Eigen::Index rows = (full.times.size() + 9) / 10;
    t.times.resize(rows);
    t.values.resize(rows, 2);
    for (Eigen::Index r = 0; r < rows; ++r) {
      t.times(r) = full.times(10 * r);
      for (int c2 = 0; c2 < 2; ++c2) t.values(r, c2) = full.values(10 * r, cols[static_cast<size_t>(c2)]);
    }
    io::write_observation_csv(dir / "data" / (std::string(c.name) + ".csv"), t, "ms", {"mL", "mmHg"});
    std::ostringstream s;
    s << "  - {name: " << c.name << ", file: data/" << c.name << ".csv, group: " << c.group
      << ", truth: {sigma0: " << c.sigma0 << ", R_d: " << c.R_d << "}}\n";
    cases += s.str();
  }
  const auto config = write_file(
      dir / "cohort.yaml",
      "name: shrunk-cohort\n"
      "simulator:\n"
      "  model: lumped-sphere\n"
      "  numerics: {dt: 1.0e-3, min_beats: 3, max_beats: 40, periodic_tolerance: 1.0e-3}\n" +
          cases +
          "observations:\n"
          "  indices: [EDV, ESV, EF, P_max]\n"
          "  noise: {EDV: 2 mL, ESV: 2 mL, EF: 0.01, P_max: 1.5 mmHg}\n"
          "estimate:\n"
          "  sigma0: {prior: 4.5e4, spread: 30 %}\n"
          "  R_d: {spread: 20 %}\n"
          "calibration: {mode: map, max_iterations: 20, tolerance: 1.0e-3}\n"
          "specificity: {groups: [healthy, failing]}\n");
  std::ostringstream out, err;
  const int code = run_cli({"--log-level", "off", "specificity", config.string(), "-o",
                            (dir / "r.h5").string(), "--summary", (dir / "r.json").string()},
                           out, err);
  ASSERT_EQ(code, kExitOk) << err.str() << out.str();
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["ranking"][0], "sigma0") << out.str();
  EXPECT_DOUBLE_EQ(j["statistics"]["sigma0"]["auc"].get<double>(), 0.0);  // AUC(failing > healthy)
  EXPECT_EQ(j["statistics"]["sigma0"]["direction"], "lower");
  EXPECT_NEAR(j["statistics"]["sigma0"]["mann_whitney_p"].get<double>(), 0.1, 1e-9);  // exact 3 vs 3: 2/20
  EXPECT_GT(j["statistics"]["R_d"]["mann_whitney_p"].get<double>(), 0.3);
  for (const auto& c : j["cases"]) {
    const double truth = c["estimate"]["sigma0"]["truth"].get<double>();
    EXPECT_NEAR(c["estimate"]["sigma0"]["value"].get<double>(), truth, 0.05 * truth) << c["name"];
  }
}

}  // namespace
}  // namespace sigmaheart::app
