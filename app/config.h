// A run config: the sections every config has (name, description, seed, simulator), parsed into
// typed structs in one place, with `--set` overrides merged first so they are checked exactly
// like the file. Later commands parse their own sections (observations:, calibration: ...) from
// Config::file.root() with the ConfigNode calls, and register the section name so that root-level
// typos are caught and `sigmaheart validate` checks their section too.
//
//   name: healthy
//   description: "..."
//   seed: 42                                 # optional
//   simulator:
//     model: lumped-sphere
//     preset: heart-failure                  # optional: a named parameter set of the model
//     numerics: {dt: 1.0e-3, max_beats: 40}
//     parameters: {sigma0: 1.25e5, P_at0: "8 mmHg"}   # number = value in the parameter's unit
#pragma once

#include "app/config_node.h"
#include "model/registry.h"
#include "model/simulator.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app {

// Where a parameter's nominal value came from.
enum class ValueSource { kDefault, kPreset, kConfig, kOverride };
const char* to_string(ValueSource source);

// `simulator:` section.
struct SimulatorSection {
  std::string model;                      // registry name ("lumped-sphere")
  model::ParameterSpace parameters;       // the model's space, nominal = the values to run
  std::vector<ValueSource> sources;       // one per parameter
  model::ModelBuild build;                // numerics already parsed and validated

  // A new simulator with these parameters and numerics.
  std::unique_ptr<model::Simulator> make() const { return build.make(parameters); }
};

struct Config;

// A top-level section that some command reads: its key and a check run by `validate`.
struct ConfigSection {
  std::string key;
  std::function<void(const Config&)> validate;  // parses the section; throws InputError
};
// The top-level sections a config may hold besides name, description, seed and simulator, each
// with the check `validate` runs. A value passed to load_config (no global state): the built-in
// commands' sections are builtin_config_sections(); tests add their own to a copy.
class ConfigSections {
 public:
  ConfigSections() = default;
  explicit ConfigSections(std::vector<ConfigSection> sections);
  void add(ConfigSection section);  // replaces an entry with the same key
  const std::vector<ConfigSection>& all() const { return sections_; }

 private:
  std::vector<ConfigSection> sections_;
};
// observations, estimate, calibration, cases, specificity, sensitivity, personalize (defined in
// app/config_sections.cpp with the parsers of the commands that read them).
const ConfigSections& builtin_config_sections();

struct Config {
  ConfigFile file;                  // text, tree and overrides: later sections parse from here
  std::string name;                 // `name:`, else the file stem
  std::string description;
  std::optional<std::uint64_t> seed;
  SimulatorSection simulator;
};

// Parses `simulator:` with the models of `models` (`model:` must name one of them). Unknown
// parameters, bad units and out-of-bounds values are InputErrors at the offending key or value.
SimulatorSection parse_simulator_section(const ConfigNode& node,
                                         const model::ModelRegistry& models = model::builtin_models());

// Reads a config, applies `--set key=value` overrides and parses the common sections.
// Override keys: "name", "description", "seed"; a bare parameter name ("sigma0"),
// "numerics.<key>", "parameters.<name>",
// or a full dotted path from the top ("simulator.model", "calibration.max_iterations").
// `models` are the models `simulator.model` may name; `sections` the other top-level sections.
Config load_config(const std::filesystem::path& path, const std::vector<std::string>& overrides = {},
                   const model::ModelRegistry& models = model::builtin_models(),
                   const ConfigSections& sections = builtin_config_sections());
// The same from text (tests, configs generated in memory).
Config parse_config(const std::string& text, const std::string& file_name,
                    const std::vector<std::string>& overrides = {},
                    const model::ModelRegistry& models = model::builtin_models(),
                    const ConfigSections& sections = builtin_config_sections());

// Parses the sections of an already loaded file (overrides applied with ConfigFile::set).
// `sigmaheart validate` parses again after removing an erroneous entry (ConfigFile::erase_at).
Config parse_config_file(ConfigFile file, const std::filesystem::path& path,
                         const model::ModelRegistry& models = model::builtin_models(),
                         const ConfigSections& sections = builtin_config_sections());

// Applies `--set key=value` overrides to a loaded file (InputError at the override).
void apply_overrides(ConfigFile& file, const std::vector<std::string>& overrides);

// The file named by a config value: `path` made relative to `base` (the directory of the file
// that names it), which must exist and be a regular file; otherwise an InputError at `at` that
// says which `what` ("observation file") was expected.
std::filesystem::path input_file(const ConfigNode& at, std::filesystem::path path,
                                 const std::filesystem::path& base, const std::string& what);

// Every file input_file() accepted since the last clear, in order, without repeats (the data
// files a config names: the checkpoint fingerprint includes their content, and no output may be
// one of them). Process-wide and thread-safe; run_cli clears it before each command.
std::vector<std::filesystem::path> named_input_files();
void clear_named_input_files();

// The dotted path an override key stands for ("sigma0" -> "simulator.parameters.sigma0").
std::string expand_override_key(const std::string& key);

}  // namespace sigmaheart::app
