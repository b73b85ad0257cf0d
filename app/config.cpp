#include "app/config.h"

#include "app/model_options.h"
#include "model/enum_names.h"

#include <algorithm>
#include <mutex>
#include <array>

#include <stdexcept>

namespace sigmaheart::app {

const char* to_string(ValueSource source) {
  static constexpr std::array<model::EnumName<ValueSource>, 4> kNames{{
      {ValueSource::kDefault, "default"},
      {ValueSource::kPreset, "preset"},
      {ValueSource::kConfig, "config"},
      {ValueSource::kOverride, "--set"},
  }};
  return model::enum_to_string(kNames, source, "?");
}

namespace {

Config parse_common(ConfigFile file, const std::filesystem::path& path,
                    const model::ModelRegistry& models, const ConfigSections& sections) {
  Config c;
  const ConfigNode root = file.root();
  std::vector<std::string> allowed = {"name", "description", "seed", "simulator"};
  for (const auto& s : sections.all()) allowed.push_back(s.key);
  root.check_keys(allowed, "section");

  c.name = root.optional<std::string>("name", path.stem().string());
  c.description = root.optional<std::string>("description", "");
  if (root.has("seed")) {
    const ConfigNode seed = root["seed"];
    const std::string text = seed.as<std::string>();
    try {
      size_t used = 0;
      if (!text.empty() && text[0] == '-') throw std::invalid_argument("negative");
      c.seed = std::stoull(text, &used);
      if (used != text.size()) throw std::invalid_argument("trailing");
    } catch (const std::exception&) {
      seed.fail("seed: expected a non-negative integer, got " + seed.describe());
    }
  }
  c.simulator = parse_simulator_section(root.require_child("simulator"), models);
  c.file = std::move(file);
  return c;
}

Config load_with_overrides(ConfigFile file, const std::filesystem::path& path,
                           const std::vector<std::string>& overrides,
                           const model::ModelRegistry& models, const ConfigSections& sections) {
  apply_overrides(file, overrides);
  return parse_common(std::move(file), path, models, sections);
}

}  // namespace

ConfigSections::ConfigSections(std::vector<ConfigSection> sections) {
  for (auto& s : sections) add(std::move(s));
}

void ConfigSections::add(ConfigSection section) {
  for (auto& s : sections_) {
    if (s.key == section.key) {
      s = std::move(section);
      return;
    }
  }
  sections_.push_back(std::move(section));
}

std::string expand_override_key(const std::string& key) {
  const auto dot = key.find('.');
  // The scalar top-level keys are themselves; any other bare key is a parameter.
  if (key == "name" || key == "description" || key == "seed") return key;
  if (dot == std::string::npos) return "simulator.parameters." + key;
  const std::string head = key.substr(0, dot);
  if (head == "numerics" || head == "parameters") return "simulator." + key;
  return key;
}

SimulatorSection parse_simulator_section(const ConfigNode& node,
                                         const model::ModelRegistry& models) {
  node.check_keys({"model", "preset", "numerics", "parameters"});
  SimulatorSection s;
  const ConfigNode model_node = node.require_child("model");
  s.model = model_node.as_choice(models.names());
  const model::ModelSetup* setup = models.find(s.model);

  const model::Preset* preset = nullptr;
  if (node.has("preset")) {
    const ConfigNode preset_node = node["preset"];
    if (setup->presets.empty()) preset_node.fail("model " + s.model + " has no presets");
    preset = setup->find_preset(preset_node.as_choice(setup->preset_names()));
  }

  // In the order a config is usually written: numerics (over the preset's), then parameters.
  const ConfigOptionReader numerics(node["numerics"]);
  s.build = setup->configure(*model::with_defaults(numerics, preset ? preset->numerics : model::Preset{}.numerics));
  s.parameters = s.build.parameters();
  s.sources.assign(static_cast<size_t>(s.parameters.size()), ValueSource::kDefault);

  // A preset's values over the defaults, then the config's own parameters over both.
  if (preset) {
    for (const auto& [name, value] : preset->values) {
      const int i = s.parameters.index_or_throw(name);
      s.parameters.set_nominal(name, value);
      s.sources[static_cast<size_t>(i)] = ValueSource::kPreset;
    }
  }

  const ConfigNode params = node["parameters"];
  params.check_keys(s.parameters.names(), "parameter", "for model " + s.model);
  for (const auto& name : params.keys()) {
    const int i = s.parameters.index_or_throw(name);
    const ConfigNode value = params[name];
    const std::string& unit = s.parameters[i].unit;
    const double v = value.as_quantity(unit);
    try {
      s.parameters.set_nominal(name, v);
    } catch (const std::invalid_argument& e) {
      value.fail(e.what());
    }
    s.sources[static_cast<size_t>(i)] =
        value.overridden() ? ValueSource::kOverride : ValueSource::kConfig;
  }
  return s;
}

void apply_overrides(ConfigFile& file, const std::vector<std::string>& overrides) {
  for (const auto& assignment : overrides) {
    const bool quote = assignment.find_first_of(" \t") != std::string::npos;
    const std::string origin = quote ? "--set '" + assignment + "'" : "--set " + assignment;
    const auto eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InputError(Location{origin, 0, 0}, "expected key=value, e.g. --set sigma0=1.5e5");
    }
    file.set(expand_override_key(assignment.substr(0, eq)), assignment.substr(eq + 1), origin);
  }
}

namespace {
std::mutex g_inputs_mutex;
std::vector<std::filesystem::path> g_inputs;
}  // namespace

std::vector<std::filesystem::path> named_input_files() {
  std::lock_guard<std::mutex> lock(g_inputs_mutex);
  return g_inputs;
}
void clear_named_input_files() {
  std::lock_guard<std::mutex> lock(g_inputs_mutex);
  g_inputs.clear();
}

std::filesystem::path input_file(const ConfigNode& at, std::filesystem::path path,
                                 const std::filesystem::path& base, const std::string& what) {
  if (path.empty()) at.fail("expected the path of the " + what + ", got nothing");
  if (path.is_relative()) path = base / path;
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) {
    std::string relative_to = "the working directory";
    if (!base.empty()) {
      relative_to.assign(1, '\'').append(base.string()).push_back('\'');  // not "'" + s + "'", which
      // trips a false -Wrestrict warning of GCC 12
    }
    at.fail(what + " '" + path.string() + "' does not exist (paths are relative to " + relative_to +
            ")");
  }
  if (!std::filesystem::is_regular_file(status)) {
    at.fail(what + " '" + path.string() + "' is " +
            (std::filesystem::is_directory(status) ? "a directory" : "not a regular file") +
            "; expected a file");
  }
  {
    std::lock_guard<std::mutex> lock(g_inputs_mutex);
    if (std::find(g_inputs.begin(), g_inputs.end(), path) == g_inputs.end()) g_inputs.push_back(path);
  }
  return path;
}

Config parse_config_file(ConfigFile file, const std::filesystem::path& path,
                         const model::ModelRegistry& models, const ConfigSections& sections) {
  return parse_common(std::move(file), path, models, sections);
}

Config load_config(const std::filesystem::path& path, const std::vector<std::string>& overrides,
                   const model::ModelRegistry& models, const ConfigSections& sections) {
  return load_with_overrides(ConfigFile::load(path), path, overrides, models, sections);
}

Config parse_config(const std::string& text, const std::string& file_name,
                    const std::vector<std::string>& overrides, const model::ModelRegistry& models,
                    const ConfigSections& sections) {
  return load_with_overrides(ConfigFile::parse(text, file_name), file_name, overrides, models,
                             sections);
}

}  // namespace sigmaheart::app
