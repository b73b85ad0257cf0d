// The common config sections and `--set` overrides (app/config.h), on the real lumped sphere.
#include "app/config.h"

#include "app/blackbox/register.h"

#include "model/lumped/regional.h"
#include "model/lumped/sphere.h"
#ifdef SIGMAHEART_HAVE_FEM
#include "model/fem/electromechanics.h"
#endif
#include "model/units.h"

#include "tests/app/test_support.h"

#include <gtest/gtest.h>

#include <string>

namespace sigmaheart::app {
namespace {

using namespace sigmaheart::testing;

const char* kHealthy =
    "name: healthy\n"                                // 1
    "description: \"test preset\"\n"                 // 2
    "simulator:\n"                                   // 3
    "  model: lumped-sphere\n"                       // 4
    "  numerics: {dt: 1.0e-3, max_beats: 30}\n"      // 5
    "  parameters:\n"                                // 6
    "    sigma0: 6.0e4\n"                            // 7
    "    P_at0: \"8 mmHg\"\n";                       // 8

std::string with_line(const std::string& text, int line, const std::string& replacement) {
  std::string out;
  size_t start = 0;
  for (int l = 1; start <= text.size(); ++l) {
    const size_t end = text.find('\n', start);
    const std::string current = text.substr(start, end == std::string::npos ? end : end - start);
    out += (l == line ? replacement : current);
    if (end == std::string::npos) break;
    out += "\n";
    start = end + 1;
  }
  return out;
}

TEST(Config, ParsesNameModelParametersWithUnitsAndTheirSources) {
  const Config c = parse_config(kHealthy, "x.yaml");
  EXPECT_EQ(c.name, "healthy");
  EXPECT_EQ(c.description, "test preset");
  EXPECT_EQ(c.simulator.model, "lumped-sphere");
  const auto& p = c.simulator.parameters;
  EXPECT_DOUBLE_EQ(p[p.index_or_throw("sigma0")].nominal, 6.0e4);
  EXPECT_DOUBLE_EQ(p[p.index_or_throw("P_at0")].nominal, 8 * model::units::kMmHg);
  EXPECT_EQ(c.simulator.sources[static_cast<size_t>(p.index_or_throw("sigma0"))], ValueSource::kConfig);
  EXPECT_EQ(c.simulator.sources[static_cast<size_t>(p.index_or_throw("R0"))], ValueSource::kDefault);
  auto sim = c.simulator.make();
  auto* sphere = dynamic_cast<model::lumped::LumpedSphere*>(sim.get());
  ASSERT_NE(sphere, nullptr);
  EXPECT_EQ(sphere->options().max_beats, 30);
  EXPECT_DOUBLE_EQ(sim->parameters().nominal()(p.index_or_throw("sigma0")), 6.0e4);
}

TEST(Config, NameDefaultsToTheFileStem) {
  const Config c = parse_config(with_line(kHealthy, 1, "# no name"), "configs/failing.yaml");
  EXPECT_EQ(c.name, "failing");
}

TEST(Config, UnknownParameterNamesFileLineColumnAndTheClosestName) {
  EXPECT_EQ(error_of([] { parse_config(with_line(kHealthy, 7, "    sigma_0: 1.5e5"), "configs/x.yaml"); }),
            "configs/x.yaml:7:5: unknown parameter 'sigma_0' for model lumped-sphere (did you mean 'sigma0'?)");
}

TEST(Config, UnknownSectionAndNumericsKeysSuggestTheClosestKey) {
  EXPECT_EQ(error_of([] { parse_config(with_line(kHealthy, 3, "simulater:"), "x.yaml"); }),
            "x.yaml:3:1: unknown section 'simulater' at the top level (did you mean 'simulator'?)");
  EXPECT_EQ(error_of([] {
              parse_config(with_line(kHealthy, 5, "  numerics: {dtt: 1.0e-3}"), "x.yaml");
            }),
            "x.yaml:5:14: unknown key 'dtt' in simulator.numerics (did you mean 'dt'?)");
}

TEST(Config, WrongTypeSaysWhatWasExpected) {
  EXPECT_EQ(error_of([] {
              parse_config(with_line(kHealthy, 5, "  numerics: {max_beats: abc}"), "x.yaml");
            }),
            "x.yaml:5:25: simulator.numerics.max_beats: expected an integer, got 'abc'");
  EXPECT_EQ(error_of([] { parse_config(with_line(kHealthy, 7, "    sigma0: abc"), "x.yaml"); }),
            "x.yaml:7:13: simulator.parameters.sigma0: expected a number in Pa or '<number> <unit>', "
            "got 'abc'");
}

TEST(Config, OutOfBoundsValueNamesParameterValueUnitAndBounds) {
  EXPECT_EQ(error_of([] { parse_config(with_line(kHealthy, 7, "    sigma0: 3e9"), "x.yaml"); }),
            "x.yaml:7:13: parameter 'sigma0' = 3e+09 Pa is outside its bounds [0, 1e+06] Pa");
}

TEST(Config, ARepeatedKeyIsRefusedAtItsSecondOccurrence) {
  // yaml-cpp would keep the first and silently ignore the second (issue: a duplicate parameter
  // under estimate: passed validate).
  EXPECT_EQ(error_of([] {
              parse_config(with_line(kHealthy, 7, "    sigma0: 6.0e4\n    sigma0: 7.0e4"), "x.yaml");
            }),
            "x.yaml:8:5: duplicate key 'sigma0' (first at line 7): each key may appear once");
}

TEST(Config, ADirectoryGivenAsTheConfigIsNamedAsSuch) {
  EXPECT_EQ(error_of([] { load_config(std::string(SIGMAHEART_SOURCE_DIR) + "/configs"); }),
            std::string(SIGMAHEART_SOURCE_DIR) +
                "/configs: is a directory; expected a YAML config file (e.g. configs/healthy.yaml)");
}

TEST(Config, InvalidNumericsPointAtTheField) {
  EXPECT_EQ(error_of([] {
              parse_config(with_line(kHealthy, 5, "  numerics: {dt: 0.5}"), "x.yaml");
            }),
            "x.yaml:5:18: simulator.numerics: dt = 0.5 s must lie in (0, 0.05]");
}

#ifdef SIGMAHEART_HAVE_FEM
// The 3D heartbeat of the command line's registry reads its numerics through the same reader.
TEST(Config, Lv3dNumericsErrorsPointAtTheField) {
  const std::string lv =
      "name: lv\n"
      "simulator:\n"
      "  model: lv-3d\n"
      "  numerics: {mesh: coarse, dt: 0.5}\n"
      "  parameters:\n"
      "    sigma0_07: 6.0e4\n";
  EXPECT_EQ(error_of([&] { parse_config(lv, "x.yaml", {}, blackbox::cli_models()); }),
            "x.yaml:4:32: simulator.numerics: dt = 0.5 s must lie in [1e-05, 0.05] s");
  EXPECT_EQ(error_of([&] { parse_config(with_line(lv, 4, "  numerics: {mesh: huge}"), "x.yaml", {}, blackbox::cli_models()); })
                .rfind("x.yaml:4:20: simulator.numerics.mesh: unknown value 'huge'", 0),
            0u);
  const Config c = parse_config(with_line(lv, 4, "  numerics: {mesh: coarse, dt: 10 ms}"), "x.yaml", {}, blackbox::cli_models());
  EXPECT_EQ(c.simulator.model, "lv-3d");
  // The geometry and the active stress of the thin-shell comparison (docs/models.md s.4.8).
  EXPECT_EQ(error_of([&] {
              parse_config(with_line(lv, 4, "  numerics: {geometry: {r_short_endo: 40 mm}}"), "x.yaml", {},
                           blackbox::cli_models());
            }),
            "x.yaml:4:24: simulator.numerics: geometry: epicardial radii must exceed the endocardial ones");
  EXPECT_EQ(error_of([&] {
              parse_config(with_line(lv, 4, "  numerics: {geometry: {r_endo: 4 cm}}"), "x.yaml", {},
                           blackbox::cli_models());
            }),
            "x.yaml:4:25: unknown key 'r_endo' in simulator.numerics.geometry; expected one of: r_short_endo, "
            "r_long_endo, r_short_epi, r_long_epi, z_base");
  EXPECT_EQ(error_of([&] {
              parse_config(with_line(lv, 4, "  numerics: {active_stress: tangential}"), "x.yaml", {},
                           blackbox::cli_models());
            }),
            "x.yaml:4:29: simulator.numerics.active_stress: unknown value 'tangential'; expected one of: fibre, "
            "tangent_isotropic");
  const std::string shell_numerics =
      "  numerics: {active_stress: tangent_isotropic, geometry: {r_short_endo: 25 mm, r_long_endo: 25 mm, "
      "r_short_epi: 30 mm, r_long_epi: 30 mm, z_base: 22.5 mm}}";
  EXPECT_EQ(error_of([&] { parse_config(with_line(lv, 4, shell_numerics), "x.yaml", {}, blackbox::cli_models()); }),
            "");
  // Linear tetrahedra as the docs write them (docs/models.md s.4.8), and without their bulk modulus.
  EXPECT_EQ(error_of([&] {
              parse_config(with_line(lv, 4, "  numerics: {element_order: 1, bulk_modulus: 10 MPa, quadrature_degree: 1}"),
                           "x.yaml", {}, blackbox::cli_models());
            }),
            "");
  EXPECT_EQ(error_of([&] {
              parse_config(with_line(lv, 4, "  numerics: {element_order: 1}"), "x.yaml", {}, blackbox::cli_models());
            }).rfind("x.yaml:4:", 0),
            0u);
}

// A preset's numerics (lv-3d `lbbb-heart-failure`: LBBB activation, dilated geometry) reach the
// model under the config's own numerics, which win key by key; its parameters are marked preset.
TEST(Config, APresetsNumericsComeUnderTheConfigsOwn) {
  const std::string lv =
      "name: lv\n"
      "simulator:\n"
      "  model: lv-3d\n"
      "  preset: lbbb-heart-failure\n"
      "  numerics: {mesh: coarse}\n";
  const auto options_of = [](const Config& c) {
    const auto sim = c.simulator.build.make(c.simulator.parameters);
    return dynamic_cast<const model::fem::LeftVentricle3D&>(*sim).options();
  };
  const Config c = parse_config(lv, "x.yaml", {}, blackbox::cli_models());
  const model::fem::LeftVentricle3DOptions o = options_of(c);
  EXPECT_EQ(o.activation, model::fem::ActivationSource::kLbbb);
  EXPECT_EQ(o.n_circumferential, 12);
  EXPECT_DOUBLE_EQ(o.geometry.r_short_endo, 0.028);
  EXPECT_DOUBLE_EQ(o.geometry.r_long_epi, 0.056);
  EXPECT_DOUBLE_EQ(c.simulator.parameters[c.simulator.parameters.index_or_throw("P_at0")].nominal, 2400.0);
  const Config own = parse_config(
      with_line(lv, 5, "  numerics: {mesh: coarse, activation: healthy, geometry: {r_short_endo: 27 mm}}"), "x.yaml",
      {}, blackbox::cli_models());
  const model::fem::LeftVentricle3DOptions o2 = options_of(own);
  EXPECT_EQ(o2.activation, model::fem::ActivationSource::kHealthy);
  EXPECT_DOUBLE_EQ(o2.geometry.r_short_endo, 0.027);  // the config's key
  EXPECT_DOUBLE_EQ(o2.geometry.r_short_epi, 0.036);   // the preset's, beside it
  // A bad value of the config's own still points at its place.
  EXPECT_EQ(error_of([&] {
              parse_config(with_line(lv, 5, "  numerics: {geometry: {r_short_epi: 20 mm}}"), "x.yaml", {},
                           blackbox::cli_models());
            }),
            "x.yaml:5:24: simulator.numerics: geometry: epicardial radii must exceed the endocardial ones");
  // The shipped config names the preset and the coarse mesh.
  const Config shipped = load_config(std::string(SIGMAHEART_SOURCE_DIR) + "/configs/lv3d-lbbb-heart-failure.yaml",
                                     {}, blackbox::cli_models());
  EXPECT_EQ(options_of(shipped).activation, model::fem::ActivationSource::kLbbb);
  EXPECT_EQ(shipped.simulator.parameters.nominal(), c.simulator.parameters.nominal());
}
#endif

TEST(Config, UnknownModelAndMissingSectionsAreReported) {
  EXPECT_EQ(error_of([] { parse_config(with_line(kHealthy, 4, "  model: lumped-spere"), "x.yaml"); })
                .rfind("x.yaml:4:10: simulator.model: unknown value 'lumped-spere' (did you mean "
                       "'lumped-sphere'?); expected one of: ",
                       0),
            0u);
  EXPECT_EQ(error_of([] { parse_config("name: x\n", "x.yaml"); }),
            "x.yaml:1:1: missing required key 'simulator'");
  EXPECT_EQ(error_of([] { parse_config("simulator:\n  numerics: {}\n", "x.yaml"); }),
            "x.yaml:2:3: missing required key 'model' in simulator");
}

TEST(Config, SetOverridesParametersNumericsAndFullPaths) {
  const Config c = parse_config(kHealthy, "x.yaml",
                                {"sigma0=1.5e5", "numerics.dt=0.5 ms", "parameters.R0=2.5 cm",
                                 "simulator.numerics.max_beats=12", "simulator.model=lumped-sphere"});
  const auto& p = c.simulator.parameters;
  EXPECT_DOUBLE_EQ(p[p.index_or_throw("sigma0")].nominal, 1.5e5);
  EXPECT_DOUBLE_EQ(p[p.index_or_throw("R0")].nominal, 0.025);
  EXPECT_EQ(c.simulator.sources[static_cast<size_t>(p.index_or_throw("sigma0"))], ValueSource::kOverride);
  EXPECT_EQ(c.simulator.sources[static_cast<size_t>(p.index_or_throw("P_at0"))], ValueSource::kConfig);
  auto sim = c.simulator.make();
  const auto& o = dynamic_cast<model::lumped::LumpedSphere&>(*sim).options();
  EXPECT_DOUBLE_EQ(o.dt, 5e-4);
  EXPECT_EQ(o.max_beats, 12);
  EXPECT_EQ(c.file.overrides().front(), "--set sigma0=1.5e5");
  EXPECT_EQ(c.file.overrides()[1], "--set 'numerics.dt=0.5 ms'");
}

TEST(Config, SetErrorsNameTheOverride) {
  EXPECT_EQ(error_of([] { parse_config(kHealthy, "x.yaml", {"sigma_0=1.5e5"}); }),
            "--set sigma_0=1.5e5: unknown parameter 'sigma_0' for model lumped-sphere (did you mean "
            "'sigma0'?)");
  EXPECT_EQ(error_of([] { parse_config(kHealthy, "x.yaml", {"sigma0=-1"}); }),
            "--set sigma0=-1: parameter 'sigma0' = -1 Pa is outside its bounds [0, 1e+06] Pa");
  EXPECT_EQ(error_of([] { parse_config(kHealthy, "x.yaml", {"numerics.dt=abc"}); }),
            "--set numerics.dt=abc: simulator.numerics.dt: expected a number in s or '<number> "
            "<unit>', got 'abc'");
  EXPECT_EQ(error_of([] { parse_config(kHealthy, "x.yaml", {"sigma0"}); }),
            "--set sigma0: expected key=value, e.g. --set sigma0=1.5e5");
}

TEST(Config, ExpandsOverrideKeys) {
  EXPECT_EQ(expand_override_key("sigma0"), "simulator.parameters.sigma0");
  EXPECT_EQ(expand_override_key("numerics.dt"), "simulator.numerics.dt");
  EXPECT_EQ(expand_override_key("parameters.R0"), "simulator.parameters.R0");
  EXPECT_EQ(expand_override_key("calibration.max_iterations"), "calibration.max_iterations");
}

TEST(Config, RegisteredSectionsAreAcceptedAtTheTopLevel) {
  const std::string text = std::string(kHealthy) + "twin_study: {members: 3}\n";
  const ConfigSections none;
  EXPECT_EQ(error_of([&] { parse_config(text, "x.yaml", {}, model::builtin_models(), none); }),
            "x.yaml:9:1: unknown section 'twin_study' at the top level; expected one of: name, "
            "description, seed, simulator");
  ConfigSections with_twin_study = builtin_config_sections();
  with_twin_study.add({"twin_study", [](const Config&) {}});
  EXPECT_NO_THROW(parse_config(text, "x.yaml", {}, model::builtin_models(), with_twin_study));
  // The built-in sections are known whichever command runs (no registration order).
  EXPECT_EQ(error_of([&] { parse_config(std::string(kHealthy) + "calibraton: {}\n", "x.yaml"); })
                .find("x.yaml:9:1: unknown section 'calibraton' at the top level (did you mean "
                      "'calibration'?)"),
            0u);
}

// The regional model's numerics are parsed in model/lumped/register.cpp through the
// model::OptionReader interface; its errors keep file:line:column and the did-you-mean.
TEST(Config, RegionalNumericsErrorsReadThroughTheModelKeepTheirLocation) {
  const std::string head = "name: r\nsimulator:\n  model: lumped-regional\n";
  EXPECT_EQ(error_of([&] { parse_config(head + "  numerics: {activation: lbbbb}\n", "r.yaml"); }),
            "r.yaml:4:26: simulator.numerics.activation: unknown value 'lbbbb' (did you mean 'lbbb'?); "
            "expected one of: synchronous, lbbb, pacing, times");
  EXPECT_EQ(error_of([&] { parse_config(head + "  numerics: {area_shares: []}\n", "r.yaml"); }),
            "r.yaml:4:27: expected at least one share");
  EXPECT_EQ(error_of([&] {
              parse_config(head + "  numerics: {activation: {pattern: times, times: 5}}\n", "r.yaml");
            }),
            "r.yaml:4:50: simulator.numerics.activation.times: expected a list of numbers in s, got '5'");
  EXPECT_EQ(error_of([&] {
              parse_config(head + "  numerics: {activation: {pattern: times, times: [0, 1 ms]}}\n", "r.yaml");
            }),
            "r.yaml:4:26: simulator.numerics: activation_times has 2 entries, expected 17");
  const Config c = parse_config(head + "  numerics: {activation: {pattern: lbbb, duration: 120 ms}}\n", "r.yaml");
  const auto& p = c.simulator.parameters;
  double latest = 0.0;
  for (int i : p.regional("activation_time")) latest = std::max(latest, p[i].nominal);
  EXPECT_NEAR(latest, 0.12, 1e-12);  // the numerics set the nominal Td_XX
}

TEST(Config, ModelsComeFromTheRegistryGiven) {
  const std::string text = "name: s\nsimulator: {model: test-beat, numerics: {samples: 5}}\n";
  EXPECT_NE(error_of([&] { parse_config(text, "s.yaml"); }).find("unknown value 'test-beat'"), std::string::npos);
  EXPECT_EQ(error_of([&] { parse_config(text, "s.yaml", {}, stand_in_models()); }),
            "s.yaml:2:51: numerics.samples: expected an integer >= 10");
  const Config c = parse_config(text, "s.yaml", {"numerics.samples=20"}, stand_in_models());
  EXPECT_EQ(c.simulator.model, "test-beat");
  EXPECT_EQ(c.simulator.make()->run(c.simulator.parameters.nominal()).trajectory.samples(), 20);
}

TEST(Config, APresetSetsItsValuesUnderTheConfigsOwnParameters) {
  // The heart-failure preset equals configs/heart-failure.yaml, which writes every value out.
  const Config file = load_config(std::string(SIGMAHEART_SOURCE_DIR) + "/configs/heart-failure.yaml");
  const Config preset = parse_config(
      "name: hf\nsimulator:\n  model: lumped-sphere\n  preset: heart-failure\n", "hf.yaml");
  EXPECT_EQ(preset.simulator.parameters.nominal(), file.simulator.parameters.nominal());
  const int r0 = preset.simulator.parameters.index_or_throw("R0");
  EXPECT_EQ(preset.simulator.sources[static_cast<size_t>(r0)], ValueSource::kPreset);

  // The config's parameters win over the preset's.
  const Config both = parse_config(
      "name: hf\nsimulator:\n  model: lumped-sphere\n  preset: heart-failure\n"
      "  parameters: {sigma0: 4.0e4}\n", "hf.yaml");
  EXPECT_EQ(both.simulator.parameters[both.simulator.parameters.index_or_throw("sigma0")].nominal, 4.0e4);

  // On the regional model the preset's contractility goes to every segment (found by its tag),
  // scaled by the ratio of the two models' default contractilities (model/lumped/register.cpp).
  const Config regional = parse_config(
      "name: hf\nsimulator:\n  model: lumped-regional\n  preset: heart-failure\n", "hf.yaml");
  const auto& space = regional.simulator.parameters;
  const model::ParameterSpace sphere = model::lumped::LumpedSphere::default_parameters();
  const double scale = model::lumped::kRegionalSigma0 / sphere[sphere.index_or_throw("sigma0")].nominal;
  ASSERT_EQ(space.regional("contractility").size(), 17u);
  for (int i : space.regional("contractility")) EXPECT_EQ(space[i].nominal, scale * 5.4e4) << space[i].name;

  const std::string e = error_of([] {
    parse_config("name: x\nsimulator:\n  model: lumped-sphere\n  preset: heart-failur\n", "x.yaml");
  });
  EXPECT_NE(e.find("x.yaml:4:11"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'heart-failure'"), std::string::npos) << e;
}

}  // namespace
}  // namespace sigmaheart::app
