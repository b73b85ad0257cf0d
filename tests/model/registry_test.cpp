// The model registry (model/registry.h): lookup, configuration with default and given numerics,
// tags on every parameter, and the simulator contract run on every built-in model.
#include "model/registry.h"

#include "model/lumped/regional.h"
#include "tests/model/simulator_contract.h"

#include "tests/model/map_options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <stdexcept>

namespace sigmaheart::model {
namespace {

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

using sigmaheart::model::testing::MapOptions;

TEST(ModelRegistry, BuiltinModelsAreFoundByNameAndUnknownNamesGiveNull) {
  const ModelRegistry& r = builtin_models();
  EXPECT_EQ(r.names(), (std::vector<std::string>{"lumped-sphere", "lumped-sphere-atrium",
                                                "lumped-regional"}));
  ASSERT_NE(r.find("lumped-sphere"), nullptr);
  EXPECT_EQ(r.find("lumped-sphere")->name, "lumped-sphere");
  EXPECT_FALSE(r.find("lumped-regional")->doc.empty());
  EXPECT_EQ(r.find("lumped-spere"), nullptr);
  EXPECT_EQ(r.find(""), nullptr);
  EXPECT_EQ(&builtin_models(), &r);  // built once
}

TEST(ModelRegistry, RejectsDuplicateNamesAndCopiesAreIndependent) {
  ModelRegistry copy = builtin_models();
  EXPECT_THROW(copy.add(*builtin_models().find("lumped-sphere")), std::invalid_argument);
  EXPECT_THROW(copy.add(ModelSetup{"no-configure", "", {}}), std::invalid_argument);
  ModelSetup renamed = *builtin_models().find("lumped-sphere");
  renamed.name = "another-sphere";
  const size_t builtin = builtin_models().names().size();
  copy.add(renamed);
  EXPECT_EQ(copy.names().size(), builtin + 1);
  EXPECT_EQ(builtin_models().names().size(), builtin);
  EXPECT_EQ(copy.find("another-sphere")->configure_defaults().make()->name(), "lumped-sphere");
}

TEST(ModelRegistry, EveryParameterCarriesAFamilyFromTheVocabulary) {
  for (const auto& setup : builtin_models().all()) {
    const ParameterSpace space = setup.configure_defaults().parameters();
    ASSERT_GT(space.size(), 0) << setup.name;
    for (const Parameter& p : space.all()) {
      EXPECT_TRUE(contains(parameter_families(), p.family))
          << setup.name << ": parameter " << p.name << " has family '" << p.family << "'";
      EXPECT_GE(p.segment, 0) << p.name;
    }
    EXPECT_TRUE(space.find("contractility").has_value() || !space.regional("contractility").empty())
        << setup.name;
    auto sim = setup.configure_defaults().make();
    for (const Channel& c : sim->channels()) {
      if (c.family.empty()) continue;
      EXPECT_TRUE(contains(channel_families(), c.family)) << setup.name << ": " << c.name;
    }
  }
}

TEST(ModelRegistry, RegionalTagsNameOneParameterPerSegmentAndFamily) {
  const ParameterSpace space = builtin_models().find("lumped-regional")->configure_defaults().parameters();
  for (const char* family : {"contractility", "activation_time", "stiffness_scale", "scar_fraction"}) {
    const std::vector<int> idx = space.regional(family);
    ASSERT_EQ(idx.size(), 17u) << family;
    for (int s = 1; s <= 17; ++s) EXPECT_EQ(space[idx[static_cast<size_t>(s - 1)]].segment, s);
  }
  EXPECT_EQ(space[*space.find("contractility", 5)].name, "sigma0_05");
  EXPECT_EQ(space[*space.find("afterload_resistance")].unit, "Pa s/m^3");
  EXPECT_FALSE(space.find("contractility", 18).has_value());
}

TEST(ModelRegistry, NumericsTravelInsideTheBuild) {
  const ModelSetup& regional = *builtin_models().find("lumped-regional");
  // Two builds with different numerics, used interleaved: no state is handed between calls.
  const ModelBuild lbbb = regional.configure(MapOptions({{"activation", "lbbb"}, {"dt", "5e-4"}}));
  const ModelBuild sync = regional.configure(NoOptions{});
  const ParameterSpace a = lbbb.parameters();
  const ParameterSpace b = sync.parameters();
  double spread_a = 0.0, spread_b = 0.0;
  for (int i : a.regional("activation_time")) spread_a = std::max(spread_a, a[i].nominal);
  for (int i : b.regional("activation_time")) spread_b = std::max(spread_b, b[i].nominal);
  EXPECT_NEAR(spread_a, 0.14, 1e-12);  // RegionalOptions::lbbb_duration
  EXPECT_EQ(spread_b, 0.0);
  auto sim = lbbb.make();
  const auto* r = dynamic_cast<const lumped::RegionalVentricle*>(sim.get());
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->options().activation, lumped::ActivationPattern::kLbbb);
  EXPECT_DOUBLE_EQ(r->options().numerics.dt, 5e-4);
}

TEST(ModelRegistry, BadNumericsAreReportedThroughTheReader) {
  const ModelSetup& sphere = *builtin_models().find("lumped-sphere");
  try {
    sphere.configure(MapOptions(std::map<std::string, std::string>{{"dt", "0.5"}}));
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "dt: numerics: dt = 0.5 s must lie in (0, 0.05]");
  }
  EXPECT_THROW(sphere.configure(MapOptions(std::map<std::string, std::string>{{"dtt", "1e-3"}})), std::invalid_argument);
}

