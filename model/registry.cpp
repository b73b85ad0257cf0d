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
      "preload_resistance",   "cavity_compliance",    "elastance",         "unloaded_volume"};
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

std::string OptionReader::text(const std::string& key, const std::string& fallback) const {
  if (has(key)) fail(key, "this options reader holds no text values");
  return fallback;
}

bool OptionReader::boolean(const std::string& key, bool fallback) const {
  if (has(key)) fail(key, "this options reader holds no true/false values");
  return fallback;
}

int OptionReader::list_size(const std::string& key) const {
  if (has(key)) fail(key, "this options reader holds no lists");
  return 0;
}

std::unique_ptr<OptionReader> OptionReader::item(const std::string& key, int i) const {
  fail(key, "expected a list with an item " + std::to_string(i) + ", got nothing");
  throw std::logic_error("OptionReader::fail returned");  // fail() never returns
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

namespace {
// Lookup by name and the list of names, for the registry's models and a model's presets.
template <class T>
const T* find_named(const std::vector<T>& items, const std::string& name) {
  for (const auto& item : items) {
    if (item.name == name) return &item;
  }
  return nullptr;
}

template <class T>
std::vector<std::string> names_of(const std::vector<T>& items) {
  std::vector<std::string> out;
  out.reserve(items.size());
  for (const auto& item : items) out.push_back(item.name);
  return out;
}
}  // namespace

const ModelSetup* ModelRegistry::find(const std::string& name) const { return find_named(setups_, name); }

std::vector<std::string> ModelRegistry::names() const { return names_of(setups_); }

const ModelRegistry& builtin_models() {
  static const ModelRegistry registry = [] {
    ModelRegistry r;
    lumped::register_lumped_models(r);
    return r;
  }();
  return registry;
}

const Preset* ModelSetup::find_preset(const std::string& preset) const {
  return find_named(presets, preset);
}

std::vector<std::string> ModelSetup::preset_names() const { return names_of(presets); }

}  // namespace sigmaheart::model
