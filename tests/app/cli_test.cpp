// The `sigmaheart` commands end to end: exit codes, messages, files written (app/cli.h,
// app/commands/). In-process through run_cli with the "test-beat" stand-in simulator, plus a few
// runs of the built binary.
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace sigmaheart::app {
namespace {

using sigmaheart::testing::read_file;
using sigmaheart::testing::scratch_dir;
using sigmaheart::testing::temporaries_in;
using sigmaheart::testing::write_file;

const char* kStandIn =
    "name: standin\n"
    "simulator:\n"
    "  model: test-beat\n"
    "  numerics: {samples: 41}\n"
    "  parameters:\n"
    "    V_ed: 150 mL\n";

using sigmaheart::testing::CliRun;
using sigmaheart::testing::cli;

TEST(Cli, SimulateWritesResultsCsvAndJsonAndExitsZero) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "standin.yaml", kStandIn);
  const auto h5 = dir / "r.h5";
  const CliRun r = cli({"--log-level", "off", "simulate", config.string(), "-o", h5.string(), "--csv",
                     (dir / "r.csv").string(), "--summary", (dir / "r.json").string(), "--set",
                     "EF=0.5"});
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_EQ(temporaries_in(dir), 0);

  io::Hdf5Reader f(h5);
  EXPECT_EQ(f.string_attribute("/", "kind"), "simulate");
  EXPECT_EQ(f.string_attribute("/", "name"), "standin");
  EXPECT_EQ(f.string_attribute("/", "config"), kStandIn);
  EXPECT_EQ(f.read_text("/config"), kStandIn);
  EXPECT_EQ(f.strings_attribute("/", "overrides"), (std::vector<std::string>{"--set EF=0.5"}));
  EXPECT_TRUE(f.has_attribute("/", "git_describe"));
  EXPECT_TRUE(f.has_attribute("/", "start_utc"));
  EXPECT_EQ(f.read_strings("/parameters/names"),
            (std::vector<std::string>{"V_ed", "EF", "P_peak", "fail"}));
  EXPECT_EQ(f.read_strings("/parameters/source"),
            (std::vector<std::string>{"config", "--set", "default", "default"}));
  const Eigen::VectorXd v = f.read_vector("/trajectories/simulated/V_lv");
  ASSERT_EQ(v.size(), 41);
  EXPECT_NEAR(v(0), 150.0, 1e-9);  // end-diastole at t = 0, in mL
  EXPECT_EQ(f.string_attribute("/trajectories/simulated/V_lv", "units"), "mL");
  EXPECT_NEAR(f.double_attribute("/summary", "EDV"), 150.0, 1e-6);
  EXPECT_EQ(f.string_attribute("/summary", "EDV.units"), "mL");
  EXPECT_NEAR(f.double_attribute("/summary", "EF"), 50.0, 1e-6);
  EXPECT_EQ(f.string_attribute("/summary", "EF.units"), "%");

  const auto j = nlohmann::json::parse(read_file(dir / "r.json"));
  EXPECT_EQ(j["status"], "ok");
  EXPECT_NEAR(j["ESV"]["value"].get<double>(), 75.0, 1e-6);
  EXPECT_EQ(j["ESV"]["unit"], "mL");
  EXPECT_NEAR(j["P_max"]["value"].get<double>(), 16000.0 / 133.322, 1e-6);
  EXPECT_EQ(j["P_max"]["unit"], "mmHg");
  EXPECT_EQ(j["period"]["value"], 0.8);
  EXPECT_EQ(j["beats"]["value"], 3);
  EXPECT_EQ(read_file(dir / "r.csv").substr(0, 41), "time [s],V_lv [mL],P_lv [mmHg],phase [1]\n");

  EXPECT_NE(r.out.find("EDV"), std::string::npos);
  EXPECT_NE(r.out.find(" 150 mL"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrote " + h5.string()), std::string::npos);
}

TEST(Cli, SimulateWithoutOutputWritesResultsNamedAfterTheConfig) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "standin.yaml", kStandIn);
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir);
  const CliRun r = cli({"--log-level", "off", "simulate", "standin.yaml"});
  std::filesystem::current_path(cwd);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "results" / "standin-simulate.h5"));
}