// with_defaults: the section's keys win, absent keys take the defaults (also inside sub-sections),
// other keys their fallback; a default that is not a number, or not one of a choice's values, is a
// preset defined wrongly (std::logic_error), and an unknown default key is caught by check_keys.
TEST(ModelRegistry, DefaultsFillTheKeysASectionLeavesOut) {
  const MapOptions section(std::map<std::string, std::string>{{"dt", "0.002"}});
  const auto r = with_defaults(section, {{"dt", "0.01"}, {"activation", "lbbb"}, {"max_beats", "4"},
                                         {"geometry.r_short_endo", "0.028"}});
  EXPECT_TRUE(r->defined());
  EXPECT_TRUE(r->has("activation"));
  EXPECT_TRUE(r->has("geometry"));
  EXPECT_FALSE(r->has("mesh"));
  EXPECT_DOUBLE_EQ(r->quantity("dt", "s", 1.0), 0.002);  // the section's
  EXPECT_EQ(r->choice("activation", {"healthy", "lbbb"}), "lbbb");
  EXPECT_EQ(r->integer("max_beats", 20), 4);
  EXPECT_EQ(r->integer("min_beats", 1), 1);
  const auto g = r->child("geometry");
  EXPECT_TRUE(g->is_map());
  EXPECT_DOUBLE_EQ(g->quantity("r_short_endo", "m", 0.025), 0.028);
  EXPECT_DOUBLE_EQ(g->quantity("r_long_endo", "m", 0.045), 0.045);
  EXPECT_THROW(r->choice("activation", {"healthy", "synchronous"}), std::logic_error);
  EXPECT_THROW(r->check_keys({"dt", "activation", "max_beats"}), std::logic_error);  // geometry not allowed
  EXPECT_NO_THROW(r->check_keys({"dt", "activation", "max_beats", "geometry"}));
  EXPECT_THROW(with_defaults(section, {{"max_beats", "four"}})->integer("max_beats", 20), std::logic_error);
  // The section's errors stay the section's.
  EXPECT_THROW(with_defaults(section, {})->check_keys({"mesh"}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model

namespace sigmaheart::testing {
namespace {

// Every registered model passes the contract with its default numerics.
INSTANTIATE_TEST_SUITE_P(Builtin, SimulatorContract,
                         ::testing::ValuesIn(contract_cases(model::builtin_models())),
                         contract_case_name);

}  // namespace
}  // namespace sigmaheart::testing
