#include "app/blackbox/tables.h"

#include "model/units.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

namespace sigmaheart::app::blackbox {

namespace {

bool identifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

// unit := factor (sep factor)* ; sep := ' ' | '*' | '/' ; factor := symbol ['^' ['-'] digits] |
// '(' unit ')' | '1'
bool si_expression(const std::string& u, size_t& i, int depth) {
  static const std::vector<std::string> symbols = {"kg", "mol", "Pa", "m", "s", "N", "J",
                                                   "W", "K", "A", "1"};
  bool need_factor = true;
  while (i < u.size()) {
    const char c = u[i];
    if (c == ')') return depth > 0 && !need_factor;
    if (c == ' ' || c == '*' || c == '/') {
      if (need_factor && c != ' ') return false;
      need_factor = true;
      ++i;
      continue;
    }
    if (!need_factor) return false;  // two factors without a separator ("mPa")
    if (c == '(') {
      ++i;
      if (!si_expression(u, i, depth + 1) || i >= u.size() || u[i] != ')') return false;
      ++i;
    } else {
      const auto it = std::find_if(symbols.begin(), symbols.end(),
                                   [&](const std::string& s) { return u.compare(i, s.size(), s) == 0; });
      if (it == symbols.end()) return false;
      i += it->size();
    }
    if (i < u.size() && u[i] == '^') {
      ++i;
      if (i < u.size() && u[i] == '-') ++i;
      const size_t start = i;
      while (i < u.size() && std::isdigit(static_cast<unsigned char>(u[i]))) ++i;
      if (i == start) return false;
    }
    need_factor = false;
  }
  return depth == 0 && !need_factor;
}

void check_family(const model::OptionReader& item, const std::string& family,
                  const std::vector<std::string>& vocabulary) {
  if (family.empty()) return;
  if (std::find(vocabulary.begin(), vocabulary.end(), family) != vocabulary.end()) return;
  std::string msg = "unknown family '" + family + "'";
  const std::string close = model::closest_match(family, vocabulary);
  if (!close.empty()) msg += " (did you mean '" + close + "'?)";
  msg += "; the vocabulary is in model/registry.h";
  item.fail("family", msg);
}

DeclaredUnit declared(const std::string& unit) {
  const auto si = model::units::to_si(unit);
  return {unit, si ? si->factor : 1.0};
}

// The keys a parameter and a channel item share: doc (default `doc`), family (one of `families`
// or empty) and segment (>= 0, 0: global).
template <class Entry>
void read_tags(const model::OptionReader& item, const char* doc, const std::vector<std::string>& families,
               Entry& entry) {
  entry.doc = item.text("doc", doc);
  entry.family = item.text("family", "");
  check_family(item, entry.family, families);
  entry.segment = item.integer("segment", 0);
  if (entry.segment < 0) item.fail("segment", "expected a segment >= 0 (0: global)");
}

std::string si_unit_of(const std::string& unit) {
  const auto si = model::units::to_si(unit);
  return si ? si->si_unit : unit;
}

}  // namespace

std::vector<int> input_vectors(const model::OptionReader& numerics, const std::string& key) {
  std::vector<int> out;
  const int n = numerics.list_size(key);
  for (int i = 0; i < n; ++i) out.push_back(numerics.item(key, i)->integer("input", 0));
  return out;
}

std::vector<DeclaredUnit> declared_units(const model::OptionReader& numerics, const std::string& key) {
  std::vector<DeclaredUnit> out;
  const int n = numerics.list_size(key);
  for (int i = 0; i < n; ++i) out.push_back(declared(numerics.item(key, i)->text("unit", "")));
  return out;
}

Eigen::VectorXd unit_factors(const std::vector<DeclaredUnit>& declared) {
  Eigen::VectorXd f(static_cast<Eigen::Index>(declared.size()));
  for (size_t i = 0; i < declared.size(); ++i) f(static_cast<Eigen::Index>(i)) = declared[i].factor;
  return f;
}

bool known_unit(const std::string& unit) {
  if (model::units::to_si(unit)) return true;
  size_t i = 0;
  return !unit.empty() && si_expression(unit, i, 0) && i == unit.size();
}

model::ParameterSpace read_parameter_table(const model::OptionReader& numerics,
                                           const std::string& key, bool input_vectors) {
  if (!numerics.has(key)) numerics.fail(key, "missing required key '" + key + "' (a list of {name, unit, nominal, lower, upper})");
  const int n = numerics.list_size(key);
  if (n == 0) {
    numerics.fail(key, "expected a list of parameters ({name, unit, nominal, lower, upper}), one "
                       "per entry of the program's parameter vector");
  }
  std::vector<model::Parameter> params;
  std::set<std::string> seen;
  for (int i = 0; i < n; ++i) {
    const auto item = numerics.item(key, i);
    if (!item->is_map()) item->fail("", "expected a map {name, unit, nominal, lower, upper}");
    std::vector<std::string> keys = {"name", "unit", "nominal", "lower", "upper", "doc", "family", "segment"};
    if (input_vectors) keys.push_back("input");
    item->check_keys(keys);
    if (item->integer("input", 0) < 0) item->fail("input", "expected an input vector index >= 0");
    model::Parameter p;
    p.name = item->text("name", "");
    if (!identifier(p.name)) {
      item->fail("name", "expected a parameter name (letters, digits, '_'), got '" + p.name + "'");
    }
    if (!seen.insert(p.name).second) item->fail("name", "parameter '" + p.name + "' is listed twice");
    if (!item->has("unit")) item->fail("unit", "missing required key 'unit' (SI, e.g. Pa, m^3, Pa s/m^3, 1)");
    p.unit = item->text("unit", "");
    if (!known_unit(p.unit)) {
      item->fail("unit", "unknown unit '" + p.unit +
                             "': expected a unit of model/units.h (mL, mmHg, s, ...) or an SI "
                             "product such as Pa/m^3, Pa s/m^3, m^3/(Pa s), 1");
    }
    for (const char* required : {"nominal", "lower", "upper"}) {
      if (!item->has(required)) item->fail(required, std::string("missing required key '") + required + "'");
    }
    // Values written with a unit are converted to the declared unit, then to SI.
    const DeclaredUnit d = declared(p.unit);
    p.nominal = d.factor * item->quantity("nominal", p.unit, 0.0);
    p.lower = d.factor * item->quantity("lower", p.unit, 0.0);
    p.upper = d.factor * item->quantity("upper", p.unit, 0.0);
    const std::string written = p.unit;
    p.unit = si_unit_of(p.unit);
    if (!(p.lower < p.upper)) {
      item->fail("upper", "expected upper > lower (" + std::to_string(p.lower / d.factor) + " " + p.unit + ")");
    }
    if (p.nominal < p.lower || p.nominal > p.upper) {
      item->fail("nominal", "nominal value outside [lower, upper] = [" + std::to_string(p.lower / d.factor) +
                                ", " + std::to_string(p.upper / d.factor) + "] " + written);
    }
    read_tags(*item, "parameter of the black-box model (declared in the config)", model::parameter_families(), p);
    params.push_back(std::move(p));
  }
  return model::ParameterSpace(std::move(params));
}

std::vector<model::Channel> read_channel_table(const model::OptionReader& numerics,
                                               const std::string& key) {
  if (!numerics.has(key)) numerics.fail(key, "missing required key '" + key + "' (a list of {name, unit})");
  const int n = numerics.list_size(key);
  if (n == 0) numerics.fail(key, "expected a list of output channels ({name, unit})");
  std::vector<model::Channel> channels;
  std::set<std::string> seen;
  for (int i = 0; i < n; ++i) {
    const auto item = numerics.item(key, i);
    if (!item->is_map()) item->fail("", "expected a map {name, unit}");
    item->check_keys({"name", "unit", "doc", "family", "segment"});
    model::Channel c;
    c.name = item->text("name", "");
    if (!identifier(c.name)) {
      item->fail("name", "expected a channel name (letters, digits, '_'), got '" + c.name + "'");
    }
    if (c.name == "time" || c.name == "t") item->fail("name", "'" + c.name + "' is the time column, not a channel");
    if (!seen.insert(c.name).second) item->fail("name", "channel '" + c.name + "' is listed twice");
    if (!item->has("unit")) item->fail("unit", "missing required key 'unit' (m^3, mL, Pa, mmHg, 1, ...)");
    const std::string unit = item->text("unit", "");
    const auto si = model::units::to_si(unit);
    if (!si) {
      item->fail("unit", "unknown unit '" + unit + "': expected a unit of model/units.h (m^3, mL, Pa, "
                         "mmHg, m^3/s, 1, ...)");
    }
    c.unit = si->si_unit;
    read_tags(*item, "output channel of the black-box model", model::channel_families(), c);
    channels.push_back(std::move(c));
  }
  return channels;
}

PeriodSource read_period(const model::OptionReader& numerics, const model::ParameterSpace& parameters,
                         bool required) {
  PeriodSource out;
  const auto family = parameters.find("period");
  if (!numerics.has("period")) {
    if (family) {
      out.parameter = *family;
      return out;
    }
    if (required) numerics.fail("period", "missing required key 'period' (a time such as 0.8 s, or the name of a parameter)");
    return out;
  }
  const std::string text = numerics.text("period", "");
  if (const auto index = parameters.index(text)) {
    if (parameters[*index].unit != "s") {
      numerics.fail("period", "parameter '" + text + "' is in " + parameters[*index].unit + ", not a time");
    }
    out.parameter = *index;
    return out;
  }
  if (family) {
    numerics.fail("period", "the period is parameter '" + parameters[*family].name +
                                "' of the table (family period); a fixed period would put the curves "
                                "on a time axis the model did not use when it is studied: write `period: " +
                                parameters[*family].name + "`");
  }
  out.fixed = numerics.quantity("period", "s", 0.0);
  if (!(out.fixed > 0.0)) numerics.fail("period", "expected a period > 0 s or the name of a parameter");
  return out;
}

std::optional<model::RunResult> refuse_out_of_bounds(const model::ParameterSpace& parameters,
                                                     const Eigen::Ref<const Eigen::VectorXd>& theta) {
  const std::string bad = parameters.check(theta);
  if (bad.empty()) return std::nullopt;
  model::RunResult result;
  result.status = model::Status::Error(model::StatusCode::kOutOfBounds, bad);
  return result;
}

}  // namespace sigmaheart::app::blackbox
