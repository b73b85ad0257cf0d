#include "model/lumped/register.h"

#include <memory>

namespace sigmaheart::model::lumped {

SphereOptions read_sphere_options(const OptionReader& node, const std::vector<std::string>& extra) {
  SphereOptions o;
  std::vector<std::string> keys = {"dt", "min_beats", "max_beats", "periodic_tolerance",
                                   "output_every", "newton_tolerance", "newton_max_iterations"};
  keys.insert(keys.end(), extra.begin(), extra.end());
  node.check_keys(keys);
  o.dt = node.quantity("dt", "s", o.dt);
  o.min_beats = node.integer("min_beats", o.min_beats);
  o.max_beats = node.integer("max_beats", o.max_beats);
  o.periodic_tolerance = node.number("periodic_tolerance", o.periodic_tolerance);
  o.output_every = node.integer("output_every", o.output_every);
  o.newton_tolerance = node.number("newton_tolerance", o.newton_tolerance);
  o.newton_max_iterations = node.integer("newton_max_iterations", o.newton_max_iterations);
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

// Presets of the sphere (docs/models.md s.7). "healthy" is the default parameter set (tuned to the
// normal adult ranges); "heart-failure" is the dilated failing ventricle of configs/heart-failure.yaml
// (HFrEF: EF ~22 %, EDV ~245 mL, EDP ~17 mmHg): larger thinner sphere, stiffer tissue, 15 % lower
// contractility, raised filling pressure with a weak atrial kick, +10 % distal resistance.
std::vector<Preset> sphere_presets() {
  return {
      {"healthy", "normal adult LV: the default parameters (EF ~61 %, EDV ~144 mL)", {}},
      {"heart-failure",
       "dilated failing LV (HFrEF): EF ~22 %, EDV ~245 mL, EDP ~17 mmHg (configs/heart-failure.yaml)",
       {{"R0", 3.0e-2}, {"d0", 1.1e-2}, {"c1", 200.0}, {"c2", 300.0}, {"c_exp", 800.0},
        {"sigma0", 4.5e4}, {"R_d", 1.1e8}, {"P_at0", 2130.0}, {"P_at_kick", 267.0}}},
  };
}

// The sphere's presets on a regional build: the sphere's contractility goes to every segment's
// (found by its tag), every other value to the parameter of the same name.
std::vector<Preset> regional_presets(const ParameterSpace& regional) {
  std::vector<Preset> out = sphere_presets();
  for (Preset& preset : out) {
    std::vector<std::pair<std::string, double>> values;
    for (const auto& [name, value] : preset.values) {
      if (name != "sigma0") {
        values.emplace_back(name, value);
        continue;
      }
      for (int i : regional.regional("contractility")) values.emplace_back(regional[i].name, value);
    }
    preset.values = std::move(values);
  }
  return out;
}

void register_lumped_models(ModelRegistry& registry) {
  registry.add(ModelSetup{
      "lumped-sphere",
      "0D Bestel-Clement-Sorine sphere with valves and a two-stage Windkessel (Caruel 2014)",
      [](const OptionReader& numerics) {
        const SphereOptions options = read_sphere_options(numerics);
        return ModelBuild(LumpedSphere::default_parameters(),
                          [options](const ParameterSpace& p) -> std::unique_ptr<Simulator> {
                            return std::make_unique<LumpedSphere>(options, p);
                          });
      },
      sphere_presets()});
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
