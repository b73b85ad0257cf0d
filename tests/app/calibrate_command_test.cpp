// `sigmaheart calibrate` through the command line (app/commands/calibrate.cpp,
// app/calibration_setup.cpp): a small twin on the lumped sphere end to end, and the promised
// located errors (exit code 2) for bad configs and malformed observation files.
#include "app/cli.h"
#include "app/errors.h"
#include "tests/app/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <sstream>

namespace sigmaheart::app {
namespace {

using namespace sigmaheart::testing;

const std::string kHealthy = std::string(SIGMAHEART_SOURCE_DIR) + "/configs/healthy.yaml";

// Observations of a hidden truth (sigma0 5.3e4 Pa, P_at0 950 Pa; the healthy preset has 5.8e4 Pa,
// 1050 Pa) at 30 frames with noise.
std::filesystem::path make_observations(const std::filesystem::path& dir) {
  const auto csv = dir / "obs.csv";
  const CliRun r = cli({"--log-level", "off", "synthesize", kHealthy, "-o", csv.string(), "--offset", "12",
                        "--noise", "V_lv=2 mL", "--noise", "P_lv=1.5 mmHg", "--seed", "5",
                        "--set", "sigma0=5.3e4", "--set", "P_at0=950"});
  EXPECT_EQ(r.code, kExitOk) << r.err;
  return csv;
}

const std::string kObservations =
    "  file: obs.csv\n  curves: [V_lv, P_lv]\n  noise: {V_lv: 2 mL, P_lv: 1.5 mmHg}\n";

std::string config(const std::string& estimate, const std::string& observations = kObservations,
                   const std::string& calibration = "{mode: map, max_iterations: 15, tolerance: 1.0e-2}") {
  // The prior is the healthy preset, the model of the observations but for the estimates.
  return "name: twin\nsimulator:\n  {model: lumped-sphere, preset: healthy}\nobservations:\n" + observations +
         "estimate:\n" + estimate + "calibration: " + calibration + "\n";
}

TEST(CalibrateCommand, AThreadCountBeyondTheLimitIsBadInputNotACrash) {
  // --threads 100000 used to crash the process when OpenMP could not create the team.
  const auto dir = scratch_dir();
  make_observations(dir);
  const auto cfg = write_file(dir / "cal.yaml", config("  sigma0: {spread: 20 %}\n"));
  const CliRun flag = cli({"--log-level", "off", "calibrate", cfg.string(), "-o",
                           (dir / "r.h5").string(), "--threads", "100000"});
  EXPECT_EQ(flag.code, kExitBadInput);
  EXPECT_NE(flag.err.find("--threads: Value 100000 not in range 1 to 1024"), std::string::npos)
      << flag.err;
  const auto in_config = write_file(
      dir / "cal2.yaml",
      config("  sigma0: {spread: 20 %}\n", kObservations, "{mode: map, threads: 5000}"));
  const CliRun key = cli({"--log-level", "off", "calibrate", in_config.string(), "-o",
                          (dir / "r.h5").string()});
  EXPECT_EQ(key.code, kExitBadInput);
  EXPECT_NE(key.err.find("threads must lie in [0, 1024]"), std::string::npos) << key.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "r.h5"));
}

TEST(CalibrateCommand, RecoversAHiddenTruthFromSynthesizedCurves) {
  const auto dir = scratch_dir();
  make_observations(dir);
  const auto cfg = write_file(dir / "cal.yaml", config("  sigma0: {spread: 20 %}\n  P_at0: {spread: 20 %}\n"));
  const CliRun r = cli({"--log-level", "off", "calibrate", cfg.string(), "-o", (dir / "r.h5").string(),
                        "--summary", (dir / "r.json").string(), "--threads", "2"});
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  const double sigma0 = j["parameters"]["sigma0"]["value"].get<double>();
  const double pat0 = j["parameters"]["P_at0"]["value"].get<double>();
  EXPECT_NEAR(sigma0, 5.3e4, 0.05 * 5.3e4);
  EXPECT_NEAR(pat0, 950.0, 0.05 * 950.0);
  EXPECT_LT(std::abs(sigma0 - 5.3e4), 3.0 * j["parameters"]["sigma0"]["std"].get<double>());
  EXPECT_EQ(j["parameters"]["sigma0"]["unit"], "Pa");
  EXPECT_LT(j["rms_normalised_residual"].get<double>(), 1.3);  // a fit at the noise level
  EXPECT_GT(j["rms_normalised_residual_prior"].get<double>(), 2.0);
  EXPECT_EQ(j["failures"].get<int>(), 0);
  EXPECT_EQ(j["status"], "converged");
  EXPECT_EQ(j["mode"], "map");
  EXPECT_TRUE(std::filesystem::exists(dir / "r.h5"));
  EXPECT_EQ(temporaries_in(dir), 0);
  EXPECT_NE(r.out.find("RMS residual in noise standard deviations"), std::string::npos);
}