TEST(Cli, BadConfigExitsTwoWithLocatedMessageAndLeavesTheOldResultUntouched) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "bad.yaml", R"(name: standin
simulator:
  model: test-beat
  parameters:
    V_edd: 150 mL
)");
  const auto h5 = write_file(dir / "r.h5", "previous result");
  const CliRun r = cli({"simulate", config.string(), "-o", h5.string()});
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_EQ(r.err, "error: " + config.string() +
                       ":5:5: unknown parameter 'V_edd' for model test-beat (did you mean 'V_ed'?)\n");
  EXPECT_EQ(read_file(h5), "previous result");
  EXPECT_EQ(temporaries_in(dir), 0);
}

TEST(Cli, OutOfBoundsSetExitsTwo) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "standin.yaml", kStandIn);
  const CliRun r = cli({"validate", config.string(), "--set", "EF=2"});
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_EQ(r.err, "error: --set EF=2: parameter 'EF' = 2 1 is outside its bounds [0.05, 0.9] 1\n");
}

// A run that failed without two finite samples has nothing to show: nothing is written and an
// earlier result stays.
TEST(Cli, FailedSimulationExitsOneAndWritesNothing) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "standin.yaml", kStandIn);
  const auto h5 = write_file(dir / "r.h5", "previous result");
  const CliRun r = cli({"--log-level", "off", "simulate", config.string(), "-o", h5.string(), "--set",
                     "fail=1"});
  EXPECT_EQ(r.code, kExitRuntimeFailure);
  EXPECT_EQ(r.err, "error: simulation of 'standin' failed (diverged): Newton diverged at t = 0.3 s\n");
  EXPECT_EQ(read_file(h5), "previous result");
}

// `simulate` of the stand-in (standin.yaml) with `--set fail=<fail>`, a summary s.json and curves
// c.csv, in a fresh directory that already holds an earlier result r.h5.
struct FailedSimulation {
  std::filesystem::path dir, h5, json, csv;
  CliRun run;
};
FailedSimulation simulate_failing(const std::string& fail) {
  FailedSimulation f;
  f.dir = scratch_dir();
  const auto config = write_file(f.dir / "standin.yaml", kStandIn);
  f.h5 = write_file(f.dir / "r.h5", "previous result");
  f.json = f.dir / "s.json";
  f.csv = f.dir / "c.csv";
  f.run = cli({"--log-level", "off", "simulate", config.string(), "-o", f.h5.string(), "--summary", f.json.string(),
               "--csv", f.csv.string(), "--set", "fail=" + fail});
  return f;
}

// What every failed simulation shows: exit 1, the message naming `status`, `reason` and the
// failed-beat file r.failed.h5, the earlier result kept, no temporaries, the status in that file.
void expect_failed_beside_earlier_result(const FailedSimulation& f, const std::string& status,
                                         const std::string& reason) {
  EXPECT_EQ(f.run.code, kExitRuntimeFailure);
  EXPECT_EQ(f.run.err, "error: simulation of 'standin' failed (" + status + "): " + reason + " is written to " +
                           (f.dir / "r.failed.h5").string() + "; the earlier result " + f.h5.string() + " was kept\n");
  EXPECT_EQ(read_file(f.h5), "previous result");
  EXPECT_EQ(temporaries_in(f.dir), 0);
  EXPECT_EQ(io::Hdf5Reader((f.dir / "r.failed.h5").string()).string_attribute("/summary", "status"), status);
}

