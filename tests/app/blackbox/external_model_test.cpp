// `model: external` (app/blackbox/external_model.h): a python3 script (standard library only)
// written into each test's scratch directory stands in for anyone's simulator. Its parameter
// `fail` chooses what goes wrong: < 0.5 a good beat, [0.5, 0.6) exit code 3, [0.6, 0.7) a hang,
// [0.7, 0.8) garbage output, [0.8, 0.9) no output, >= 0.9 a NaN in the output.
#include "app/blackbox/command_template.h"
#include "app/blackbox/external_model.h"
#include "app/blackbox/process.h"
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "estimation/ensemble.h"
#include "estimation/forward_model.h"
#include "estimation/prior.h"
#include "estimation/roukf/roukf.h"
#include "observers/global_indices.h"
#include "tests/app/test_support.h"
#include "tests/model/simulator_contract.h"
#include "tests/support/expect_status.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <thread>

namespace sigmaheart::testing {
namespace {

namespace fs = std::filesystem;
namespace bb = app::blackbox;
using model::StatusCode;

// The same beat as BeatStandIn (tests/app/test_support.h), as a program.
const char* kBeatScript = R"(#!/usr/bin/env python3
import json, math, os, sys, time
args = dict(zip(sys.argv[1::2], sys.argv[2::2]))
p = json.load(open(args["--params"]))["parameters"]
out = args["--out"]
fail = p["fail"]
if 0.5 <= fail < 0.6:
    sys.stderr.write("starting\nmodel exploded at t = 0.3 s\n")
    sys.exit(3)
if 0.6 <= fail < 0.7:
    with open("pid.txt", "w") as f:
        f.write(str(os.getpid()))
    time.sleep(60)
if 0.8 <= fail < 0.9:
    sys.exit(0)
n, period = 81, 0.8
with open(out, "w") as f:
    if 0.7 <= fail < 0.8:
        f.write("this is not a CSV file\n\x00\x01garbage\n")
        sys.exit(0)
    f.write("time [s], V_lv [m^3], P_lv [Pa], phase [1]\n")
    for k in range(n):
        t = period * k / (n - 1)
        phi = 2.0 * math.pi * t / period
        s = 0.5 * (1.0 - math.cos(phi))
        v = p["V_ed"] * (1.0 - p["EF"] * s)
        if fail >= 0.9 and k == 40:
            v = float("nan")
        pr = 1000.0 + (p["P_peak"] - 1000.0) * math.sin(phi / 2.0) ** 4
        f.write("%r, %r, %r, %r\n" % (t, v, pr, 2.0 if phi < math.pi else 0.0))
)";

const char* kTable = R"(    parameters:
      - {name: V_ed, unit: m^3, nominal: 1.4e-4, lower: 1e-5, upper: 5e-4, family: unloaded_volume}
      - {name: EF, unit: "1", nominal: 0.6, lower: 0.05, upper: 0.9}
      - {name: P_peak, unit: Pa, nominal: 16000, lower: 1000, upper: 40000}
      - {name: fail, unit: "1", nominal: 0.0, lower: 0.0, upper: 1.0}
    channels:
      - {name: V_lv, unit: m^3}
      - {name: P_lv, unit: Pa}
      - {name: phase, unit: "1"}
)";

// The same beat in sh + awk (starts in about a millisecond, where python3 takes 50 ms to 1 s on
// a loaded machine): reads params.yaml; fail >= 0.5 crashes, in [0.6, 0.7) hangs in a child.
const char* kAwkScript = R"(#!/bin/sh
if awk '/^  fail: / { h = ($2 >= 0.6 && $2 < 0.7) } END { exit !h }' "$1"; then
  sleep 60 &
  echo $! > child.txt
  wait
fi
awk -v out="$2" '
/^  [A-Za-z_]+: / { name = $1; sub(":", "", name); p[name] = $2 + 0 }
END {
  if (p["fail"] >= 0.5) { print "model exploded at t = 0.3 s" > "/dev/stderr"; exit 3 }
  pi = atan2(0, -1); n = 41; T = 0.8
  print "time [s], V_lv [m^3], P_lv [Pa], phase [1]" > out
  for (k = 0; k < n; k++) {
    t = T * k / (n - 1); phi = 2 * pi * t / T; s = 0.5 * (1 - cos(phi))
    printf "%.17g, %.17g, %.17g, %d\n", t, p["V_ed"] * (1 - p["EF"] * s),
           1000 + (p["P_peak"] - 1000) * sin(phi / 2) ^ 4, phi < pi ? 2 : 0 > out
  }
}' "$1"
)";

