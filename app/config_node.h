// Reusable pieces for reading YAML configs with located errors (STYLE.md practice 3).
//
// A ConfigFile is the text of one config plus its parsed tree and the `--set` overrides merged
// into it. A ConfigNode is a view of one node that knows its dotted path ("simulator.numerics.dt")
// and where it came from, so every error it raises names file:line:column (1-based) or the
// `--set` that introduced the value. Each config section is parsed into a typed struct in one
// function that uses only these calls:
//
//   void parse_calibration(const ConfigNode& node, CalibrationOptions& o) {
//     node.check_keys({"max_iterations", "tolerance"});
//     o.max_iterations = node.optional<int>("max_iterations", o.max_iterations);
//     o.tolerance = node.optional_quantity("tolerance", "1", o.tolerance);
//     if (o.max_iterations < 1) node["max_iterations"].fail("expected an integer >= 1");
//   }
#pragma once

#include "app/errors.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app {

namespace detail {
struct ConfigOrigin;  // file name and the paths set by overrides (shared by all nodes of a file)
}

class ConfigNode {
 public:
  ConfigNode() = default;
  ConfigNode(YAML::Node node, std::shared_ptr<const detail::ConfigOrigin> origin, std::string path,
             Location fallback);
  ConfigNode(const ConfigNode&) = default;
  ConfigNode(ConfigNode&&) = default;
  // Assignment rebinds this handle to the other node. yaml-cpp's own Node::operator= writes the
  // other node's value INTO the node this handle refers to, which edited the parsed config in place
  // (a case list assigned over the `cases:` path; a re-bound `activation:` map).
  ConfigNode& operator=(const ConfigNode& other) {
    if (this != &other) {
      node_.reset(other.node_);
      origin_ = other.origin_;
      path_ = other.path_;
      fallback_ = other.fallback_;
    }
    return *this;
  }
  ConfigNode& operator=(ConfigNode&& other) noexcept {
    node_.reset(other.node_);
    origin_ = std::move(other.origin_);
    path_ = std::move(other.path_);
    fallback_ = std::move(other.fallback_);
    return *this;
  }

  // The value at `key` of a map. A missing key gives an undefined node whose errors point at
  // this node (its parent). Throws InputError when this node is a scalar or sequence.
  ConfigNode operator[](const std::string& key) const;
  // Item i of a sequence (path "key[i]").
  ConfigNode operator[](size_t i) const;

  bool defined() const;  // present and not null ("key:" with nothing after it counts as absent)
  bool is_map() const { return defined() && node_.IsMap(); }
  bool is_sequence() const { return defined() && node_.IsSequence(); }
  bool is_scalar() const { return defined() && node_.IsScalar(); }
  bool has(const std::string& key) const { return (*this)[key].defined(); }
  size_t size() const;                 // entries of a map or sequence, 0 otherwise
  std::vector<std::string> keys() const;  // keys of a map, in file order
  const std::string& path() const { return path_; }
  // True when the value (or a parent of it) came from a `--set` override.
  bool overridden() const { return override_origin(path_) != nullptr; }
  const YAML::Node& yaml() const { return node_; }
  // The scalar text, or a short description ("a map", "a sequence", "nothing").
  std::string describe() const;

  // This node's value. Supported T: double (finite), int, bool, std::string,
  // std::vector<double>, std::vector<std::string>. Wrong types give
  // "<path>: expected a number, got 'abc'".
  template <class T>
  T as() const;
  template <class T>
  T require(const std::string& key) const {
    return require_child(key).template as<T>();
  }
  template <class T>
  T optional(const std::string& key, T fallback) const {
    ConfigNode c = (*this)[key];
    return c.defined() ? c.template as<T>() : fallback;
  }

  // Unit-aware numbers: a plain number is taken to be in `unit`; a string "<number> <unit>" (for
  // example "8 mmHg", "1 ms") is converted to `unit` with model/units.h.
  double as_quantity(const std::string& unit) const;
  double require_quantity(const std::string& key, const std::string& unit) const {
    return require_child(key).as_quantity(unit);
  }
  double optional_quantity(const std::string& key, const std::string& unit,
                           double fallback) const {
    ConfigNode c = (*this)[key];
    return c.defined() ? c.as_quantity(unit) : fallback;
  }

  // A string that must be one of `allowed` (enum names); a did-you-mean otherwise.
  std::string as_choice(const std::vector<std::string>& allowed) const;

  // The child at `key`, which must be present: "missing required key 'simulator'" otherwise.
  ConfigNode require_child(const std::string& key) const;

  // Requires a map (an absent node passes) whose keys are all in `allowed`. An unknown key is
  // reported at the key: "unknown <noun> 'dtt' <context> (did you mean 'dt'?)". The default
  // context is "in <path>" ("at the top level" for the root).
  void check_keys(const std::vector<std::string>& allowed, const std::string& noun = "key",
                  const std::string& context = "") const;

  // Where this node came from (file:line:column, or the `--set` that gave it).
  Location location() const;
  // Where the key `key` of this map is written (the key itself, not its value).
  Location key_location(const std::string& key) const;

  InputError error(const std::string& message) const { return InputError(location(), message); }
  [[noreturn]] void fail(const std::string& message) const { throw error(message); }

 private:
  std::string child_path(const std::string& key) const;
  const std::string* override_origin(const std::string& path) const;

  YAML::Node node_;
  std::shared_ptr<const detail::ConfigOrigin> origin_;
  std::string path_;
  Location fallback_;  // used when the node is missing or was built in memory
};

template <> double ConfigNode::as<double>() const;
template <> int ConfigNode::as<int>() const;
template <> bool ConfigNode::as<bool>() const;
template <> std::string ConfigNode::as<std::string>() const;
template <> std::vector<double> ConfigNode::as<std::vector<double>>() const;
template <> std::vector<std::string> ConfigNode::as<std::vector<std::string>>() const;

// One config file: its text, its parsed tree and the overrides merged into it.
class ConfigFile {
 public:
  // Reads and parses a file. InputError when it cannot be read or is not valid YAML (with the
  // line and column of the syntax error).
  static ConfigFile load(const std::filesystem::path& path);
  // Parses text; `file_name` is used in error messages.
  static ConfigFile parse(const std::string& text, const std::string& file_name);

  // Sets the value at a dotted path (creating maps on the way) from YAML text, e.g.
  // set("simulator.numerics.dt", "5e-4", "--set numerics.dt=5e-4"). Errors on that value name
  // `origin` instead of a file position.
  void set(const std::string& dotted_path, const std::string& value_text,
           const std::string& origin);

  // Removes the map entry (key and value) or the sequence item written at `where`, the innermost
  // one when several start there (a block map starts where its first key does), and returns its
  // key ("[i]" for an item); "" when `where` is not a position in this file or nothing is written
  // there. `sigmaheart validate` uses it to go on past an error (app/commands/validate.cpp).
  std::string erase_at(const Location& where);

  const std::string& file() const;
  const std::string& text() const { return text_; }
  // The `--set` origins applied, in order (for provenance).
  std::vector<std::string> overrides() const;
  // True when the value at `dotted_path` (or one of its parents) was set by an override.
  bool overridden(const std::string& dotted_path) const;
  ConfigNode root() const;

 private:
  std::string text_;
  YAML::Node root_;
  std::shared_ptr<detail::ConfigOrigin> origin_;
};

}  // namespace sigmaheart::app
