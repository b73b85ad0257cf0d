// `sigmaheart validate CONFIG`: parse and check a config without running anything. Every section
// present that a command reads (builtin_config_sections, app/config_sections.cpp) is checked, and the simulator is
// built once, so a config that validates is one the other commands accept.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"


namespace sigmaheart::app {

namespace {

int run_validate(const ConfigOptions& o, CommandContext& ctx) {
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  const ConfigNode root = config.file.root();
  std::vector<std::string> checked = {"simulator"};
  for (const auto& section : ctx.sections->all()) {
    if (!root.has(section.key)) continue;
    section.validate(config);
    checked.push_back(section.key);
  }
  try {
    config.simulator.make();
  } catch (const std::invalid_argument& e) {
    throw InputError(root["simulator"].location(), e.what());
  }
  int set = 0;
  for (auto s : config.simulator.sources) set += s != ValueSource::kDefault;
  std::string sections;
  for (const auto& k : checked) sections += (sections.empty() ? "" : ", ") + k;
  ctx.out << config.file.file() << ": ok ('" << config.name << "', model "
          << config.simulator.model << ", " << config.simulator.parameters.size()
          << " parameters, " << set << " set by the config; sections checked: " << sections
          << ")\n";
  return kExitOk;
}

}  // namespace

void register_validate(CLI::App& app, CommandContext& ctx) {
  add_config_command(app, ctx, "validate", "Check a config (keys, types, units, bounds) without running it",
                     run_validate);
}

}  // namespace sigmaheart::app