fs::path write_awk_script(const fs::path& dir) {
  const fs::path script = write_file(dir / "beat.sh", kAwkScript);
  fs::permissions(script, fs::perms::owner_all, fs::perm_options::add);
  return script;
}

fs::path write_script(const fs::path& dir) {
  const fs::path script = write_file(dir / "beat.py", kBeatScript);
  fs::permissions(script, fs::perms::owner_all, fs::perm_options::add);
  return script;
}

// A config of the external beat model in dir/m.yaml; `extra` lines go into numerics.
fs::path write_config(const fs::path& dir, const std::string& extra = "",
                      const std::string& command = "./beat.py --params {params} --out {output}") {
  return write_file(dir / "m.yaml", "name: m\nsimulator:\n  model: external\n  numerics:\n"
                                    "    command: \"" + command + "\"\n"
                                    "    workdir: runs\n    output: curves.csv\n    timeout: 20 s\n" +
                                        extra + kTable);
}

std::unique_ptr<model::Simulator> make_simulator(const fs::path& config) {
  const app::Config c = app::load_config(config, {}, bb::cli_models());
  return c.simulator.make();
}

// The external model of write_config(dir) around the Python beat script (write_script).
std::unique_ptr<model::Simulator> script_simulator(const fs::path& dir) {
  write_script(dir);
  return make_simulator(write_config(dir));
}

// The config text of the external model around the sh + awk beat (write_awk_script), which reads
// a YAML parameter file.
std::string awk_config_text(const fs::path& dir) {
  write_awk_script(dir);
  return read_file(write_config(dir, "    parameter_format: yaml\n", "./beat.sh {params} {output}"));
}

// That model with a 1 s timeout (the hang and ensemble tests).
std::unique_ptr<model::Simulator> quick_awk_simulator(const fs::path& dir) {
  std::string text = awk_config_text(dir);
  text.replace(text.find("timeout: 20 s"), 13, "timeout: 1 s");
  return make_simulator(write_file(dir / "m.yaml", text));
}

Eigen::VectorXd theta(double fail, double ef = 0.6) {
  Eigen::VectorXd t(4);
  t << 1.4e-4, ef, 16000.0, fail;
  return t;
}

// True while `pid` exists and is not a zombie (an orphan killed with its group may stay a zombie
// until init reaps it).
bool running(int pid) {
  std::string stat = read_file("/proc/" + std::to_string(pid) + "/stat");
  if (stat.empty()) return false;
  const auto close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() && stat[close + 2] != 'Z' &&
         stat[close + 2] != 'X';
}

CliRun run_cli_models(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, bb::cli_models());
  return {code, out.str(), err.str()};
}

// ---------------------------------------------------------------------------------------------
TEST(CommandTemplate, SplitsLikeAShellButRunsNone) {
  const auto t = bb::CommandTemplate::parse(
      R"(python3 'my model.py' --p {params} "--out={output}" a\ b x{{y}} ; ls)",
      {"params", "output", "dir", "member"});
  const auto argv = t.expand({{"params", "/d/p.json"}, {"output", "/d/o 1.csv"}});
  const std::vector<std::string> want = {"python3", "my model.py", "--p", "/d/p.json",
                                         "--out=/d/o 1.csv", "a b", "x{y}", ";", "ls"};
  EXPECT_EQ(argv, want);
  EXPECT_EQ(t.program(), "python3");
  EXPECT_TRUE(t.uses("params"));
  EXPECT_FALSE(t.uses("dir"));
}

TEST(CommandTemplate, RejectsUnknownPlaceholdersAndUnclosedBracesWithTheirColumn) {
  const std::vector<std::string> allowed = {"params", "output"};
  try {
    bb::CommandTemplate::parse("run {params} {outptu}", allowed);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("column 14"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("{outptu}"), std::string::npos) << e.what();
  }
  EXPECT_THROW(bb::CommandTemplate::parse("run {params", allowed), std::invalid_argument);
  EXPECT_THROW(bb::CommandTemplate::parse("run params}", allowed), std::invalid_argument);
  EXPECT_THROW(bb::CommandTemplate::parse("run 'params", allowed), std::invalid_argument);
  EXPECT_THROW(bb::CommandTemplate::parse("   ", allowed), std::invalid_argument);
}

