// `sigmaheart therapy` through the command line (app/commands/therapy.cpp): a map with sweeps on the
// regional model, the propagation of a personalisation result, a failing site reported beside the
// others, and bad input (issue 47, item 6) at file:line:column with exit 2.
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/io/hdf5_writer.h"
#include "tests/app/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

namespace sigmaheart::testing {
namespace {

const char* kRegional = R"(name: therapy-test
simulator:
  model: lumped-regional
  numerics: {dt: 2 ms, activation: {pattern: lbbb, duration: 140 ms}}
)";

CliRun therapy(const std::filesystem::path& dir, const std::string& config, const std::vector<std::string>& extra = {}) {
  const auto cfg = write_file(dir / "therapy.yaml", config);
  std::vector<std::string> args = {"therapy", cfg.string(), "-o", (dir / "t.h5").string(), "--summary",
                                   (dir / "t.json").string(), "--threads", "1"};
  args.insert(args.end(), extra.begin(), extra.end());
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, app::blackbox::cli_models());
  return {code, out.str(), err.str()};
}

nlohmann::json summary(const std::filesystem::path& dir) { return nlohmann::json::parse(read_file(dir / "t.json")); }

// A personalize result as the command writes it (app/io/roukf_h5.cpp: the datasets read back by
// app/io/posterior_file.h): two contractilities estimated, log transforms, the rest at the model's
// nominal values.
void write_personalization(const std::filesystem::path& path, const std::string& model, const std::string& status) {
  const auto build = app::blackbox::cli_models().find(model)->configure_defaults();
  const model::ParameterSpace& space = build.parameters();
  Eigen::VectorXd theta = space.nominal();
  const std::vector<std::string> names = {"sigma0_05", "sigma0_11"};
  const Eigen::Vector2d value(4.5e4, 5.0e4), reference(5.3e4, 5.3e4);
  Eigen::Vector2d eta;
  for (int j = 0; j < 2; ++j) {
    eta(j) = std::log(value(j) / reference(j));
    if (const auto i = space.index(names[static_cast<size_t>(j)])) theta(*i) = value(j);
  }
  app::io::Hdf5Writer h5(path);
  h5.write_strings("/parameters/names", space.names());
  h5.write_vector("/parameters/values", theta);
  h5.write_strings("/estimate/names", names);
  h5.write_strings("/estimate/units", {"Pa", "Pa"});
  h5.write_strings("/estimate/family", {"sigma0", "sigma0"});
  h5.write_strings("/estimate/transform", {"log", "log"});
  h5.write_vector("/estimate/eta", eta);
  h5.write_vector("/estimate/value", value);
  h5.write_matrix("/estimate/eta_covariance", Eigen::Matrix2d{{0.01, 0.002}, {0.002, 0.01}});
  h5.create_group("/summary");
  h5.set_attribute("/summary", "termination", status);
  h5.set_attribute("/", "kind", "personalize");
  h5.set_attribute("/", "config", "name: p\nsimulator:\n  model: " + model + "\n");
  h5.commit();
}

TEST(TherapyCommand, WritesTheLeadSiteMapAndTheSweepsOfARegionalHeart) {
  const auto dir = scratch_dir();
  const CliRun r = therapy(dir, std::string(kRegional) + R"(therapy:
  lv_leads: [5, 11]
  sweep: {av_delay: [100 ms], vv_delay: [20 ms]}
)");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const auto j = summary(dir);
  ASSERT_EQ(j["map"].size(), 2u);
  ASSERT_EQ(j["sweep"].size(), 2u);
  for (const auto& row : j["map"]) {
    EXPECT_EQ(row["status"], "ok");
    EXPECT_GT(row["AHR"]["mean"].get<double>(), 0.0) << row["label"];  // LBBB: pacing the lateral wall helps
    EXPECT_EQ(row["AHR"]["lower"], row["AHR"]["upper"]);                // no posterior: no spread
  }
  EXPECT_NE(r.out.find("<- best"), std::string::npos) << r.out;
  const app::io::Hdf5Reader h5(dir / "t.h5");
  EXPECT_EQ(h5.string_attribute("/", "kind"), "therapy");
  EXPECT_TRUE(h5.exists("/trajectories/best"));
  EXPECT_EQ(h5.read_strings("/responses/change_names").front(), "AHR");
}

