// `sigmaheart validate CONFIG`: parse and check a config without running anything. Every section
// present that a command reads (builtin_config_sections, app/config_sections.cpp) is checked, and the simulator is
// built once, so a config that validates is one the other commands accept.
//
// Every error it can find is reported, not only the first: after an error at a position of the
// config, the entry written there is removed (ConfigFile::erase_at) and the part parsed again,
// so the next error shows. A part stops at an error that cannot be removed (a YAML syntax error,
// one in a data file or a --set override) and at an error the removal itself caused (a required
// key that was removed); the sections that need the simulator: section are checked only when it
// parses.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/observe_setup.h"

#include <algorithm>
#include <functional>
#include <optional>

namespace sigmaheart::app {

namespace {

// More than this many errors in one part: the rest are not looked for (a file of garbage).
constexpr int kMaxErrorsPerPart = 50;

class ErrorCollector {
 public:
  explicit ErrorCollector(ConfigFile& file) : file_(file) {}

  // Runs `check` until it passes (true) or cannot go on past its last error (false).
  bool run(const std::function<void()>& check) {
    for (int found = 0; found < kMaxErrorsPerPart; ++found) {
      try {
        check();
        return true;
      } catch (const InputError& e) {
        if (caused_by_removal(e) || seen(e)) return false;
        errors_.push_back(e);
        const std::string removed = file_.erase_at(e.where());
        if (removed.empty()) return false;
        removed_.push_back(removed);
      }
    }
    return false;
  }

  const std::vector<InputError>& errors() const { return errors_; }

 private:
  bool caused_by_removal(const InputError& e) const {
    return std::any_of(removed_.begin(), removed_.end(), [&](const std::string& key) {
      return e.message().rfind("missing required key '" + key + "'", 0) == 0;
    });
  }
  bool seen(const InputError& e) const {
    return std::any_of(errors_.begin(), errors_.end(),
                       [&](const InputError& o) { return std::string(o.what()) == e.what(); });
  }

  ConfigFile& file_;
  std::vector<InputError> errors_;
  std::vector<std::string> removed_;
};

int run_validate(const ConfigOptions& o, CommandContext& ctx) {
  ConfigFile file = ConfigFile::load(o.config);  // a syntax error ends here, alone
  apply_overrides(file, o.overrides);
  ErrorCollector errors(file);
#ifdef SIGMAHEART_HAVE_FEM
  if (file.root().has("observe") && !file.root().has("simulator")) {
    // An observe config names files and landmarks, no simulator (app/observe_setup.h).
    errors.run([&] { parse_observe(file); });
    for (const auto& e : errors.errors()) ctx.err << "error: " << e.what() << "\n";
    if (!errors.errors().empty()) return kExitBadInput;
    ctx.out << file.file() << ": ok (observe: files and landmarks checked)\n";
    return kExitOk;
  }
#endif

  std::optional<Config> config;
  const bool simulator_ok = errors.run([&] {
    Config parsed = parse_config_file(file, o.config, *ctx.models, *ctx.sections);
    try {
      parsed.simulator.make();
    } catch (const std::invalid_argument& e) {
      throw InputError(parsed.file.root()["simulator"].location(), e.what());
    }
    config = std::move(parsed);
  });

  std::vector<std::string> checked = {"simulator"};
  std::vector<std::string> unchecked;
  const ConfigNode root = file.root();
  for (const auto& section : ctx.sections->all()) {
    if (!root.has(section.key)) continue;
    if (!simulator_ok) {
      unchecked.push_back(section.key);
      continue;
    }
    errors.run([&] { section.validate(*config); });
    checked.push_back(section.key);
  }

  if (!errors.errors().empty()) {
    for (const auto& e : errors.errors()) ctx.err << "error: " << e.what() << "\n";
    const size_t n = errors.errors().size();
    if (n > 1 || !unchecked.empty()) {
      ctx.err << file.file() << ": " << n << (n == 1 ? " error" : " errors");
      if (!unchecked.empty()) {
        std::string list;
        for (const auto& k : unchecked) list += (list.empty() ? "" : ", ") + k;
        ctx.err << "; not checked until simulator: parses: " << list;
      }
      ctx.err << "\n";
    }
    return kExitBadInput;
  }

  int set = 0;
  for (auto s : config->simulator.sources) set += s != ValueSource::kDefault;
  std::string sections;
  for (const auto& k : checked) sections += (sections.empty() ? "" : ", ") + k;
  ctx.out << config->file.file() << ": ok ('" << config->name << "', model "
          << config->simulator.model << ", " << config->simulator.parameters.size()
          << " parameters, " << set << " set by the config; sections checked: " << sections
          << ")\n";
  return kExitOk;
}

}  // namespace

void register_validate(CLI::App& app, CommandContext& ctx) {
  add_config_command(app, ctx, "validate",
                     "Check a config (keys, types, units, bounds) without running it; reports every "
                     "error it finds",
                     run_validate);
}

}  // namespace sigmaheart::app