TEST(Process, TailLinesKeepsTheLastLines) {
  const auto dir = scratch_dir();
  write_file(dir / "e.txt", "1\n2\n3\n4\n");
  EXPECT_EQ(bb::tail_lines(dir / "e.txt", 2), "3\n4");
  EXPECT_EQ(bb::tail_lines(dir / "e.txt", 10), "1\n2\n3\n4");
  EXPECT_EQ(bb::tail_lines(dir / "missing.txt", 2), "");
}

// ---------------------------------------------------------------------------------------------
// The round trip: the program's curves equal the in-process formulas at the times it wrote
// (python3 and C++ call the same libm; the CSV carries shortest round-trip text).
TEST(ExternalModel, ProgramGivesTheInProcessNumbers) {
  const auto dir = scratch_dir();
  auto sim = script_simulator(dir);
  EXPECT_EQ(sim->name(), "external");
  ASSERT_EQ(sim->parameters().size(), 4);
  const Eigen::VectorXd th = theta(0.0, 0.55);
  const model::RunResult r = sim->run(th);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ASSERT_EQ(r.trajectory.samples(), 81);
  EXPECT_NEAR(r.info.period, 0.8, 1e-15);
  double worst = 0.0;
  for (int k = 0; k < 81; ++k) {
    const double t = r.trajectory.times(k);
    const double phi = 2.0 * M_PI * t / 0.8;
    const double s = 0.5 * (1.0 - std::cos(phi));
    const double v = th(0) * (1.0 - th(1) * s);
    const double p = 1000.0 + (th(2) - 1000.0) * std::pow(std::sin(phi / 2.0), 4);
    worst = std::max(worst, std::abs(r.trajectory.values(k, 0) - v) / std::abs(v));
    worst = std::max(worst, std::abs(r.trajectory.values(k, 1) - p) / std::abs(p));
  }
  EXPECT_LE(worst, 1e-15);
  // The member directory is removed after a good run.
  EXPECT_TRUE(fs::is_empty(dir / "runs"));
}

TEST(ExternalModel, ACrashIsProcessFailedWithItsStderrAndTheKeptDirectory) {
  const auto dir = scratch_dir();
  auto sim = script_simulator(dir);
  const model::RunResult r = sim->run(theta(0.55));
  expect_status(r.status, StatusCode::kProcessFailed, "exit code 3");
  EXPECT_NE(r.status.message.find("model exploded at t = 0.3 s"), std::string::npos) << r.status.message;
  EXPECT_NE(r.status.message.find((dir / "runs").string()), std::string::npos) << r.status.message;
  // Kept for inspection, with the parameter file the program was given.
  int kept = 0;
  for (const auto& e : fs::directory_iterator(dir / "runs")) {
    ++kept;
    const auto j = nlohmann::json::parse(read_file(e.path() / "params.json"));
    EXPECT_EQ(j["parameters"]["fail"].get<double>(), 0.55);
    EXPECT_EQ(j["units"][0], "m^3");
  }
  EXPECT_EQ(kept, 1);
}

