// `sigmaheart personalize` on data that are not laid out as the model's beat (docs/estimation.md
// s.4.9), on five-patch twins (cheap: 6-11 members): frames that start elsewhere in the beat
// (align: end-diastole), activation times estimated with contractility, volume shares from the
// data, the start from a calibrate result, and a measured activation map; each bad input at its
// line and column.
#include "app/io/hdf5_writer.h"
#include "app/io/observation_file.h"
#include "model/lumped/regional.h"
#include "personalize_helpers.h"

#include <algorithm>
#include <cmath>

namespace sigmaheart::app::personalize_testing {
namespace {

using namespace sigmaheart::testing;

// Five patches activated 20-140 ms after the onset, 2 ms steps; `extra` lines go under numerics.
std::string five_patch_simulator(const std::string& extra = "") {
  return "simulator:\n  model: lumped-regional\n  numerics:\n    dt: 2.0e-3\n"
         "    area_shares: [0.3, 0.2, 0.2, 0.2, 0.1]\n"
         "    activation: {pattern: times, times: [20 ms, 50 ms, 80 ms, 110 ms, 140 ms]}\n" + extra;
}
const char* const kChannels = "V_seg01,V_seg02,V_seg03,V_seg04,V_seg05";

// 30 frames of the twin: patches 1 and 2 at 40 % of the 60 kPa prior, noise 0.05 mL.
std::filesystem::path synthesize_twin(const std::filesystem::path& dir, const std::string& simulator,
                                      const std::vector<std::string>& sets = {"sigma0_01=24000", "sigma0_02=24000"}) {
  const auto cfg = write_file(dir / "twin.yaml", "name: twin\n" + simulator);
  std::vector<std::string> args = {"synthesize", cfg.string(), "-o", (dir / "twin.csv").string(), "--frames", "30",
                                    "--seed", "46", "--channels", kChannels};
  for (int p = 1; p <= 5; ++p) {
    args.push_back("--noise");
    args.push_back("V_seg0" + std::to_string(p) + "=0.05 mL");
  }
  for (const auto& s : sets) {
    args.push_back("--set");
    args.push_back(s);
  }
  const CliRun r = cli(args);
  EXPECT_EQ(r.code, 0) << r.err;
  return dir / "twin.csv";
}

std::string personalize_section(const std::filesystem::path& data, const std::string& observations,
                                const std::string& estimate) {
  return "personalize:\n  observations:\n    file: " + data.string() +
         "\n    noise: 0.05 mL\n    start_beats: 3\n" + observations + "  estimate:\n" + estimate +
         "  filter: {passes: split, beats: 16, map_iterations: 10}\n";
}
const char* const kSigma0 = "    sigma0: {segments: all, prior: 6.0e4, spread: 50 %, transform: log}\n";

// The time shift left after the landmark alignment, estimated (model/time_shift.h).
const char* const kShift = "    t_shift: {prior: 0, spread: 10 ms, transform: identity}\n";

// Runs personalize; expected_code -1: a fit that may or may not reach its MAP point (exit 0 or 1,
// results written either way).
nlohmann::json run(const std::filesystem::path& dir, const std::string& name, const std::string& text,
                   int expected_code = 0) {
  const auto cfg = write_file(dir / (name + ".yaml"), "name: " + name + "\n" + text);
  const std::string json = (dir / (name + ".json")).string();
  const CliRun r = cli({"personalize", cfg.string(), "-o", (dir / (name + ".h5")).string(), "--summary", json,
                        "--threads", "2"});
  if (expected_code >= 0) {
    EXPECT_EQ(r.code, expected_code) << r.err;
  } else {
    EXPECT_TRUE(r.code == 0 || r.code == 1) << r.err;
  }
  return std::filesystem::exists(json) ? nlohmann::json::parse(read_file(json)) : nlohmann::json{};
}

double value(const nlohmann::json& j, const std::string& p) { return j["parameters"][p]["value"].get<double>(); }

// The twin's frames rotated by 7 (frame 7 first) and timed from 0: the file's t = 0 is 198 ms after
// the onset. Compared at the file's times as times after the ECG trigger the fit is far off; aligned
// on end-diastole (landmark 13 ms off at the frames' resolution, the cavity curve of the prior-mean
// beat 4 ms off) with the remaining shift t_shift estimated, it recovers the twin within 3 %
// (measured: max error 0.2 %, t_shift 4.17 +- 0.07 ms against the true 4.03, NIS 4.3 in its band
// 3.9-6.2) and reports where it put the frames.
TEST(PersonalizeSetup, FramesFromAnotherStartAreAlignedOnEndDiastole) {
  const auto dir = scratch_dir();
  const auto twin = synthesize_twin(dir, five_patch_simulator());
  io::ObservationCurves c = io::read_observation_csv(twin);
  const Eigen::Index n = c.trajectory.times.size();
  model::Trajectory shifted = c.trajectory;
  for (Eigen::Index k = 0; k < n; ++k) {
    shifted.times(k) = c.trajectory.times(k);  // 0, T/30, ...: frame k of the file is frame k + 7 of the beat
    shifted.values.row(k) = c.trajectory.values.row((k + 7) % n);
  }
  const auto data = dir / "shifted.csv";
  io::write_observation_csv(data, shifted, "ms", c.display_units, {"the twin's frames from frame 7 on"});

  const nlohmann::json ecg = run(dir, "ecg", five_patch_simulator() + personalize_section(data, "", kSigma0), -1);
  // The frames of the file's beat fall in two of the model's beats: the model must be periodic
  // there (8 beats from its relaxed state; 3 leave a NIS of 19 from the beat-to-beat change).
  std::string aligned = personalize_section(data, "    align: end-diastole\n", std::string(kSigma0) + kShift);
  aligned.replace(aligned.find("start_beats: 3"), 14, "start_beats: 8");
  const nlohmann::json ed = run(dir, "ed", five_patch_simulator() + aligned);
  ASSERT_FALSE(ed.empty());
  EXPECT_EQ(ed["termination"], "completed") << ed["message"];
  for (int p = 1; p <= 5; ++p) {
    const std::string name = "sigma0_0" + std::to_string(p);
    EXPECT_NEAR(value(ed, name) / (p <= 2 ? 24000.0 : 60000.0), 1.0, 0.03) << name;
  }
  EXPECT_LE(ed["nis_mean"].get<double>(), ed["nis_band_95"][1].get<double>());
  EXPECT_GT(ecg["nis_mean"].get<double>(), 10.0 * ecg["nis_band_95"][1].get<double>());
  // The file's end-diastole lies 7 frames (198 ms) before the beat's, modulo the period.
  const double shift = ed["setup"]["model_ed_time"].get<double>() - ed["setup"]["data_ed_time"].get<double>();
  EXPECT_NEAR(std::remainder(shift - 0.85 * 7 / 30, 0.85), 0.0, 0.85 / 60) << shift;
}

// Contractility and activation time of every patch from the regional volumes alone (ECG times):
// the activation times within 10 ms of the truth, the contractilities within 10 %, both informed.
TEST(PersonalizeSetup, ActivationAndContractilityAreRecoveredTogether) {
  const auto dir = scratch_dir();
  const auto twin = synthesize_twin(dir, five_patch_simulator());
  const std::string estimate =
      std::string(kSigma0) + "    Td: {segments: all, prior: 70 ms, spread: 40 ms, transform: logit, bounds: [0, 0.25]}\n";
  const nlohmann::json j = run(dir, "joint", five_patch_simulator() + personalize_section(twin, "", estimate));
  ASSERT_FALSE(j.empty());
  EXPECT_EQ(j["termination"], "completed") << j["message"];
  EXPECT_EQ(j["members"], 11);
  const double td[5] = {0.02, 0.05, 0.08, 0.11, 0.14};
  for (int p = 1; p <= 5; ++p) {
    const std::string s = "0" + std::to_string(p);
    EXPECT_NEAR(value(j, "Td_" + s), td[p - 1], 0.010) << "Td_" << s;
    EXPECT_NEAR(value(j, "sigma0_" + s) / (p <= 2 ? 24000.0 : 60000.0), 1.0, 0.10) << "sigma0_" << s;
    EXPECT_TRUE(j["parameters"]["Td_" + s]["informed"].get<bool>());
  }
}

// Data whose segments hold other shares of the cavity (a ventricle with area shares 0.1-0.3,
// synchronous: every segment keeps its share, V_p = V w_p) fitted by a model with equal shares:
// with its own shares the model cannot fit the curves' sizes; with `shares: data` it does, to the
// noise, and recovers the uniform contractility within 3 %.
TEST(PersonalizeSetup, VolumeSharesFromTheDataMakeTheRegionalVolumesTheSameQuantity) {
  const auto dir = scratch_dir();
  const std::string data_model =
      "simulator:\n  model: lumped-regional\n  numerics: {dt: 2.0e-3, area_shares: [0.3, 0.25, 0.2, 0.15, 0.1]}\n";
  const auto twin = synthesize_twin(dir, data_model, {"sigma0_01=5e4", "sigma0_02=5e4", "sigma0_03=5e4",
                                                     "sigma0_04=5e4", "sigma0_05=5e4"});
  const std::string model = "simulator:\n  model: lumped-regional\n  numerics: {dt: 2.0e-3, area_shares: [0.2, 0.2, 0.2, 0.2, 0.2]}\n";
  const nlohmann::json own = run(dir, "own", model + personalize_section(twin, "", kSigma0), -1);
  const nlohmann::json shared = run(dir, "shared", model + personalize_section(twin, "    shares: data\n", kSigma0));
  ASSERT_FALSE(shared.empty());
  EXPECT_EQ(shared["termination"], "completed") << shared["message"];
  EXPECT_GT(own["nis_mean"].get<double>(), 100.0 * own["nis_band_95"][1].get<double>());
  EXPECT_LE(shared["nis_mean"].get<double>(), shared["nis_band_95"][1].get<double>());
  for (int p = 1; p <= 5; ++p) EXPECT_NEAR(value(shared, "sigma0_0" + std::to_string(p)) / 5e4, 1.0, 0.03) << p;
  const auto& w = shared["setup"]["volume_shares"];
  ASSERT_EQ(w.size(), 5u);
  EXPECT_NEAR(w[0].get<double>(), 0.3, 0.005);
  EXPECT_NEAR(w[4].get<double>(), 0.1, 0.005);
}

// A measured activation map sets Td of the segments it lists; a bad map and a bad calibrate result
// are input errors at their line.
TEST(PersonalizeSetup, AnActivationMapSetsTheActivationTimesAndBadInputIsLocated) {
  const auto dir = scratch_dir();
  const auto twin = synthesize_twin(dir, five_patch_simulator());
  const auto map = write_file(dir / "map.csv", "# mapping\nsegment, time [ms]\n1, 25\n2, 45\n");
  const std::string section = personalize_section(twin, "", kSigma0) + "  activation: {file: " + map.string() + "}\n";
  const auto cfg = write_file(dir / "map.yaml", "name: map\n" + five_patch_simulator() + section);
  const CliRun ok = cli({"params", cfg.string()});  // the map does not change the config's own values
  EXPECT_EQ(ok.code, 0) << ok.err;
  const CliRun v = cli({"validate", cfg.string()});
  EXPECT_EQ(v.code, 0) << v.err;
  for (const auto& [text, where] : {std::pair<std::string, std::string>{"segment, time [ms]\n1, 25\n1, 30\n", "bad.csv:3:1"},
                                    {"segment, time [ms]\n9, 25\n", "bad.csv:2:1"},
                                    {"segment, t\n1, 25\n", "bad.csv:1:1"},
                                    {"segment, time [ms]\n1, soon\n", "bad.csv:2:4"}}) {
    write_file(dir / "bad.csv", text);
    const auto bad = write_file(dir / "badmap.yaml", "name: m\n" + five_patch_simulator() +
                                                         personalize_section(twin, "", kSigma0) +
                                                         "  activation: {file: " + (dir / "bad.csv").string() + "}\n");
    const CliRun r = cli({"validate", bad.string()});
    EXPECT_EQ(r.code, 2) << text;
    EXPECT_NE(r.err.find(where), std::string::npos) << text << ": " << r.err;
  }
}

// validate on the five-patch personalize config of `twin` that starts from the results file
// `start` is bad input located at the start's file: (start.yaml:16) and says `what`.
void expect_start_refused(const std::filesystem::path& dir, const std::filesystem::path& twin,
                          const std::filesystem::path& start, const std::string& what) {
  const auto cfg = write_file(dir / "start.yaml", "name: s\n" + five_patch_simulator() +
                                                      personalize_section(twin, "", kSigma0) +
                                                      "  start: {file: " + start.string() + "}\n");
  const CliRun r = cli({"validate", cfg.string()});
  EXPECT_EQ(r.code, 2) << start;
  EXPECT_NE(r.err.find("start.yaml:16:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
}

// A calibrate result of the sphere starts the regional filter: its posterior is the prior of the
// globals it estimated (co-estimated) and its contractility centres the segments'; held, the
// globals take its estimate. A results file of another kind, or of parameters the model lacks, is
// an input error at `file:`.
TEST(PersonalizeSetup, ACalibrateResultStartsTheGlobalsAndAMismatchIsLocated) {
  const auto dir = scratch_dir();
  const auto twin = synthesize_twin(dir, five_patch_simulator());
  // A small calibration of the sphere on the twin's cavity volume (the sum of the regional ones).
  io::ObservationCurves c = io::read_observation_csv(twin);
  model::Trajectory lv;
  lv.times = c.trajectory.times;
  lv.values = c.trajectory.values.rowwise().sum();
  lv.channels = {{"V_lv", "m^3", ""}};
  io::write_observation_csv(dir / "lv.csv", lv, "ms", {"mL"});
  const auto cal = write_file(dir / "cal.yaml",
                              "name: cal\nsimulator:\n  model: lumped-sphere\n  numerics: {dt: 2.0e-3}\n"
                              "observations:\n  file: lv.csv\n  curves: [V_lv]\n  noise: {V_lv: 0.5 mL}\n"
                              "estimate:\n  sigma0: {spread: 30 %, transform: log}\n  k_RS: {spread: 30 %, transform: log}\n"
                              "calibration: {mode: map, max_iterations: 8}\n");
  const CliRun rc = cli({"calibrate", cal.string(), "-o", (dir / "cal.h5").string()});
  ASSERT_TRUE(rc.code == 0 || rc.code == 1) << rc.err;  // converged or not, its posterior is written
  const std::string h5 = (dir / (rc.code == 0 ? "cal.h5" : "cal.failed.h5")).string();
  io::Hdf5Reader f(h5);
  const Eigen::VectorXd cal_mean = f.read_vector("/estimate/mean");
  const Eigen::VectorXd cal_eta = f.read_vector("/estimate/eta_mean");
  const Eigen::MatrixXd cal_P = f.read_matrix("/estimate/eta_covariance");
  const std::vector<std::string> cal_kinds = f.read_strings("/estimate/transform");

  for (const char* globals : {"estimate", "hold"}) {
    const std::string start = std::string("  start: {file: ") + h5 + ", globals: " + globals + "}\n";
    const std::string sigma = "    sigma0: {segments: all, spread: 50 %, transform: log}\n";
    const auto cfg = write_file(dir / "start.yaml", "name: s\n" + five_patch_simulator() +
                                                        personalize_section(twin, "", sigma) + start);
    const CliRun p = cli({"params", cfg.string()});
    ASSERT_EQ(p.code, 0) << p.err;
    const nlohmann::json j = run(dir, std::string("start-") + globals,
                                 five_patch_simulator() + personalize_section(twin, "", sigma) + start);
    ASSERT_FALSE(j.empty());
    // The segments' prior is centred on the calibrated sphere's sigma0.
    EXPECT_NEAR(j["parameters"]["sigma0_01"]["prior"].get<double>(), cal_mean(0), 1e-6 * cal_mean(0));
    if (std::string(globals) == "estimate") {
      ASSERT_TRUE(j["parameters"].contains("k_RS"));
      EXPECT_NEAR(j["parameters"]["k_RS"]["prior"].get<double>(), cal_mean(1), 1e-9 * cal_mean(1));
      // The calibration's std in eta carried over: T'(eta) sqrt(P_11), T the transform it used (a
      // log prior on a bounded parameter runs as logit on [max(lower, 0), upper]).
      const model::Parameter& q = model::lumped::RegionalVentricle::default_parameters()[
          model::lumped::RegionalVentricle::default_parameters().index_or_throw("k_RS")];
      const double lo = std::max(q.lower, 0.0), x = cal_mean(1);
      const double slope = cal_kinds[1] == "log" ? x : (x - lo) * (q.upper - x) / (q.upper - lo);
      EXPECT_NEAR(j["parameters"]["k_RS"]["prior_std"].get<double>(), slope * std::sqrt(cal_P(1, 1)), 1e-6 * x)
          << cal_kinds[1];
    } else {
      EXPECT_FALSE(j["parameters"].contains("k_RS"));
    }
  }
  // Another kind of results file; a calibration of parameters the model does not have.
  expect_start_refused(dir, twin, dir / "start-hold.h5", "is not a calibrate result");
  {  // A calibrate result of the sphere with an atrial chamber: E_at_min is no parameter here.
    io::Hdf5Writer w(dir / "atrium.h5");
    w.set_attribute("/", "kind", "calibrate");
    w.write_text("/config", "name: a\nsimulator: {model: lumped-sphere-atrium}\n");
    w.write_strings("/estimate/names", {"sigma0", "E_at_min"});
    w.write_strings("/estimate/transform", {"log", "log"});
    w.write_vector("/estimate/eta_mean", Eigen::Vector2d(0.1, 0.0), "1");
    w.write_vector("/estimate/mean", Eigen::Vector2d(6e4 * std::exp(0.1), 2e7), "SI");
    w.write_matrix("/estimate/eta_covariance", Eigen::Matrix2d::Identity() * 0.01, "1", {}, {});
    w.commit();
  }
  expect_start_refused(dir, twin, dir / "atrium.h5",
                       "estimates E_at_min, which model lumped-regional does not have");
  (void)cal_eta;
}

}  // namespace
}  // namespace sigmaheart::app::personalize_testing
