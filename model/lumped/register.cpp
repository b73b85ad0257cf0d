#include "model/lumped/register.h"

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::model::lumped {

SphereOptions read_sphere_options(const OptionReader& node, const std::vector<std::string>& extra) {
  SphereOptions o;
  std::vector<std::string> keys = {"dt", "min_beats", "max_beats", "periodic_tolerance",
                                   "output_every", "newton_tolerance", "newton_max_iterations",
                                   "activation_shape"};
  keys.insert(keys.end(), extra.begin(), extra.end());
  node.check_keys(keys);
  read_beat_numerics(node, o);
  read_activation_input(node, o.activation_input);
  if (const std::string msg = o.validate(); !msg.empty()) {
    // The messages start with the field name ("dt = -1 s must lie in (0, 0.05]"): point there.
    node.fail(msg.substr(0, msg.find_first_of(" =")), node.path() + ": " + msg);
  }
  return o;
}

RegionalOptions read_regional_options(const OptionReader& node) {
  RegionalOptions o;
  o.numerics = read_sphere_options(node, {"activation", "area_shares"});
  if (node.has("area_shares")) {
    o.area_shares = node.quantities("area_shares", "1");
    if (o.area_shares.empty()) node.fail("area_shares", "expected at least one share");
  }
  const std::vector<std::string> patterns = {"synchronous", "lbbb", "pacing", "times"};
  const auto act = node.child("activation");
  if (node.has("activation")) {
    std::string p;
    if (act->is_map()) {
      act->check_keys({"pattern", "duration", "segment", "conduction_velocity", "times"});
      p = act->choice("pattern", patterns);
    } else {
      p = node.choice("activation", patterns);
    }
    o.activation = p == "times" ? ActivationPattern::kExplicit : *parse_activation_pattern(p);
  }
  if (act->is_map()) {
    o.lbbb_duration = act->quantity("duration", "s", o.lbbb_duration);
    o.pacing_segment = act->integer("segment", o.pacing_segment);
    o.conduction_velocity = act->quantity("conduction_velocity", "m/s", o.conduction_velocity);
    if (act->has("times")) o.activation_times = act->quantities("times", "s");
  }
  if (const std::string msg = o.validate(); !msg.empty()) {
    node.fail(msg.rfind("area_shares", 0) == 0 ? "area_shares" : "activation",
              node.path() + ": " + msg);
  }
  return o;
}

// Presets of the sphere (docs/models.md s.7), each as its values that differ from
// LumpedSphere::default_parameters(); configs/healthy.yaml and configs/heart-failure.yaml write
// every value out. tests/model/lumped/preset_test.cpp checks both beats against the cited ranges.
//
// "healthy": normal adult LV at 70 bpm. Against the defaults: faster relaxation (k_RS 40 1/s,
// active-stress decay time 25 ms, normal isovolumic relaxation; the default 20 1/s gives an IVRT
// of 141 ms), a smaller atrial kick (250 Pa = 1.9 mmHg) on a slightly higher mean atrial pressure
// (1050 Pa = 7.9 mmHg), so that early filling dominates (E/A 1.35 instead of 0.60), +9 %
// contractility (sigma0) to keep the EF that the larger filling volume costs, and a
// normal-adult arterial load: total resistance R_p + R_d = 1.0e8 Pa s/m^3 (1000 dyn s/cm^5) and
// proximal compliance 1e-8 m^3/Pa (1.3 mL/mmHg) for a 123/73 mmHg pressure. Beat (dt 1 ms): EDV
// 156.9 mL, ESV 54.9 mL, EF 65.0 %, IVRT 69 ms, E/A 1.35, EDP 7.4 mmHg.
//
// "heart-failure": the dilated failing LV (HFrEF) derived from "healthy": larger thinner sphere
// (eccentric remodelling: the wall stress of a given pressure grows as R/d, Laplace), stiffer
// tissue (fibrosis), 7 % lower contractility, the default slow relaxation (k_RS 20 1/s), raised
// filling pressure with a weak atrial kick, +10 % distal resistance. Beat: EDV 244.9 mL, ESV
// 174.0 mL, EF 29.0 %, EDP 17.1 mmHg, E/A 4.0 (restrictive filling), aortic 58.8-93.5 mmHg.
std::vector<Preset> sphere_presets() {
  return {
      {"healthy", "normal adult LV (EF ~65 %, EDV ~157 mL, IVRT ~69 ms, E/A ~1.35)",
       {{"sigma0", 5.8e4}, {"k_RS", 40.0}, {"R_d", 0.9e8}, {"C_p", 1.0e-8}, {"P_at0", 1050.0},
        {"P_at_kick", 250.0}}},
      {"heart-failure",
       "dilated failing LV (HFrEF): EF ~29 %, EDV ~245 mL, EDP ~17 mmHg (configs/heart-failure.yaml)",
       {{"R0", 3.0e-2}, {"d0", 1.1e-2}, {"c1", 200.0}, {"c2", 300.0}, {"c_exp", 800.0},
        {"sigma0", 5.4e4}, {"k_RS", 20.0}, {"R_d", 0.99e8}, {"C_p", 1.0e-8}, {"P_at0", 2130.0},
        {"P_at_kick", 267.0}}},
  };
}

// The sphere's presets on a regional build: the sphere's contractility, scaled by the ratio of the
// two models' defaults (the regional patches lose force as they shorten, docs/models.md s.3.2),
// goes to every segment's (found by its tag), every other value to the parameter of the same name.
std::vector<Preset> regional_presets(const ParameterSpace& regional) {
  std::vector<Preset> out = sphere_presets();
  const ParameterSpace sphere = LumpedSphere::default_parameters();
  const double scale = kRegionalSigma0 / sphere[sphere.index_or_throw("sigma0")].nominal;
  for (Preset& preset : out) {
    std::vector<std::pair<std::string, double>> values;
    for (const auto& [name, value] : preset.values) {
      if (name != "sigma0") {
        values.emplace_back(name, value);
        continue;
      }
      for (int i : regional.regional("contractility")) values.emplace_back(regional[i].name, scale * value);
    }
    preset.values = std::move(values);
  }
  return out;
}

// The sphere's entry, with a prescribed atrial pressure or an atrial chamber.
ModelSetup sphere_setup(std::string name, std::string doc, LumpedSphere::Atrium atrium,
                        std::vector<Preset> presets) {
  return ModelSetup{
      std::move(name), std::move(doc),
      [atrium](const OptionReader& numerics) {
        const SphereOptions options = read_sphere_options(numerics);
        return ModelBuild(LumpedSphere::default_parameters(atrium),
                          [options, atrium](const ParameterSpace& p) -> std::unique_ptr<Simulator> {
                            return std::make_unique<LumpedSphere>(options, p, atrium);
                          });
      },
      std::move(presets)};
}

void register_lumped_models(ModelRegistry& registry) {
  registry.add(sphere_setup(
      "lumped-sphere",
      "0D Bestel-Clement-Sorine sphere with valves and a two-stage Windkessel (Caruel 2014)",
      LumpedSphere::Atrium::kPrescribed, sphere_presets()));
  registry.add(sphere_setup(
      "lumped-sphere-atrium",
      "the lumped sphere with a left-atrial chamber (time-varying elastance fed from the pulmonary "
      "veins, Korakianitis & Shi 2006) instead of a prescribed atrial pressure",
      LumpedSphere::Atrium::kChamber, {}));
  registry.add(ModelSetup{
      "lumped-regional",
      "17 AHA wall patches on the BCS sphere (MultiPatch, Walmsley 2015); regional volumes V_segXX",
      [](const OptionReader& numerics) {
        const RegionalOptions options = read_regional_options(numerics);
        return ModelBuild(RegionalVentricle::default_parameters(options),
                          [options](const ParameterSpace& p) -> std::unique_ptr<Simulator> {
                            return std::make_unique<RegionalVentricle>(options, p);
                          });
      },
      regional_presets(RegionalVentricle::default_parameters())});
}

}  // namespace sigmaheart::model::lumped
