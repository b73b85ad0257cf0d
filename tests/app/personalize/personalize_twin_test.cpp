// The bundled twin experiment in full through the command line (experiments/regional-
// personalization/README.md): four passes bring every one of the 17 contractilities within 10 %
// of the truth, and the infarcted segments are the ones marked low.
#include "personalize_helpers.h"

namespace sigmaheart::app::personalize_testing {
namespace {

using sigmaheart::testing::read_file;
using sigmaheart::testing::scratch_dir;

TEST(PersonalizeTwin, FourPassesRecoverEveryContractilityWithinTenPercent) {
  const auto dir = scratch_dir();
  const std::string json = (dir / "twin.json").string();
  const CliRun r = cli({"personalize", twin_config(), "-o", (dir / "twin.h5").string(), "--summary",
                        json, "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  std::printf("%s", r.out.c_str());
  const auto j = nlohmann::json::parse(read_file(json));
  expect_infarct_marked_low(j);
  for (int s = 1; s <= 17; ++s) {
    EXPECT_LT(j["parameters"][seg(s)]["error_percent"].get<double>(), 10.0) << "segment " << s;
  }
  const auto& per_pass = j["max_error_percent_per_pass"];
  ASSERT_EQ(per_pass.size(), 4u);
  EXPECT_LT(per_pass[3].get<double>(), 0.5 * per_pass[0].get<double>());
  EXPECT_LE(j["passes_to_within_10_percent"].get<int>(), 4);
}

}  // namespace
}  // namespace sigmaheart::app::personalize_testing