TEST(CalibrateCommand, AGlobalStartFromAFarPriorListsEveryStartAndKeepsTheBestObjective) {
  const auto dir = scratch_dir();
  make_observations(dir);
  // Prior a third below the truth of sigma0 (5.3e4 Pa); `log` is given as logit on the model's
  // bounds [0, 1e7] Pa, so no member can leave them.
  const auto cfg = write_file(
      dir / "cal.yaml",
      config("  sigma0: {prior: 3.5e4, spread: 30 %}\n  P_at0: {spread: 20 %}\n", kObservations,
             "{max_iterations: 20, tolerance: 1.0e-2, global_start: {samples: 8, keep: 2}}"));
  const CliRun r = cli({"--log-level", "off", "calibrate", cfg.string(), "-o", (dir / "r.h5").string(),
                        "--summary", (dir / "r.json").string(), "--threads", "2"});
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  ASSERT_EQ(j["starts"].size(), 2u);
  double best = j["objective"].get<double>();
  for (const auto& st : j["starts"]) EXPECT_GE(st["objective"].get<double>(), best);
  EXPECT_NEAR(j["parameters"]["sigma0"]["value"].get<double>(), 5.3e4, 0.05 * 5.3e4);
  EXPECT_NE(read_file(dir / "r.h5").find("logit"), std::string::npos);  // /estimate/transform
}

// A calibration that is not a success: exit 1, the status in words on stderr, in the JSON summary
// and in the HDF5 results, which are still written.
struct FailedCase {
  std::string estimate;
  std::string calibration;
  std::string status;  // UtTermination in words
};

TEST(CalibrateCommand, EveryOutcomeButConvergedExitsOneAndStillWritesItsStatus) {
  const auto dir = scratch_dir();
  make_observations(dir);
  const std::vector<FailedCase> cases = {
      {"  sigma0: {spread: 20 %}\n  P_at0: {spread: 20 %}\n", "{max_iterations: 1}",
       "stopped at the iteration limit"},
      // The truth (5.3e4 Pa) lies above the bounds; a vague prior lets the estimate reach them.
      {"  sigma0: {prior: 3.0e4, spread: 5 eta, transform: logit, bounds: [1.0e4, 5.0e4]}\n",
       "{max_iterations: 40, tolerance: 1.0e-3}", "stuck at a bound"},
      // A prior far from the data with a small spread: one linear update is not to be trusted.
      {"  sigma0: {prior: 2.5e4, spread: 5 %}\n", "{mode: one-shot}", "one-shot update not trusted"},
      // APD members beyond the heart period (0.85 s) fail; the abort policy gives up.
      {"  APD: {prior: 0.8, spread: 10 %}\n", "{failure_policy: abort}", "aborted (failed runs)"},
  };
  for (const auto& c : cases) {
    std::filesystem::remove(dir / "r.h5");
    std::filesystem::remove(dir / "r.json");
    const auto cfg = write_file(dir / "cal.yaml", config(c.estimate, kObservations, c.calibration));
    const CliRun r = cli({"--log-level", "off", "calibrate", cfg.string(), "-o", (dir / "r.h5").string(),
                          "--summary", (dir / "r.json").string(), "--threads", "2"});
    EXPECT_EQ(r.code, kExitRuntimeFailure) << c.status << "\n" << r.err;
    EXPECT_NE(r.err.find(c.status), std::string::npos) << r.err;
    ASSERT_TRUE(std::filesystem::exists(dir / "r.json")) << c.status;
    const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
    EXPECT_EQ(j["status"], c.status) << j["message"];
    EXPECT_FALSE(j["ok"].get<bool>());
    ASSERT_TRUE(std::filesystem::exists(dir / "r.h5")) << c.status;
    EXPECT_NE(read_file(dir / "r.h5").find(c.status), std::string::npos);  // /summary@status
  }
}

