#include "app/config_node.h"

#include "model/simulator.h"
#include "model/units.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace sigmaheart::app {

namespace detail {
struct ConfigOrigin {
  std::string file;
  // (dotted path, origin text) of each override; later entries win.
  std::vector<std::pair<std::string, std::string>> overrides;
};
}  // namespace detail

namespace {

Location mark_location(const std::string& file, const YAML::Mark& mark) {
  if (mark.is_null() || mark.line < 0) return {file, 0, 0};
  return {file, mark.line + 1, mark.column + 1};
}

// True when `path` equals `prefix` or lies below it ("a.b" is under "a", "a.bc" is not).
bool under(const std::string& path, const std::string& prefix) {
  if (path.size() < prefix.size() || path.compare(0, prefix.size(), prefix) != 0) return false;
  return path.size() == prefix.size() || path[prefix.size()] == '.' || path[prefix.size()] == '[';
}

std::string quoted_list(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& item : items) s += (s.empty() ? "" : ", ") + item;
  return s;
}

std::string trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

}  // namespace

ConfigNode::ConfigNode(YAML::Node node, std::shared_ptr<const detail::ConfigOrigin> origin,
                       std::string path, Location fallback)
    : node_(std::move(node)),
      origin_(std::move(origin)),
      path_(std::move(path)),
      fallback_(std::move(fallback)) {}

std::string ConfigNode::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

const std::string* ConfigNode::override_origin(const std::string& path) const {
  if (!origin_) return nullptr;
  for (auto it = origin_->overrides.rbegin(); it != origin_->overrides.rend(); ++it) {
    if (under(path, it->first)) return &it->second;
  }
  return nullptr;
}

bool ConfigNode::defined() const { return node_.IsDefined() && !node_.IsNull(); }

Location ConfigNode::location() const {
  if (const std::string* o = override_origin(path_)) return {*o, 0, 0};
  if (node_.IsDefined()) {
    Location l = mark_location(origin_ ? origin_->file : fallback_.file, node_.Mark());
    if (l.line > 0) return l;
  }
  return fallback_;
}

Location ConfigNode::key_location(const std::string& key) const {
  if (const std::string* o = override_origin(child_path(key))) return {*o, 0, 0};
  if (is_map()) {
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      if (it->first.IsScalar() && it->first.Scalar() == key) {
        Location l = mark_location(origin_ ? origin_->file : fallback_.file, it->first.Mark());
        if (l.line > 0) return l;
      }
    }
  }
  return location();
}

ConfigNode ConfigNode::operator[](const std::string& key) const {
  if (defined() && !node_.IsMap()) {
    fail("expected a map with key '" + key + "', got " + describe());
  }
  YAML::Node child;  // undefined unless found
  if (defined()) {
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      if (it->first.IsScalar() && it->first.Scalar() == key) {
        child = it->second;
        break;
      }
    }
  }
  if (!child.IsDefined()) {
    return ConfigNode(YAML::Node(YAML::NodeType::Undefined), origin_, child_path(key), location());
  }
  return ConfigNode(child, origin_, child_path(key), key_location(key));
}

ConfigNode ConfigNode::operator[](size_t i) const {
  if (!is_sequence()) fail("expected a sequence, got " + describe());
  if (i >= node_.size()) fail("has no item " + std::to_string(i));
  return ConfigNode(node_[i], origin_, path_ + "[" + std::to_string(i) + "]", location());
}

size_t ConfigNode::size() const {
  return (defined() && (node_.IsMap() || node_.IsSequence())) ? node_.size() : 0;
}

std::vector<std::string> ConfigNode::keys() const {
  std::vector<std::string> out;
  if (!is_map()) return out;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    out.push_back(it->first.IsScalar() ? it->first.Scalar() : std::string("?"));
  }
  return out;
}

std::string ConfigNode::describe() const {
  if (!node_.IsDefined() || node_.IsNull()) return "nothing";
  if (node_.IsMap()) return "a map";
  if (node_.IsSequence()) return "a sequence";
  return "'" + node_.Scalar() + "'";
}

ConfigNode ConfigNode::require_child(const std::string& key) const {
  ConfigNode c = (*this)[key];
  if (!c.defined()) {
    const std::string where = path_.empty() ? "" : " in " + path_;
    if (node_.IsDefined() && node_.IsMap() && node_[key].IsDefined()) {
      throw InputError(key_location(key), "key '" + key + "'" + where + " has no value");
    }
    fail("missing required key '" + key + "'" + where);
  }
  return c;
}

