#pragma once

// Options given as a map (what app/'s config reader does with a YAML section), for tests of the
// models' numerics parsing (model/registry.h OptionReader). Errors throw std::invalid_argument
// "key: message".
#include "model/registry.h"

#include <algorithm>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::model::testing {

class MapOptions final : public OptionReader {
 public:
  explicit MapOptions(std::map<std::string, std::string> values) : values_(std::move(values)) {}
  // The same options under another section path (as the config reader names it).
  MapOptions named(std::string path) const {
    MapOptions o(values_);
    o.path_ = std::move(path);
    return o;
  }
  bool defined() const override { return true; }
  bool has(const std::string& key) const override { return values_.count(key) > 0; }
  bool is_map() const override { return true; }
  std::string path() const override { return path_; }
  void check_keys(const std::vector<std::string>& allowed) const override {
    for (const auto& [k, v] : values_) {
      if (!contains(allowed, k)) fail(k, "unknown key '" + k + "'");
    }
  }
  double quantity(const std::string& key, const std::string&, double fallback) const override {
    return has(key) ? std::stod(values_.at(key)) : fallback;
  }
  double number(const std::string& key, double fallback) const override { return quantity(key, "1", fallback); }
  bool boolean(const std::string& key, bool fallback) const override {
    if (!has(key)) return fallback;
    if (values_.at(key) != "true" && values_.at(key) != "false") fail(key, "expected true or false");
    return values_.at(key) == "true";
  }
  int integer(const std::string& key, int fallback) const override {
    return has(key) ? std::stoi(values_.at(key)) : fallback;
  }
  std::string choice(const std::string& key, const std::vector<std::string>& allowed) const override {
    if (!has(key) || !contains(allowed, values_.at(key))) fail(key, "bad choice");
    return values_.at(key);
  }
  std::vector<double> quantities(const std::string& key, const std::string&) const override {
    fail(key, "lists are not supported here");
  }
  std::unique_ptr<OptionReader> child(const std::string&) const override { return std::make_unique<NoOptions>(); }
  [[noreturn]] void fail(const std::string& key, const std::string& message) const override {
    throw std::invalid_argument(key + ": " + message);
  }

 private:
  static bool contains(const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  }
  std::map<std::string, std::string> values_;
  std::string path_ = "numerics";
};

}  // namespace sigmaheart::model::testing