TEST(TherapyCommand, PropagatesTheUncertaintyOfAPersonalisationResult) {
  const auto dir = scratch_dir();
  write_personalization(dir / "p.h5", "lumped-regional", "completed");
  const CliRun r = therapy(dir, std::string(kRegional) + R"(therapy:
  personalization: p.h5
  lv_leads: [5]
  sweep: none
)");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const auto j = summary(dir);
  EXPECT_EQ(j["points"], 5);  // star: 2p + 1
  const auto& ahr = j["map"][0]["AHR"];
  EXPECT_LT(ahr["lower"].get<double>(), ahr["mean"].get<double>());
  EXPECT_GT(ahr["upper"].get<double>(), ahr["mean"].get<double>());
  EXPECT_GT(ahr["std"].get<double>(), 0.01);
  // A personalisation that did not converge gives a prediction that says so (exit 1), written.
  write_personalization(dir / "p.h5", "lumped-regional", "MAP refinement not converged");
  const CliRun bad = therapy(dir, std::string(kRegional) + R"(therapy:
  personalization: p.h5
  lv_leads: [5]
  sweep: none
  uncertainty: {method: point}
)");
  EXPECT_EQ(bad.code, 1) << bad.out << bad.err;
  EXPECT_NE(bad.err.find("did not converge"), std::string::npos) << bad.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "t.failed.h5") || std::filesystem::exists(dir / "t.h5"));
}

TEST(TherapyCommand, AFailingSiteIsReportedAndTheOthersAreWritten) {
  const auto dir = scratch_dir();
  const CliRun r = therapy(dir, std::string(kRegional) + R"(therapy:
  intrinsic_conduction: false
  scar: [13, 14, 15, 16]
  lv_leads: [5, 17]
  sweep: none
)");
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  const auto j = summary(dir);
  EXPECT_EQ(j["map"][0]["status"], "failed");
  EXPECT_NE(j["map"][0]["failure"].get<std::string>().find("never activated"), std::string::npos);
  EXPECT_EQ(j["map"][1]["status"], "ok");
  EXPECT_NE(r.out.find("FAILED"), std::string::npos);
}

// Bad input: exit 2, the message at file:line:column of the key, before any run.
void expect_bad(const std::string& config, const std::string& at, const std::string& what) {
  const auto dir = scratch_dir();
  write_personalization(dir / "sphere.h5", "lumped-sphere", "completed");
  const CliRun r = therapy(dir, config);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("therapy.yaml:" + at), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "t.h5"));
}

TEST(TherapyCommand, BadInputExitsTwoAtTheKey) {
  expect_bad(std::string(kRegional) + "therapy:\n  timing: {av_delay: 500 ms}\n", "6:", "av_delay = 500 ms must lie in");
  expect_bad(std::string(kRegional) + "therapy:\n  lv_leads: [{point: [0, 0, 20 mm]}]\n", "6:",
             "takes lead sites by AHA segment");
  expect_bad(std::string(kRegional) + "therapy:\n  lv_leads: [18]\n", "6:", "expected an AHA segment 1..17");
  expect_bad("name: t\nsimulator: {model: lumped-sphere}\ntherapy: {lv_leads: [5]}\n", "2:",
             "has no activation a therapy can set");
  expect_bad(std::string(kRegional) + "therapy:\n  personalization: sphere.h5\n", "6:",
             "personalised model 'lumped-sphere'");
  expect_bad(R"(name: t
simulator:
  model: lv-3d
  numerics: {mesh: coarse, activation: lbbb}
therapy:
  lv_leads: [{point: [0, 0, 200 mm]}]
)", "6:", "lies outside the mesh");
}

}  // namespace
}  // namespace sigmaheart::testing
