#include "app/simulators.h"

#include "model/lumped/regional.h"
#include "model/lumped/sphere.h"

#include <map>
#include <optional>
#include <mutex>

namespace sigmaheart::app {

namespace {

// `numerics:` of the lumped sphere -> SphereOptions (defaults from the struct).
// `extra` names further keys a model adds to the section (parsed by its own function).
model::lumped::SphereOptions parse_sphere_numerics(const ConfigNode& node,
                                                   const std::vector<std::string>& extra = {}) {
  model::lumped::SphereOptions o;
  std::vector<std::string> keys = {"dt", "min_beats", "max_beats", "periodic_tolerance",
                                   "output_every", "newton_tolerance", "newton_max_iterations"};
  keys.insert(keys.end(), extra.begin(), extra.end());
  node.check_keys(keys);
  o.dt = node.optional_quantity("dt", "s", o.dt);
  o.min_beats = node.optional<int>("min_beats", o.min_beats);
  o.max_beats = node.optional<int>("max_beats", o.max_beats);
  o.periodic_tolerance = node.optional<double>("periodic_tolerance", o.periodic_tolerance);
  o.output_every = node.optional<int>("output_every", o.output_every);
  o.newton_tolerance = node.optional<double>("newton_tolerance", o.newton_tolerance);
  o.newton_max_iterations = node.optional<int>("newton_max_iterations", o.newton_max_iterations);
  if (const std::string msg = o.validate(); !msg.empty()) {
    // The messages start with the field name ("dt = -1 s must lie in (0, 0.05]"): point there.
    const std::string field = msg.substr(0, msg.find_first_of(" ="));
    const ConfigNode at = node.has(field) ? node[field] : node;
    at.fail(node.path() + ": " + msg);
  }
  return o;
}

// `numerics:` of the regional ventricle -> RegionalOptions: the sphere's keys plus
//   activation: lbbb                 # synchronous | lbbb | pacing | times
//   activation: {pattern: lbbb, duration: 140 ms}
//   activation: {pattern: pacing, segment: 17, conduction_velocity: 0.6 m/s}
//   activation: {pattern: times, times: [0, 12 ms, ...]}   # one per segment
//   area_shares: [0.25, 0.75]        # optional: N patches instead of the 17 AHA segments
// The activation pattern sets the nominal Td_XX of the parameter space, so `parameters:` (and
// --set Td_05=...) can still change single segments.
model::lumped::RegionalOptions parse_regional_numerics(const ConfigNode& node) {
  using model::lumped::ActivationPattern;
  model::lumped::RegionalOptions o;
  o.numerics = parse_sphere_numerics(node, {"activation", "area_shares"});
  if (node.has("area_shares")) {
    o.area_shares = node["area_shares"].as<std::vector<double>>();
    if (o.area_shares.empty()) node["area_shares"].fail("expected at least one share");
  }
  const ConfigNode act = node["activation"];
  const std::vector<std::string> patterns = {"synchronous", "lbbb", "pacing", "times"};
  ConfigNode pattern_node = act;
  if (act.is_map()) {
    act.check_keys({"pattern", "duration", "segment", "conduction_velocity", "times"});
    pattern_node = act.require_child("pattern");
  }
  if (act.defined()) {
    const std::string p = pattern_node.as_choice(patterns);
    o.activation = p == "times" ? ActivationPattern::kExplicit
                                : *model::lumped::parse_activation_pattern(p);
  }
  if (act.is_map()) {
    o.lbbb_duration = act.optional_quantity("duration", "s", o.lbbb_duration);
    o.pacing_segment = act.optional<int>("segment", o.pacing_segment);
    o.conduction_velocity = act.optional_quantity("conduction_velocity", "m/s", o.conduction_velocity);
    if (act.has("times")) {
      const ConfigNode times = act["times"];
      if (!times.is_sequence()) times.fail("expected a list of activation times, one per segment");
      for (size_t i = 0; i < times.size(); ++i) o.activation_times.push_back(times[i].as_quantity("s"));
    }
  }
  if (const std::string msg = o.validate(); !msg.empty()) {
    const ConfigNode at = msg.rfind("area_shares", 0) == 0 ? node["area_shares"] : act;
    (at.defined() ? at : node).fail(node.path() + ": " + msg);
  }
  return o;
}

// The regional model's nominal Td_XX depend on the activation pattern parsed from `numerics:`,
// while SimulatorEntry::default_parameters() takes no arguments. parse_simulator_section
// (config.cpp) calls parse_numerics and then default_parameters on the same thread, so the
// parsed options are handed over here and taken (reset) by the next default_parameters() call.
thread_local std::optional<model::lumped::RegionalOptions> last_regional_options;

std::map<std::string, SimulatorEntry>& registry() {
  static std::map<std::string, SimulatorEntry> entries = [] {
    std::map<std::string, SimulatorEntry> m;
    m["lumped-sphere"] = SimulatorEntry{
        "lumped-sphere",
        "0D Bestel-Clement-Sorine sphere with valves and a two-stage Windkessel (Caruel 2014)",
        [] { return model::lumped::LumpedSphere::default_parameters(); },
        [](const ConfigNode& numerics) -> SimulatorBuilder {
          const auto options = parse_sphere_numerics(numerics);
          return [options](const model::ParameterSpace& p) -> std::unique_ptr<model::Simulator> {
            return std::make_unique<model::lumped::LumpedSphere>(options, p);
          };
        }};
    m["lumped-regional"] = SimulatorEntry{
        "lumped-regional",
        "17 AHA wall patches on the BCS sphere (MultiPatch, Walmsley 2015); regional volumes V_segXX",
        [] {
          const model::lumped::RegionalOptions o = last_regional_options.value_or(
              model::lumped::RegionalOptions{});
          last_regional_options.reset();
          return model::lumped::RegionalVentricle::default_parameters(o);
        },
        [](const ConfigNode& numerics) -> SimulatorBuilder {
          const auto options = parse_regional_numerics(numerics);
          last_regional_options = options;
          return [options](const model::ParameterSpace& p) -> std::unique_ptr<model::Simulator> {
            return std::make_unique<model::lumped::RegionalVentricle>(options, p);
          };
        }};
    return m;
  }();
  return entries;
}

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

void register_simulator(SimulatorEntry entry) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  registry()[entry.name] = std::move(entry);
}

const SimulatorEntry* find_simulator(const std::string& name) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  auto it = registry().find(name);
  return it == registry().end() ? nullptr : &it->second;
}

std::vector<std::string> simulator_names() {
  std::lock_guard<std::mutex> lock(registry_mutex());
  std::vector<std::string> names;
  for (const auto& [name, entry] : registry()) names.push_back(name);
  return names;
}

}  // namespace sigmaheart::app
