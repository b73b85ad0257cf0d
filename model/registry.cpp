#include "model/registry.h"

#include "model/lumped/register.h"

#include <stdexcept>

namespace sigmaheart::model {

const std::vector<std::string>& parameter_families() {
  static const std::vector<std::string> families = {
      "contractility",        "activation_time",      "stiffness_scale",   "scar_fraction",
      "activation_rate",      "relaxation_rate",      "activation_duration", "active_stiffness",
      "active_viscosity",     "crossbridge_kinetics", "passive_stiffness", "passive_viscosity",
      "geometry",             "wall_density",         "period",            "valve_conductance",
      "afterload_resistance", "afterload_compliance", "venous_pressure",   "preload_pressure",
      "cavity_compliance",    "elastance",            "unloaded_volume"};
  return families;
}

const std::vector<std::string>& channel_families() {
  static const std::vector<std::string> families = {"regional_volume"};
  return families;
}

std::string NoOptions::choice(const std::string& key, const std::vector<std::string>&) const {
  fail(key, "missing required key '" + key + "'");
}

std::vector<double> NoOptions::quantities(const std::string& key, const std::string&) const {
  fail(key, "missing required key '" + key + "'");
}

std::unique_ptr<OptionReader> NoOptions::child(const std::string&) const {
  return std::make_unique<NoOptions>();
}

void NoOptions::fail(const std::string& key, const std::string& message) const {
  throw std::invalid_argument(key.empty() ? message : key + ": " + message);
}

std::unique_ptr<Simulator> ModelBuild::make(const ParameterSpace& parameters) const {
  if (!factory_) throw std::invalid_argument("ModelBuild::make: the build has no factory");
  return factory_(parameters);
}

void ModelRegistry::add(ModelSetup setup) {
  if (setup.name.empty() || !setup.configure) {
    throw std::invalid_argument("ModelRegistry::add: a model needs a name and a configure function");
  }
  if (find(setup.name) != nullptr) {
    throw std::invalid_argument("ModelRegistry::add: a model named '" + setup.name +
                                "' is already registered");
  }
  setups_.push_back(std::move(setup));
}

const ModelSetup* ModelRegistry::find(const std::string& name) const {
  for (const auto& s : setups_) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

std::vector<std::string> ModelRegistry::names() const {
  std::vector<std::string> out;
  out.reserve(setups_.size());
  for (const auto& s : setups_) out.push_back(s.name);
  return out;
}

const ModelRegistry& builtin_models() {
  static const ModelRegistry registry = [] {
    ModelRegistry r;
    lumped::register_lumped_models(r);
    return r;
  }();
  return registry;
}

const Preset* ModelSetup::find_preset(const std::string& preset) const {
  for (const auto& p : presets) {
    if (p.name == preset) return &p;
  }
  return nullptr;
}

std::vector<std::string> ModelSetup::preset_names() const {
  std::vector<std::string> out;
  for (const auto& p : presets) out.push_back(p.name);
  return out;
}

}  // namespace sigmaheart::model