// A run that diverged inside a beat writes that beat's finite samples up to the failure, without
// indices, with status "diverged" and its message (exit 1), beside an earlier result, which stays.
TEST(Cli, DivergedSimulationExitsOneAndWritesTheBeatUpToTheFailure) {
  const FailedSimulation failed = simulate_failing("0.87");
  const auto& [dir, h5, json, csv, r] = failed;
  expect_failed_beside_earlier_result(failed, "diverged", "Newton diverged at t = 0.3 s; the beat up to t = 0.3 s of beat 3");
  io::Hdf5Reader f((dir / "r.failed.h5").string());
  EXPECT_EQ(f.string_attribute("/summary", "message"), "Newton diverged at t = 0.3 s");
  // 41 samples over 0.8 s: those at t = 0, 0.02, ..., 0.3 s; the NaN sample after them is left out.
  const Eigen::VectorXd v = f.read_vector("/trajectories/simulated/V_lv");
  ASSERT_EQ(v.size(), 16);
  EXPECT_TRUE(v.allFinite());
  EXPECT_NEAR(v(0), 150.0, 1e-9);  // mL
  const auto j = nlohmann::json::parse(read_file(json));
  EXPECT_EQ(j["status"], "diverged");
  EXPECT_FALSE(j.contains("EF"));  // a part of a beat has no indices
  EXPECT_NEAR(j["time_reached"]["value"].get<double>(), 0.3, 1e-12);
  EXPECT_EQ(j["beats"]["value"].get<double>(), 3.0);
  std::ifstream c(csv);
  int lines = 0;
  for (std::string line; std::getline(c, line);) ++lines;
  EXPECT_EQ(lines, 17);  // header and 16 samples
  EXPECT_NE(r.out.find("standin (test-beat): FAILED (diverged) in beat 3\n"), std::string::npos);
}

// A run that ends without a periodic beat still integrated its beats: the last one is written with
// status "not-periodic" (exit 1), beside an earlier result, which stays.
TEST(Cli, NotPeriodicSimulationExitsOneAndWritesItsLastBeatBesideTheEarlierResult) {
  const FailedSimulation failed = simulate_failing("0.85");
  const auto& [dir, h5, json, csv, r] = failed;
  expect_failed_beside_earlier_result(
      failed, "not-periodic",
      "not periodic after 3 beats: beat-to-beat change 0.02 > periodic_tolerance 0.001; the last beat");
  io::Hdf5Reader f((dir / "r.failed.h5").string());
  const Eigen::VectorXd v = f.read_vector("/trajectories/simulated/V_lv");
  ASSERT_EQ(v.size(), 41);
  EXPECT_NEAR(v(0), 150.0, 1e-9);  // mL, the beat as computed
  const auto j = nlohmann::json::parse(read_file(json));
  EXPECT_EQ(j["status"], "not-periodic");
  EXPECT_NEAR(j["periodicity_change"]["value"].get<double>(), 0.02, 1e-12);
  // No earlier result: the files go where asked.
  const auto fresh = dir / "fresh.h5";
  EXPECT_EQ(cli({"--log-level", "off", "simulate", (dir / "standin.yaml").string(), "-o", fresh.string(), "--set",
                 "fail=0.85"})
                .code,
            kExitRuntimeFailure);
  EXPECT_EQ(io::Hdf5Reader(fresh.string()).string_attribute("/summary", "status"), "not-periodic");
}

TEST(Cli, ValidateReportsOkAndParamsListsUnitsBoundsAndSources) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "standin.yaml", kStandIn);
  const CliRun v = cli({"validate", config.string()});
  EXPECT_EQ(v.code, kExitOk) << v.err;
  EXPECT_EQ(v.out, config.string() +
                       ": ok ('standin', model test-beat, 4 parameters, 1 set by the config; "
                       "sections checked: simulator)\n");
  const CliRun p = cli({"params", config.string()});
  EXPECT_EQ(p.code, kExitOk) << p.err;
  EXPECT_EQ(p.out,
            "standin: model test-beat, 4 parameters\n"
            "name    unit  nominal  lower   upper  from     doc\n"
            "V_ed    m^3   0.00015  1e-05  0.0005  config   end-diastolic volume\n"
            "EF      1         0.6   0.05     0.9  default  ejection fraction\n"
            "P_peak  Pa    1.6e+04   1000   4e+04  default  peak LV pressure\n"
            "fail    1           0      0       1  default  > 0.5 makes the run fail ((0.8, 0.86): not periodic; (0.86, "
            "0.89): diverged mid-beat)\n");
}

TEST(Cli, UnknownOptionOrMissingConfigExitsTwo) {
  EXPECT_EQ(cli({"simulate"}).code, kExitBadInput);
  EXPECT_EQ(cli({"simulate", "x.yaml", "--frobnicate"}).code, kExitBadInput);
  const CliRun r = cli({"validate", "/nonexistent/x.yaml"});
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_EQ(r.err, "error: /nonexistent/x.yaml: no such config file\n");
}