struct BadCase {
  std::string yaml;
  std::string where;  // expected location prefix
  std::string words;  // expected words of the message
};

// method: least-squares (the Ceres MAP solver) recovers the same truth and reports through the
// same files; reference: least-squares runs it beside the UT, whose objective must then equal the
// MAP objective (the UT's map mode lands on the MAP point, docs/estimation.md s.3.2) to 1e-3.
TEST(CalibrateCommand, LeastSquaresMethodAndReferenceReachTheMapPointAndWriteTheFitReport) {
  const auto dir = scratch_dir();
  make_observations(dir);
  const std::string estimate = "  sigma0: {spread: 20 %}\n  P_at0: {spread: 20 %}\n";
  const auto lsq = write_file(dir / "lsq.yaml", config(estimate, kObservations, "{method: least-squares}"));
  const CliRun a = cli({"--log-level", "off", "calibrate", lsq.string(), "-o", (dir / "a.h5").string(),
                        "--summary", (dir / "a.json").string(), "--threads", "2"});
  ASSERT_EQ(a.code, kExitOk) << a.err;
  const auto ja = nlohmann::json::parse(read_file(dir / "a.json"));
  EXPECT_EQ(ja["status"], "converged");
  EXPECT_NEAR(ja["parameters"]["sigma0"]["value"].get<double>(), 5.3e4, 0.05 * 5.3e4);
  EXPECT_EQ(ja["map"]["termination"], "converged");
  EXPECT_EQ(ja["fit_report"]["channels"].size(), 2u);
  EXPECT_NE(a.out.find("MAP least squares"), std::string::npos) << a.out;
  EXPECT_NE(read_file(dir / "a.h5").find("fit_report"), std::string::npos);

  const auto ref = write_file(dir / "ref.yaml", config(estimate, kObservations,
                                                       "{tolerance: 1.0e-4, reference: least-squares}"));
  const CliRun b = cli({"--log-level", "off", "calibrate", ref.string(), "-o", (dir / "b.h5").string(),
                        "--summary", (dir / "b.json").string(), "--threads", "2"});
  ASSERT_EQ(b.code, kExitOk) << b.err;
  const auto jb = nlohmann::json::parse(read_file(dir / "b.json"));
  EXPECT_NEAR(jb["objective"].get<double>() / jb["map"]["cost"].get<double>(), 1.0, 1e-3) << b.out;
  EXPECT_NEAR(jb["parameters"]["sigma0"]["value"].get<double>(), ja["parameters"]["sigma0"]["value"].get<double>(),
              0.1 * jb["parameters"]["sigma0"]["std"].get<double>());
  EXPECT_NE(b.out.find("UT objective / MAP objective"), std::string::npos) << b.out;
}

TEST(CalibrateCommand, BadConfigsGiveLocatedErrorsExitTwoAndKeepTheOldResult) {
  const auto dir = scratch_dir();
  make_observations(dir);
  write_file(dir / "bad.csv", "time [ms], V_lv [mL]\n0, 140\n28, 139\n57, abc\n85, 120\n");
  const std::vector<BadCase> cases = {
      {config("  sigma_0: {spread: 20 %}\n"), "cal.yaml:9:", "did you mean 'sigma0'"},
      {config("  sigma0: {spread: 0.2}\n"), "cal.yaml:9:", "percentage"},
      {config("  sigma0: {spread: 20 %, transform: logt}\n"), "cal.yaml:9:", "logit"},
      {config("  sigma0: {spread: 20 %}\n", "  file: nowhere.csv\n  curves: [V_lv]\n  noise: {V_lv: 2 mL}\n"),
       "cal.yaml:5:", "does not exist"},
      {config("  sigma0: {spread: 20 %}\n", "  file: bad.csv\n  curves: [V_lv]\n  noise: {V_lv: 2 mL}\n"),
       "bad.csv:4:", "number"},
      {config("  sigma0: {spread: 20 %}\n", "  file: obs.csv\n  curves: [V_lv]\n"), "", "noise"},
      {config("  sigma0: {spread: 20 %}\n", "  file: obs.csv\n  indices: [EDV, ESVV]\n  noise: {default: 5 %}\n"),
       "cal.yaml:", "ESV"},
      {config("  sigma0: {spread: 20 %}\n", kObservations, "{method: ceres}"), "cal.yaml:10:23:", "least-squares"},
      {config("  sigma0: {spread: 20 %}\n", kObservations, "{least_squares: {relative_step: 0.5}}"),
       "cal.yaml:10:", "relative_step"},
  };
  write_file(dir / "r.h5", "an earlier result");
  for (const auto& c : cases) {
    const auto cfg = write_file(dir / "cal.yaml", c.yaml);
    const CliRun r = cli({"--log-level", "off", "calibrate", cfg.string(), "-o", (dir / "r.h5").string()});
    EXPECT_EQ(r.code, kExitBadInput) << c.yaml << r.err;
    EXPECT_NE(r.err.find(c.where), std::string::npos) << c.yaml << "\n" << r.err;
    EXPECT_NE(r.err.find(c.words), std::string::npos) << c.yaml << "\n" << r.err;
    EXPECT_EQ(read_file(dir / "r.h5"), "an earlier result");
  }
}