void ConfigNode::check_keys(const std::vector<std::string>& allowed, const std::string& noun,
                            const std::string& context) const {
  if (!defined()) return;
  if (!node_.IsMap()) {
    fail((path_.empty() ? std::string("expected") : path_ + ": expected") +
         " a map of key: value, got " + describe());
  }
  const std::string where =
      !context.empty() ? context : (path_.empty() ? "at the top level" : "in " + path_);
  // Keys first (keys() copies each scalar out of yaml-cpp's iterator proxy), then positions: a
  // single loop that compared keys while iterating missed duplicates under -O3 with GCC 12.
  const std::vector<std::string> names = keys();
  size_t index = 0;
  for (auto it = node_.begin(); it != node_.end(); ++it, ++index) {
    const std::string& key = names[index];
    const auto first = names.begin();
    const auto here = first + static_cast<std::ptrdiff_t>(index);
    if (std::find(first, here, key) != here) {
      throw InputError(mark_location(origin_ ? origin_->file : fallback_.file, it->first.Mark()),
                       "duplicate key '" + key + "' " + where);
    }
    bool known = false;
    for (const auto& a : allowed) known = known || a == key;
    if (known) continue;
    std::string msg = "unknown " + noun + " '" + key + "' " + where;
    const std::string guess = model::closest_match(key, allowed);
    if (!guess.empty()) {
      msg += " (did you mean '" + guess + "'?)";
    } else if (allowed.size() <= 12) {
      msg += "; expected one of: " + quoted_list(allowed);
    }
    throw InputError(key_location(key), msg);
  }
}

namespace {

// The scalar `node` as T, or a located "<path>: expected <what>, got ..." error.
template <class T>
T scalar_as(const ConfigNode& node, const std::string& what) {
  if (!node.is_scalar()) node.fail(node.path() + ": expected " + what + ", got " + node.describe());
  try {
    return node.yaml().as<T>();
  } catch (const YAML::Exception&) {
    node.fail(node.path() + ": expected " + what + ", got " + node.describe());
  }
}

}  // namespace

template <>
double ConfigNode::as<double>() const {
  const double v = scalar_as<double>(*this, "a number");
  if (!std::isfinite(v)) fail(path_ + ": expected a finite number, got " + describe());
  return v;
}

template <>
int ConfigNode::as<int>() const {
  return scalar_as<int>(*this, "an integer");
}

template <>
bool ConfigNode::as<bool>() const {
  return scalar_as<bool>(*this, "true or false");
}

template <>
std::string ConfigNode::as<std::string>() const {
  if (!is_scalar()) fail(path_ + ": expected a string, got " + describe());
  return node_.Scalar();
}

template <>
std::vector<double> ConfigNode::as<std::vector<double>>() const {
  if (!is_sequence()) fail(path_ + ": expected a sequence of numbers, got " + describe());
  std::vector<double> out;
  for (size_t i = 0; i < node_.size(); ++i) out.push_back((*this)[i].as<double>());
  return out;
}

template <>
std::vector<std::string> ConfigNode::as<std::vector<std::string>>() const {
  if (!is_sequence()) fail(path_ + ": expected a sequence of strings, got " + describe());
  std::vector<std::string> out;
  for (size_t i = 0; i < node_.size(); ++i) out.push_back((*this)[i].as<std::string>());
  return out;
}

double ConfigNode::as_quantity(const std::string& unit) const {
  if (!is_scalar()) fail(path_ + ": expected a number in " + unit + ", got " + describe());
  const std::string text = trim(node_.Scalar());
  const char* begin = text.c_str();
  char* end = nullptr;
  const double number = std::strtod(begin, &end);
  if (end == begin) {
    fail(path_ + ": expected a number in " + unit + " or '<number> <unit>', got " + describe());
  }
  if (!std::isfinite(number)) fail(path_ + ": expected a finite number, got " + describe());
  const std::string given = trim(std::string(end));
  if (given.empty() || given == unit) return number;
  if (!model::units::to_si(given)) {
    fail(path_ + ": unknown unit '" + given + "' in " + describe());
  }
  if (!model::units::to_si(unit)) {
    fail(path_ + ": cannot convert '" + given + "' to " + unit + "; give the value in " + unit);
  }
  try {
    return model::units::convert(number, given, unit);
  } catch (const std::invalid_argument& e) {
    fail(path_ + ": " + e.what());
  }
}

std::string ConfigNode::as_choice(const std::vector<std::string>& allowed) const {
  const std::string value = as<std::string>();
  for (const auto& a : allowed) {
    if (a == value) return value;
  }
  std::string msg = path_ + ": unknown value '" + value + "'";
  const std::string guess = model::closest_match(value, allowed);
  if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
  msg += "; expected one of: " + quoted_list(allowed);
  fail(msg);
}

// ---------------------------------------------------------------------------------------------

