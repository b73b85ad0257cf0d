// `sigmaheart params CONFIG`: the parameters of the configured simulator as a table, with the
// values the config sets (units are the model's SI units; config values may use others), and the
// tags estimators find them by (family, segment; model/registry.h) when the model tags them.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"

#include <iomanip>
#include <sstream>

namespace sigmaheart::app {

namespace {

std::string number(double v) {
  std::ostringstream s;
  s << std::setprecision(4) << v;
  return s.str();
}

int run_params(const ConfigOptions& o, CommandContext& ctx) {
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  const auto& space = config.simulator.parameters;
  bool tagged = false, ranged = false;
  for (const auto& p : space.all()) {
    tagged = tagged || !p.family.empty();
    ranged = ranged || p.has_range();
  }
  std::vector<std::string> header = {"name", "unit", "nominal", "lower", "upper", "from"};
  // The physiological range (docs/models.md s.8), when the model states any.
  if (ranged) header.insert(header.begin() + 5, "physiological");
  if (tagged) header.insert(header.end(), {"family", "segment"});
  header.push_back("doc");
  std::vector<std::vector<std::string>> rows;
  for (int i = 0; i < space.size(); ++i) {
    const auto& p = space[i];
    std::vector<std::string> row = {p.name, p.unit, number(p.nominal), number(p.lower),
                                    number(p.upper),
                                    to_string(config.simulator.sources[static_cast<size_t>(i)])};
    if (ranged) {
      row.insert(row.begin() + 5, p.has_range() ? number(p.range_lower) + "-" + number(p.range_upper) : "-");
    }
    if (tagged) {
      row.push_back(p.family.empty() ? "-" : p.family);
      row.push_back(p.regional() ? std::to_string(p.segment) : "-");
    }
    row.push_back(p.range_source.empty() ? p.doc : p.doc + "; range " + p.range_source);
    rows.push_back(std::move(row));
  }
  std::vector<size_t> width(header.size());
  for (size_t c = 0; c < header.size(); ++c) width[c] = header[c].size();
  for (const auto& r : rows) {
    for (size_t c = 0; c < r.size(); ++c) width[c] = std::max(width[c], r[c].size());
  }
  auto print = [&](const std::vector<std::string>& r) {
    std::string line;
    for (size_t c = 0; c < r.size(); ++c) {
      const bool numeric = c >= 2 && c <= (ranged ? 5u : 4u);
      const size_t pad = width[c] - r[c].size();
      if (c + 1 == r.size()) {
        line += r[c];
      } else {
        line += numeric ? std::string(pad, ' ') + r[c] : r[c] + std::string(pad, ' ');
        line += "  ";
      }
    }
    ctx.out << line << "\n";
  };
  ctx.out << config.name << ": model " << config.simulator.model << ", " << space.size()
          << " parameters\n";
  print(header);
  for (const auto& r : rows) print(r);
  return kExitOk;
}

}  // namespace

void register_params(CLI::App& app, CommandContext& ctx) {
  add_config_command(app, ctx, "params", "List the simulator's parameters: unit, value, bounds, doc", run_params);
}

}  // namespace sigmaheart::app