// The fit figure draws the model on the data's time axis (issue 45, item 5): the arrays it plots
// for the calibrated beat, interpolated at the frames' times (periodic, linear, as the curve
// sampler reads a beat), are /fit/after to 1e-9; with end-diastole alignment the model's clock is
// shifted (time_offset != 0) and the title names the data's case, not the config's name.
TEST(CalibrateCommand, TheFitFigureDrawsTheCalibratedBeatThroughFitAfterOnTheDataClock) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib, h5py' > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "Debian's python3 with matplotlib and h5py is not installed";
  }
  const auto dir = scratch_dir();
  make_observations(dir);
  const auto cfg = write_file(
      dir / "cal.yaml",
      config("  sigma0: {spread: 20 %}\n", kObservations + "  align: end-diastole\n",
             "{mode: map, max_iterations: 2, tolerance: 1.0e-2}"));
  const CliRun r = cli({"--log-level", "off", "calibrate", cfg.string(), "-o", (dir / "r.h5").string(),
                        "--threads", "2"});
  ASSERT_TRUE(r.code == kExitOk || r.code == kExitRuntimeFailure) << r.err;
  const auto script = write_file(dir / "readback.py", R"(
import sys
import h5py
import numpy as np
sys.path.insert(0, sys.argv[1] + "/scripts")
import sigmaplot_calibrate as sc
with h5py.File(sys.argv[2], "r") as f:
    names = [sc.text(n) for n in f["observations/names"][()]]
    after = f["fit/after"][()]
    t_frames = f["observations"].attrs["frame_origin"] + f["observations/frame_times"][()]
    period = float(f["fit/curves/calibrated"].attrs["period"])
    curves = sc.aligned_model_curves(f, "calibrated")
    worst = 0.0
    for ch in ("V_lv", "P_lv"):
        idx = [i for i, n in enumerate(names) if n.startswith(ch + "@")]
        t, v, _ = curves[ch]
        z = np.interp(t_frames, t, v, period=period)
        worst = max(worst, float(np.max(np.abs(z - after[idx]) / np.maximum(1.0, np.abs(after[idx])))))
    print(f"{worst:.3e} {curves['time_offset']:.6f} {sc.case_title(f, 'calibration fit')}")
)");
  const std::string cmd = "/usr/bin/python3 '" + script.string() + "' '" + SIGMAHEART_SOURCE_DIR + "' '" +
                          (dir / "r.h5").string() + "' > '" + (dir / "out.txt").string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << read_file(dir / "out.txt");
  std::istringstream out(read_file(dir / "out.txt"));
  double worst = 1.0, offset = 0.0;
  std::string title;
  out >> worst >> offset;
  std::getline(out, title);
  EXPECT_LT(worst, 1e-9) << read_file(dir / "out.txt");
  EXPECT_GT(std::abs(offset), 1e-3);  // end-diastole alignment moves the model's clock
  EXPECT_NE(title.find("calibration fit \u2014 obs (config twin)"), std::string::npos) << title;
}

}  // namespace
}  // namespace sigmaheart::app