namespace {
// yaml-cpp keeps both pairs of a repeated key and lookups return the first, so a key given twice
// (an estimate: entry copied and not renamed) was silently half-ignored. Refused at the second.
void reject_duplicate_keys(const YAML::Node& node, const std::string& file_name) {
  if (node.IsMap()) {
    std::map<std::string, int> first_line;
    for (auto it = node.begin(); it != node.end(); ++it) {
      if (it->first.IsScalar()) {
        const std::string key = it->first.Scalar();
        const auto [at, fresh] = first_line.emplace(key, it->first.Mark().line + 1);
        if (!fresh) {
          throw InputError(mark_location(file_name, it->first.Mark()),
                           "duplicate key '" + key + "' (first at line " +
                               std::to_string(at->second) + "): each key may appear once");
        }
      }
      reject_duplicate_keys(it->second, file_name);
    }
  } else if (node.IsSequence()) {
    for (const YAML::Node& item : node) reject_duplicate_keys(item, file_name);
  }
}
bool starts_at(const YAML::Node& node, int line, int column) {
  const YAML::Mark m = node.Mark();
  return !m.is_null() && m.line + 1 == line && (column <= 0 || m.column + 1 == column);
}

// Removes the innermost map entry or sequence item of `node` written at line:column (erase_at)
// and returns its key, "" when there is none.
std::string erase_written_at(YAML::Node node, int line, int column) {
  if (node.IsMap()) {
    for (auto it = node.begin(); it != node.end(); ++it) {
      if (std::string inner = erase_written_at(it->second, line, column); !inner.empty()) {
        return inner;
      }
      if (starts_at(it->first, line, column) || starts_at(it->second, line, column)) {
        const YAML::Node key = it->first;
        node.remove(key);
        return key.IsScalar() ? key.Scalar() : std::string("?");
      }
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      if (std::string inner = erase_written_at(node[i], line, column); !inner.empty()) return inner;
      if (starts_at(node[i], line, column)) {
        node.remove(i);
        return "[" + std::to_string(i) + "]";
      }
    }
  }
  return "";
}
}  // namespace

std::string ConfigFile::erase_at(const Location& where) {
  if (where.file != file() || where.line <= 0) return "";
  return erase_written_at(root_, where.line, where.column);
}

ConfigFile ConfigFile::parse(const std::string& text, const std::string& file_name) {
  ConfigFile f;
  f.text_ = text;
  f.origin_ = std::make_shared<detail::ConfigOrigin>();
  f.origin_->file = file_name;
  try {
    f.root_.reset(YAML::Load(text));
  } catch (const YAML::ParserException& e) {
    throw InputError(mark_location(file_name, e.mark), "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InputError(mark_location(file_name, e.mark), "cannot read YAML: " + e.msg);
  }
  reject_duplicate_keys(f.root_, file_name);
  if (!f.root_.IsDefined() || f.root_.IsNull()) {
    f.root_.reset(YAML::Node(YAML::NodeType::Map));  // an empty file: "missing key" errors follow
  } else if (!f.root_.IsMap()) {
    throw InputError(mark_location(file_name, f.root_.Mark()),
                     "expected a map of sections (name:, simulator: ...) at the top level");
  }
  return f;
}

ConfigFile ConfigFile::load(const std::filesystem::path& path) {
  if (std::error_code ec; std::filesystem::is_directory(path, ec)) {
    throw InputError(Location{path.string(), 0, 0},
                     "is a directory; expected a YAML config file (e.g. configs/healthy.yaml)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::error_code ec;
    const bool exists = std::filesystem::exists(path, ec);
    throw InputError(Location{path.string(), 0, 0},
                     exists ? "cannot read the config file" : "no such config file");
  }
  std::ostringstream s;
  s << in.rdbuf();
  return parse(s.str(), path.string());
}

const std::string& ConfigFile::file() const { return origin_->file; }

std::vector<std::string> ConfigFile::overrides() const {
  std::vector<std::string> out;
  for (const auto& o : origin_->overrides) out.push_back(o.second);
  return out;
}

bool ConfigFile::overridden(const std::string& dotted_path) const {
  for (const auto& o : origin_->overrides) {
    if (under(dotted_path, o.first)) return true;
  }
  return false;
}

ConfigNode ConfigFile::root() const {
  // An empty file (or one of comments only) has no node to point at: its errors point at 1:1.
  return ConfigNode(root_, origin_, "", Location{origin_->file, 1, 1});
}

void ConfigFile::set(const std::string& dotted_path, const std::string& value_text,
                     const std::string& origin) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream s(dotted_path);
  while (std::getline(s, part, '.')) {
    if (part.empty()) throw InputError(Location{origin, 0, 0}, "empty key in '" + dotted_path + "'");
    parts.push_back(part);
  }
  if (parts.empty()) throw InputError(Location{origin, 0, 0}, "expected key=value");

  YAML::Node value;
  try {
    value = YAML::Load(value_text);
  } catch (const YAML::Exception& e) {
    throw InputError(Location{origin, 0, 0}, "cannot read the value '" + value_text + "': " + e.msg);
  }

  YAML::Node node = root_;
  std::string walked;
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    walked += (walked.empty() ? "" : ".") + parts[i];
    const YAML::Node existing = std::as_const(node)[parts[i]];  // const: looks, never inserts
    if (!existing.IsDefined() || existing.IsNull()) {
      node[parts[i]] = YAML::Node(YAML::NodeType::Map);
    } else if (!existing.IsMap()) {
      throw InputError(Location{origin, 0, 0},
                       "cannot set '" + dotted_path + "': '" + walked + "' is not a map");
    }
    node.reset(node[parts[i]]);  // rebind (plain assignment would overwrite the parent's value)
  }
  node[parts.back()] = value;
  origin_->overrides.emplace_back(dotted_path, origin);
}

}  // namespace sigmaheart::app
