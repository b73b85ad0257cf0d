#include "model/registry.h"

#include "model/lumped/register.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
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

void read_activation_input(const OptionReader& node, bcs::ActivationInput& input) {
  if (!node.has("activation_shape")) return;
  const std::vector<std::string> shapes = {"square", "ramped"};
  const auto a = node.child("activation_shape");
  const std::string shape = a->is_map() ? a->choice("shape", shapes) : node.choice("activation_shape", shapes);
  input.shape = shape == "square" ? bcs::ActivationShape::kSquare : bcs::ActivationShape::kRamped;
  if (a->is_map()) {
    a->check_keys({"shape", "rise", "fall", "relax_ramp", "relax_hold", "rest_ramp", "rest"});
    bcs::RampedActivation& r = input.ramp;
    r.rise = a->number("rise", r.rise);
    r.fall = a->number("fall", r.fall);
    r.relax_ramp = a->quantity("relax_ramp", "s", r.relax_ramp);
    r.relax_hold = a->quantity("relax_hold", "s", r.relax_hold);
    r.rest_ramp = a->quantity("rest_ramp", "s", r.rest_ramp);
    r.rest = a->number("rest", r.rest);
    if (const std::string msg = input.validate(); !msg.empty()) {
      const std::string key = msg.substr(0, msg.find_first_of(" ="));
      a->fail(key == "rise + fall" ? "fall" : key, node.path() + ".activation_shape: " + msg);
    }
  }
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

std::string OptionReader::json_text(const std::string& key) const {
  if (has(key)) fail(key, "this options reader holds no structured values");
  return "{}";
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

namespace {

// with_defaults(): `base` (borrowed, or owned for sub-sections) over `defaults`.
class DefaultedOptions final : public OptionReader {
 public:
  DefaultedOptions(const OptionReader& base, std::unique_ptr<OptionReader> owned,
                   std::vector<std::pair<std::string, std::string>> defaults)
      : base_(base), owned_(std::move(owned)), defaults_(std::move(defaults)) {}

  bool defined() const override { return base_.defined() || !defaults_.empty(); }
  bool has(const std::string& key) const override {
    if (base_.has(key)) return true;
    for (const auto& [k, v] : defaults_)
      if (k == key || k.rfind(key + ".", 0) == 0) return true;
    return false;
  }
  bool is_map() const override { return base_.is_map() || !defaults_.empty(); }
  std::string path() const override { return base_.path(); }
  void check_keys(const std::vector<std::string>& allowed) const override {
    base_.check_keys(allowed);
    for (const auto& [k, v] : defaults_) {
      const std::string head = k.substr(0, k.find('.'));
      if (std::find(allowed.begin(), allowed.end(), head) == allowed.end())
        throw std::logic_error("preset numerics: '" + k + "' is not a key of " + base_.path());
    }
  }
  double quantity(const std::string& key, const std::string& unit, double fallback) const override {
    if (base_.has(key)) return base_.quantity(key, unit, fallback);
    const std::string* d = find(key);
    return d ? to_number(key, *d) : fallback;
  }
  double number(const std::string& key, double fallback) const override {
    if (base_.has(key)) return base_.number(key, fallback);
    const std::string* d = find(key);
    return d ? to_number(key, *d) : fallback;
  }
  int integer(const std::string& key, int fallback) const override {
    if (base_.has(key)) return base_.integer(key, fallback);
    const std::string* d = find(key);
    if (!d) return fallback;
    const double v = to_number(key, *d);
    if (v != std::floor(v)) throw std::logic_error("preset numerics: " + key + " = '" + *d + "' is not an integer");
    return static_cast<int>(v);
  }
  std::string choice(const std::string& key, const std::vector<std::string>& allowed) const override {
    if (base_.has(key)) return base_.choice(key, allowed);
    const std::string* d = find(key);
    if (!d) return base_.choice(key, allowed);  // reports the missing key
    if (std::find(allowed.begin(), allowed.end(), *d) == allowed.end())
      throw std::logic_error("preset numerics: " + key + " = '" + *d + "' is not one of its choices");
    return *d;
  }
  std::vector<double> quantities(const std::string& key, const std::string& unit) const override {
    return base_.quantities(key, unit);
  }
  std::unique_ptr<OptionReader> child(const std::string& key) const override {
    std::vector<std::pair<std::string, std::string>> sub;
    for (const auto& [k, v] : defaults_)
      if (k.rfind(key + ".", 0) == 0) sub.emplace_back(k.substr(key.size() + 1), v);
    std::unique_ptr<OptionReader> base_child = base_.child(key);
    const OptionReader& ref = *base_child;
    return std::make_unique<DefaultedOptions>(ref, std::move(base_child), std::move(sub));
  }
  std::string text(const std::string& key, const std::string& fallback) const override {
    if (base_.has(key)) return base_.text(key, fallback);
    const std::string* d = find(key);
    return d ? *d : fallback;
  }
  bool boolean(const std::string& key, bool fallback) const override {
    if (base_.has(key)) return base_.boolean(key, fallback);
    const std::string* d = find(key);
    if (!d) return fallback;
    if (*d != "true" && *d != "false")
      throw std::logic_error("preset numerics: " + key + " = '" + *d + "' is not true or false");
    return *d == "true";
  }
  int list_size(const std::string& key) const override { return base_.list_size(key); }
  std::string json_text(const std::string& key) const override { return base_.json_text(key); }
  std::unique_ptr<OptionReader> item(const std::string& key, int i) const override { return base_.item(key, i); }
  std::string base_directory() const override { return base_.base_directory(); }
  [[noreturn]] void fail(const std::string& key, const std::string& message) const override {
    base_.fail(base_.has(key) ? key : std::string(), message);
    throw std::logic_error("OptionReader::fail returned");  // fail() never returns
  }

 private:
  const std::string* find(const std::string& key) const {
    for (const auto& [k, v] : defaults_)
      if (k == key) return &v;
    return nullptr;
  }
  static double to_number(const std::string& key, const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
      throw std::logic_error("preset numerics: " + key + " = '" + text + "' is not a number in SI units");
    return v;
  }

  const OptionReader& base_;
  std::unique_ptr<OptionReader> owned_;  // base_ when it is a sub-section made by child()
  std::vector<std::pair<std::string, std::string>> defaults_;
};

}  // namespace

std::unique_ptr<OptionReader> with_defaults(const OptionReader& section,
                                            std::vector<std::pair<std::string, std::string>> defaults) {
  return std::make_unique<DefaultedOptions>(section, nullptr, std::move(defaults));
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