// The built binary --------------------------------------------------------------------------

int run_binary(const std::string& args, const std::filesystem::path& output) {
  const std::string cmd = std::string(SIGMAHEART_BINARY_DIR) + "/sigmaheart " + args + " > '" +
                          output.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(Binary, VersionPrintsVersionAndGitDescription) {
  const auto dir = scratch_dir();
  EXPECT_EQ(run_binary("--version", dir / "out.txt"), 0);
  EXPECT_EQ(read_file(dir / "out.txt").rfind("sigmaheart 0.1.0 (", 0), 0u) << read_file(dir / "out.txt");
}

TEST(Binary, HelpDocumentsTheExitCodes) {
  const auto dir = scratch_dir();
  EXPECT_EQ(run_binary("--help", dir / "out.txt"), 0);
  EXPECT_NE(read_file(dir / "out.txt").find("2  bad input"), std::string::npos);
}

TEST(Binary, BadConfigExitsTwoWithFileLineColumn) {
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "x.yaml", R"(simulator:
  model: lumped-sphere
  parameters:
    sigma_0: 1.5e5
)");
  EXPECT_EQ(run_binary("validate '" + config.string() + "'", dir / "out.txt"), 2);
  EXPECT_EQ(read_file(dir / "out.txt"),
            "error: " + config.string() +
                ":4:5: unknown parameter 'sigma_0' for model lumped-sphere (did you mean 'sigma0'?)\n");
}

// scripts/plot ------------------------------------------------------------------------------

TEST(Plot, SimulateResultGivesPvLoopAndCurvePngsNamedAfterTheResult) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib, h5py' > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "Debian's python3 with matplotlib and h5py is not installed";
  }
  const auto dir = scratch_dir();
  const auto config = write_file(dir / "standin.yaml", kStandIn);
  ASSERT_EQ(cli({"--log-level", "off", "simulate", config.string(), "-o", (dir / "r.h5").string()}).code,
            kExitOk);
  const std::string cmd = std::string(SIGMAHEART_SOURCE_DIR) + "/scripts/plot '" +
                          (dir / "r.h5").string() + "' -o '" + (dir / "png").string() + "' > '" +
                          (dir / "out.txt").string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_file(dir / "out.txt");
  EXPECT_EQ(read_file(dir / "out.txt"), (dir / "png" / "r-pv-loop.png").string() + "\n" +
                                            (dir / "png" / "r-curves.png").string() + "\n");
  EXPECT_GT(std::filesystem::file_size(dir / "png" / "r-pv-loop.png"), 10000u);
}

TEST(Plot, FileThatIsNotAResultExitsTwo) {
  const auto dir = scratch_dir();
  write_file(dir / "x.h5", "not hdf5");
  const std::string cmd = std::string(SIGMAHEART_SOURCE_DIR) + "/scripts/plot '" +
                          (dir / "x.h5").string() + "' > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  if (WIFEXITED(status) && WEXITSTATUS(status) == 1) GTEST_SKIP() << "no matplotlib";
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2);
}

// An output that is a data file the config names is refused before any work (exit 2), and the
// data file is left as it was.
TEST(Cli, AnOutputThatIsADataFileOfTheConfigIsRefused) {
  const auto dir = scratch_dir();
  const std::filesystem::path src = SIGMAHEART_SOURCE_DIR;
  std::filesystem::create_directories(dir / "data");
  std::filesystem::copy_file(src / "configs" / "data" / "volunteer02.csv", dir / "data" / "volunteer02.csv");
  std::filesystem::copy_file(src / "configs" / "calibrate-volunteer.yaml", dir / "c.yaml");
  const std::string data = read_file(dir / "data" / "volunteer02.csv");
  for (const char* option : {"-o", "--summary"}) {
    const CliRun r = cli({"calibrate", (dir / "c.yaml").string(), option, (dir / "data" / "volunteer02.csv").string()});
    EXPECT_EQ(r.code, kExitBadInput) << option << "\n" << r.err;
    EXPECT_NE(r.err.find("volunteer02.csv"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(dir / "data" / "volunteer02.csv"), data);
  }
}


}  // namespace
}  // namespace sigmaheart::app
