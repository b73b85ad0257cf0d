// The bundled twin experiment in full through the command line (experiments/regional-
// personalization/README.md): with the true noise, no forgetting and the frames split over passes
// (the data count once) every one of the 17 contractilities ends within 10 % of the truth, the
// whole-data NIS inside its chi-square 95 % band, and the infarcted segments are the ones marked low.
#include "personalize_helpers.h"

namespace sigmaheart::app::personalize_testing {
namespace {

using sigmaheart::testing::read_file;
using sigmaheart::testing::scratch_dir;

TEST(PersonalizeTwin, WithTheTrueNoiseEveryContractilityEndsWithinTenPercent) {
  const auto dir = scratch_dir();
  const std::string json = (dir / "twin.json").string();
  const CliRun r = cli({"personalize", twin_config(), "-o", (dir / "twin.h5").string(), "--summary",
                        json, "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  std::printf("%s", r.out.c_str());
  const auto j = nlohmann::json::parse(read_file(json));
  expect_infarct_marked_low(j);
  EXPECT_EQ(j["pass_mode"], "split");
  EXPECT_EQ(j["nis_source"], "whole data at the estimate (2 x MAP objective)");
  const double nis = j["nis_mean"].get<double>();
  EXPECT_GE(nis, j["nis_band_95"][0].get<double>());
  EXPECT_LE(nis, j["nis_band_95"][1].get<double>());
  // The truth inside the +-2 sigma interval: for 17 independent standard normals 3 or more fall
  // outside with probability 4 % (and all fall inside only with probability 45 %).
  int covered = 0;
  for (int s = 1; s <= 17; ++s) {
    const auto& e = j["parameters"][seg(s)];
    EXPECT_LT(e["error_percent"].get<double>(), 10.0) << "segment " << s;
    const double truth = e["truth"].get<double>();
    covered += (e["lower_2sigma"].get<double>() <= truth && truth <= e["upper_2sigma"].get<double>()) ? 1 : 0;
  }
  EXPECT_GE(covered, 15);
  double sum = 0.0;
  for (const auto& f : j["pass_fractions"]) sum += f.get<double>();
  EXPECT_NEAR(sum, 1.0, 1e-12);
  const auto& per_pass = j["max_error_percent_per_pass"];
  ASSERT_EQ(per_pass.size(), j["passes"].get<size_t>());
  EXPECT_LT(per_pass.back().get<double>(), 0.2 * per_pass[0].get<double>());
}

}  // namespace
}  // namespace sigmaheart::app::personalize_testing