TEST(ExternalModel, AHangIsKilledWithItsProcessGroupAfterTheTimeout) {
  const auto dir = scratch_dir();
  auto quick = quick_awk_simulator(dir);
  const auto t0 = std::chrono::steady_clock::now();
  const model::RunResult r = quick->run(theta(0.65));
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  expect_status(r.status, StatusCode::kTimeout, "timed out after 1 s");
  EXPECT_GE(elapsed, 1.0);
  EXPECT_LT(elapsed, 5.0);
  // The script's child (a sleep 60 in the same process group) is gone too.
  int pid = 0;
  for (const auto& e : fs::directory_iterator(dir / "runs")) {
    if (fs::exists(e.path() / "child.txt")) pid = std::stoi(read_file(e.path() / "child.txt"));
  }
  ASSERT_GT(pid, 0);
  // SIGKILL is delivered asynchronously: give the kernel a moment to end it.
  for (int i = 0; i < 100 && running(pid); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(running(pid));
  // The same script with a good parameter set runs (the awk beat).
  const model::RunResult ok = quick->run(theta(0.0));
  ASSERT_TRUE(ok.status.ok()) << ok.status.message;
  EXPECT_NEAR(ok.trajectory.values(20, 0), 1.4e-4 * (1.0 - 0.6), 1e-18);
}

TEST(ExternalModel, GarbageMissingAndNonFiniteOutputsAreBadOutput) {
  const auto dir = scratch_dir();
  auto sim = script_simulator(dir);
  const model::RunResult garbage = sim->run(theta(0.75));
  expect_status(garbage.status, StatusCode::kBadOutput, "unreadable output");
  const model::RunResult none = sim->run(theta(0.85));
  expect_status(none.status, StatusCode::kBadOutput, "wrote no output file");
  const model::RunResult nan = sim->run(theta(0.95));
  expect_status(nan.status, StatusCode::kBadOutput, "'V_lv' is missing or not finite at t = 0.4 s");
  const model::RunResult outside = sim->run(theta(0.0, 0.95));
  EXPECT_EQ(outside.status.code, StatusCode::kOutOfBounds);
}

// The config `text` with a channel `name` declared before the line `before`: the program's output
// has no such column, so a run is bad output that names it.
void expect_missing_column(const fs::path& dir, std::string text, const std::string& before, const std::string& name,
                           const std::string& unit) {
  text.replace(text.find(before), 0, "      - {name: " + name + ", unit: " + unit + "}\n");
  auto sim = make_simulator(write_file(dir / "m.yaml", text));
  const model::RunResult r = sim->run(theta(0.0));
  expect_status(r.status, StatusCode::kBadOutput, "no column '" + name + "'");
}

TEST(ExternalModel, AMissingChannelIsBadOutput) {
  const auto dir = scratch_dir();
  write_script(dir);
  expect_missing_column(dir, read_file(write_config(dir)), "      - {name: phase, unit: \"1\"}", "P_ao", "mmHg");
}

TEST(ExternalModel, YamlParameterFilesCarryTheExactValues) {
  Eigen::VectorXd th(2);
  th << 0.1, 1.0 / 3.0;
  const model::ParameterSpace space({{"a", "Pa", 0.1, 0, 1, "a"}, {"b", "m^3/(Pa s)", 0.2, 0, 1, "b"}});
  const std::string text = bb::parameter_file_text(space, th, bb::ParameterFormat::kYaml);
  EXPECT_NE(text.find("  b: 0.3333333333333333\n"), std::string::npos) << text;
  EXPECT_NE(text.find("units: [\"Pa\", \"m^3/(Pa s)\"]"), std::string::npos) << text;
  const auto j = nlohmann::json::parse(bb::parameter_file_text(space, th, bb::ParameterFormat::kJson));
  EXPECT_EQ(j["values"][1].get<double>(), 1.0 / 3.0);
  EXPECT_EQ(j["names"][0], "a");
}

// An .h5 output: /time and one dataset per channel with `units` attributes, converted to SI. The
// "program" copies a file the test wrote with the project's HDF5 writer.
TEST(ExternalModel, HdfOutputIsReadWithItsUnits) {
  const auto dir = scratch_dir();
  Eigen::VectorXd t(5), v(5), p(5);
  t << 0, 200, 400, 600, 800;          // ms
  v << 120, 100, 60, 80, 120;          // mL
  p << 8, 90, 120, 20, 8;              // mmHg
  {
    app::io::Hdf5Writer h5(dir / "premade.h5");
    h5.write_vector("/time", t, "ms");
    h5.write_vector("/V_lv", v, "mL");
    h5.write_vector("/P_lv", p, "mmHg");
    h5.commit();
  }
  const fs::path script = write_file(dir / "copy.sh", "#!/bin/sh\ncp \"$1\" \"$2\"\n");
  fs::permissions(script, fs::perms::owner_all, fs::perm_options::add);
  std::string text = read_file(write_config(dir, "", "./copy.sh " + (dir / "premade.h5").string() + " {output}"));
  text.replace(text.find("output: curves.csv"), 18, "output: curves.h5");
  const std::string phase = "      - {name: phase, unit: \"1\"}\n";
  text.replace(text.find(phase), phase.size(), "");
  auto sim = make_simulator(write_file(dir / "m.yaml", text));
  const model::RunResult r = sim->run(theta(0.0));
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ASSERT_EQ(r.trajectory.samples(), 5);
  EXPECT_DOUBLE_EQ(r.trajectory.times(4), 0.8);
  EXPECT_DOUBLE_EQ(r.trajectory.values(2, 0), 60e-6);
  EXPECT_DOUBLE_EQ(r.trajectory.values(2, 1), 120 * 133.322);
  // A channel the file lacks is bad output.
  expect_missing_column(dir, text, "      - {name: P_lv, unit: Pa}\n", "P_ar", "Pa");
}

// Clones run concurrently in the ensemble's workers; each failure is its member's Status.
TEST(ExternalModel, EnsembleMembersFailOneByOneOnTwoThreads) {
  const auto dir = scratch_dir();
  auto sim = quick_awk_simulator(dir);
  observers::GlobalIndicesOptions go;
  go.indices = {"EDV", "EF"};
  const observers::GlobalIndices observer(go, sim->channels());
  const estimation::SimulatorForwardModel forward(*sim, observer, std::vector<std::string>{"EF", "fail"});
  estimation::EnsembleOptions eo;
  eo.threads = 2;
  estimation::Ensemble ensemble(forward, eo);
  const std::vector<double> fails = {0.0, 0.55, 0.0, 0.65, 0.0, 0.0, 0.55, 0.1};
  Eigen::MatrixXd thetas(static_cast<Eigen::Index>(fails.size()), 2);
  for (size_t i = 0; i < fails.size(); ++i) thetas.row(static_cast<Eigen::Index>(i)) << 0.5 + 0.02 * i, fails[i];
  const estimation::EnsembleResult r = ensemble.evaluate(thetas);
  const std::vector<StatusCode> want = {StatusCode::kOk, StatusCode::kProcessFailed, StatusCode::kOk,
                                        StatusCode::kTimeout, StatusCode::kOk, StatusCode::kOk,
                                        StatusCode::kProcessFailed, StatusCode::kOk};
  ASSERT_EQ(r.status.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) EXPECT_EQ(r.status[i].code, want[i]) << i << ": " << r.status[i].message;
  EXPECT_EQ(r.failures(), 3);
  // Good members: EF as set (the curve reaches V_ed (1 - EF) exactly at mid-beat).
  for (int i : {0, 2, 4, 5, 7}) EXPECT_NEAR(r.Z(i, 1), thetas(i, 0), 1e-12) << i;
  EXPECT_TRUE(std::isnan(r.Z(1, 0)));
}

// ---------------------------------------------------------------------------------------------
// Bad configs are refused before any work, located at file:line:column (exit 2).
TEST(ExternalCli, AMissingExecutableIsRejectedBeforeAnyWork) {
  const auto dir = scratch_dir();
  const auto cfg = write_config(dir, "", "./no-such-model.py --params {params}");
  const CliRun r = run_cli_models({"validate", cfg.string()});
  EXPECT_EQ(r.code, app::kExitBadInput) << r.err;
  EXPECT_NE(r.err.find("m.yaml:5:14"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("no-such-model.py' does not exist"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "runs"));
  const auto path_cfg = write_config(dir, "", "sigmaheart-no-such-program {params}");
  const CliRun p = run_cli_models({"validate", path_cfg.string()});
  EXPECT_EQ(p.code, app::kExitBadInput);
  EXPECT_NE(p.err.find("not an executable in any directory of $PATH"), std::string::npos) << p.err;
}

TEST(ExternalCli, AMalformedTemplateIsRejectedWithItsColumn) {
  const auto dir = scratch_dir();
  write_script(dir);
  const CliRun r = run_cli_models({"validate", write_config(dir, "", "./beat.py --params {parms}").string()});
  EXPECT_EQ(r.code, app::kExitBadInput);
  EXPECT_NE(r.err.find("m.yaml:5:14"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("unknown placeholder {parms}"), std::string::npos) << r.err;
  const CliRun q = run_cli_models({"validate", write_config(dir, "", "./beat.py --params {params").string()});
  EXPECT_EQ(q.code, app::kExitBadInput);
  EXPECT_NE(q.err.find("is never closed"), std::string::npos) << q.err;
}

TEST(ExternalCli, AnInsaneParameterTableIsRejectedAtTheEntry) {
  const auto dir = scratch_dir();
  write_script(dir);
  std::string text = read_file(write_config(dir));
  std::string bad_unit = text;
  bad_unit.replace(bad_unit.find("unit: Pa,"), 9, "unit: Pascal,");
  const CliRun u = run_cli_models({"validate", write_file(dir / "u.yaml", bad_unit).string()});
  EXPECT_EQ(u.code, app::kExitBadInput);
  EXPECT_NE(u.err.find("u.yaml:12:"), std::string::npos) << u.err;
  EXPECT_NE(u.err.find("unknown unit 'Pascal'"), std::string::npos) << u.err;
  std::string bad_bounds = text;
  bad_bounds.replace(bad_bounds.find("lower: 1000, upper: 40000"), 25, "lower: 50000, upper: 40000");
  const CliRun b = run_cli_models({"validate", write_file(dir / "b.yaml", bad_bounds).string()});
  EXPECT_EQ(b.code, app::kExitBadInput);
  EXPECT_NE(b.err.find("expected upper > lower"), std::string::npos) << b.err;
  std::string bad_key = text;
  bad_key.replace(bad_key.find("timeout: 20 s"), 13, "timeout: -1 s");
  const CliRun k = run_cli_models({"validate", write_file(dir / "k.yaml", bad_key).string()});
  EXPECT_EQ(k.code, app::kExitBadInput);
  EXPECT_NE(k.err.find("k.yaml:8:"), std::string::npos) << k.err;
}

// A Sobol' study over members of which some crash, hang or write garbage finishes with the
// failures recorded (policy impute-mean; docs/estimation.md s.8).
TEST(ExternalCli, ASensitivityStudyRecordsTheFailedMembers) {
  const auto dir = scratch_dir();
  std::string text = awk_config_text(dir);
  text.replace(text.find("nominal: 0.0, lower: 0.0, upper: 1.0"), 36, "nominal: 0.3, lower: 0.0, upper: 1.0");
  text += "sensitivity:\n"
          "  method: sobol\n"
          "  seed: 3\n"
          "  outputs: [EF, EDV]\n"
          "  parameters:\n"
          "    EF: {relative: 0.2}\n"
          "    fail: {lower: 0.0, upper: 0.58}\n"
          "  sobol: {N: 16, bootstrap: 20, convergence_levels: 1, failure_policy: impute-mean}\n"
          "  ensemble: {threads: 2}\n";
  const auto cfg = write_file(dir / "m.yaml", text);
  const CliRun r = run_cli_models({"--log-level", "off", "sensitivity", cfg.string(), "-o", (dir / "r.h5").string(),
                                   "--summary", (dir / "r.json").string()});
  ASSERT_EQ(r.code, app::kExitOk) << r.err << r.out;
  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["runs"], 16 * 4);
  const auto& failed = j["failed_runs"];
  ASSERT_GT(failed.size(), 0u);
  EXPECT_LT(failed.size(), 32u);  // about 14 % of 64 (fail uniform on [0, 0.58], >= 0.5 crashes)
  for (const auto& f : failed) {
    EXPECT_EQ(f["code"], "process-failed");
    EXPECT_NE(f["message"].get<std::string>().find("model exploded"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------------
// The steppable protocol on a small sh + awk model: x relaxes to V_ed with time constant tau,
// exactly (x(t1) = V_ed + (x(t0) - V_ed) exp(-(t1 - t0) / tau), x(0) = V_ed / 2); channels
// V_lv = x and P_lv = E x.
const char* kStepScript = R"(#!/bin/sh
awk -v tend="$4" -v out="$3" '
FNR == NR { if ($0 ~ /^  [A-Za-z_]+: /) { n = $1; sub(":", "", n); p[n] = $2 + 0 }; next }
FNR == 1 { next }
{ gsub(/ /, ""); split($0, v, ","); t0 = v[1] + 0; x = v[2] + 0; have = 1 }
END {
  if (!have) { t0 = 0; x = 0.5 * p["V_ed"] }
  if (tend + 0 > t0) x = p["V_ed"] + (x - p["V_ed"]) * exp(-(tend - t0) / p["tau"])
  print "time [s], x [m^3], V_lv [m^3], P_lv [Pa]" > out
  printf "%.17g, %.17g, %.17g, %.17g\n", tend, x, x, p["E"] * x > out
}' "$1" "$2"
)";

fs::path write_step_config(const fs::path& dir, const std::string& step_command =
                                                    "./step.sh {params} {state_in} {state_out} {t_end}") {
  const fs::path script = write_file(dir / "step.sh", kStepScript);
  fs::permissions(script, fs::perms::owner_all, fs::perm_options::add);
  return write_file(dir / "s.yaml", "name: s\nsimulator:\n  model: external\n  numerics:\n"
                                    "    steppable: true\n"
                                    "    step_command: \"" + step_command + "\"\n"
                                    "    parameter_format: yaml\n    workdir: runs\n    timeout: 10 s\n"
                                    "    period: 0.8 s\n    frames: 21\n"
                                    "    parameters:\n"
                                    "      - {name: V_ed, unit: m^3, nominal: 1.4e-4, lower: 1e-5, upper: 5e-4}\n"
                                    "      - {name: tau, unit: s, nominal: 0.3, lower: 0.05, upper: 2}\n"
                                    "      - {name: E, unit: Pa/m^3, nominal: 1e8, lower: 1e7, upper: 1e9}\n"
                                    "    state:\n      - {name: x, unit: m^3}\n"
                                    "    channels:\n      - {name: V_lv, unit: m^3}\n      - {name: P_lv, unit: Pa}\n");
}

TEST(ExternalSteppable, AdvancesReplaysAndSamplesThroughTheProgram) {
  const auto dir = scratch_dir();
  auto sim = make_simulator(write_step_config(dir));
  auto* steppable = dynamic_cast<model::SteppableSimulator*>(sim.get());
  ASSERT_NE(steppable, nullptr);
  ASSERT_EQ(steppable->state_layout().size(), 1u);
  const Eigen::VectorXd theta = sim->parameters().nominal();
  model::State s = steppable->initial_state(theta);
  EXPECT_EQ(s.time, 0.0);
  EXPECT_EQ(s.x(0), 0.7e-4);
  ASSERT_TRUE(steppable->advance(s, theta, 0.3).ok());
  EXPECT_EQ(s.time, 0.3);
  EXPECT_NEAR(s.x(0), 1.4e-4 - 0.7e-4 * std::exp(-1.0), 1e-15 * 1.4e-4);
  // Replay from a saved state lands on the same bits.
  model::State a = s, b = s;
  ASSERT_TRUE(steppable->advance(a, theta, 0.5).ok());
  ASSERT_TRUE(steppable->advance(b, theta, 0.5).ok());
  EXPECT_EQ(a.x(0), b.x(0));
  EXPECT_EQ(a.time, 0.5);
  // A state the filter edited is sampled by the program.
  model::State edited = a;
  edited.x(0) = 1e-4;
  const Eigen::VectorXd y = steppable->sample(edited, theta);
  ASSERT_EQ(y.size(), 2);
  EXPECT_EQ(y(0), 1e-4);
  EXPECT_NEAR(y(1), 1e4, 1e-9);
  // Going back in time is refused; the state stays where it was.
  model::State back = a;
  EXPECT_EQ(steppable->advance(back, theta, 0.1).code, StatusCode::kInvalidArgument);
  EXPECT_EQ(back.x(0), a.x(0));
  // run(): 21 frames over 0.8 s, each a step of the program.
  const model::RunResult r = sim->run(theta);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ASSERT_EQ(r.trajectory.samples(), 21);
  EXPECT_EQ(r.trajectory.times(20), 0.8);
  EXPECT_NEAR(r.trajectory.values(20, 0), 1.4e-4 - 0.7e-4 * std::exp(-0.8 / 0.3), 1e-13 * 1.4e-4);
  EXPECT_TRUE(fs::is_empty(dir / "runs"));
}

TEST(ExternalSteppable, AStepCommandWithoutItsPlaceholdersIsRejected) {
  const auto dir = scratch_dir();
  const CliRun r = run_cli_models({"validate", write_step_config(dir, "./step.sh {params} {state_in} {state_out}").string()});
  EXPECT_EQ(r.code, app::kExitBadInput);
  EXPECT_NE(r.err.find("s.yaml:6:19"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("must pass {t_end}"), std::string::npos) << r.err;
}

// The simulator contract (tests/model/simulator_contract.h) on both forms of the external model:
// the sh + awk beat (one program run per run()) and the steppable relaxation model.
fs::path contract_dir() {
  static const fs::path dir = [] {
    // One directory per process: ctest runs each case in its own process, in parallel.
    const fs::path d = fs::path(SIGMAHEART_BINARY_DIR) / "tests-app-scratch" /
                       ("BlackBoxContract-" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    write_awk_script(d);
    write_config(d, "    parameter_format: yaml\n", "./beat.sh {params} {output}");
    write_step_config(d);
    return d;
  }();
  return dir;
}

INSTANTIATE_TEST_SUITE_P(
    External, SimulatorContract,
    ::testing::Values(ContractCase{"external_program", [] { return make_simulator(contract_dir() / "m.yaml"); }},
                      ContractCase{"external_steppable", [] { return make_simulator(contract_dir() / "s.yaml"); }}),
    contract_case_name);

// The ROUKF drives the steppable external model: it recovers V_ed of the relaxation model from
// eight exact frames of V_lv (truth 1.6e-4 m^3, prior 1.4e-4 m^3 +- 20 %: 12.5 % off; it ends
// 1.9 % off after one pass), editing the program's state (x) along the way.
TEST(ExternalSteppable, TheRoukfRecoversAParameterThroughTheProgram) {
  const auto dir = scratch_dir();
  auto sim = make_simulator(write_step_config(dir));
  const auto* steppable = dynamic_cast<const model::SteppableSimulator*>(sim.get());
  ASSERT_NE(steppable, nullptr);
  const double v_true = 1.6e-4, tau = 0.3;
  estimation::RoukfData data;
  data.channels = {"V_lv"};
  data.times.resize(8);
  data.values.resize(8, 1);
  for (int k = 0; k < 8; ++k) {
    data.times(k) = 0.1 * (k + 1);
    data.values(k, 0) = v_true - 0.5 * v_true * std::exp(-data.times(k) / tau);
  }
  estimation::Prior prior;
  prior.parameters.push_back(estimation::PriorParameter::gaussian(
      "V_ed", "m^3", 1.4e-4, 0.2, estimation::SpreadKind::kRelative, {}));
  estimation::RoukfOptions o;
  o.R = Eigen::MatrixXd::Constant(1, 1, 0.5e-6 * 0.5e-6);  // 0.5 mL noise std
  o.ensemble.threads = 2;
  const estimation::RoukfSummary r = estimation::run_roukf(*steppable, prior, data, o);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(r.theta(0), v_true, 0.03 * v_true) << r.brief_report();
  EXPECT_GT(r.member_runs, 8);
}

// experiments/black-box, shrunk so it cannot rot: its configs validate, and one run of its python3
// model (lv_wk3.py) gives a plausible beat in SI.
TEST(BlackBoxExperiment, ConfigsValidateAndTheModelRunsOnce) {
  const fs::path exp = fs::path(SIGMAHEART_SOURCE_DIR) / "experiments/black-box";
  for (const char* name : {"model-external.yaml", "calibrate-external.yaml", "sensitivity-external.yaml"}) {
    const CliRun r = run_cli_models({"validate", (exp / name).string()});
    EXPECT_EQ(r.code, app::kExitOk) << name << ": " << r.err;
  }
  const auto dir = scratch_dir();
  // The shipped model with member directories in the scratch directory.
  std::string text = read_file(exp / "model-external.yaml");
  text.replace(text.find("./lv_wk3.py"), 11, (exp / "lv_wk3.py").string());
  auto sim = make_simulator(write_file(dir / "m.yaml", text));
  const model::RunResult r = sim->run(sim->parameters().nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ASSERT_EQ(r.trajectory.samples(), 81);
  const Eigen::VectorXd v = r.trajectory.channel("V_lv");
  const double edv = v.maxCoeff(), esv = v.minCoeff();
  EXPECT_GT(edv, 90e-6);  // m^3
  EXPECT_LT(edv, 140e-6);
  const double ef = (edv - esv) / edv;
  EXPECT_GT(ef, 0.4);
  EXPECT_LT(ef, 0.65);
  EXPECT_GT(r.trajectory.channel("P_lv").maxCoeff(), 100.0 * 133.322);  // Pa
}

}  // namespace
}  // namespace sigmaheart::testing
