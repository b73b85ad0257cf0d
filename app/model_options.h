// model::OptionReader over a config node: how a model's `numerics:` section reaches the model
// without model/ knowing YAML. Every error is the ConfigNode's InputError, with file:line:column
// (or the `--set` that gave the value) and a did-you-mean for unknown keys and choices.
#pragma once

#include "app/config_node.h"
#include "model/registry.h"

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app {

class ConfigOptionReader final : public model::OptionReader {
 public:
  explicit ConfigOptionReader(ConfigNode node) : node_(std::move(node)) {}

  bool defined() const override { return node_.defined(); }
  bool has(const std::string& key) const override { return node_.has(key); }
  bool is_map() const override { return node_.is_map(); }
  std::string path() const override { return node_.path(); }
  void check_keys(const std::vector<std::string>& allowed) const override { node_.check_keys(allowed); }
  double quantity(const std::string& key, const std::string& unit, double fallback) const override {
    return node_.optional_quantity(key, unit, fallback);
  }
  double number(const std::string& key, double fallback) const override {
    return node_.optional<double>(key, fallback);
  }
  int integer(const std::string& key, int fallback) const override {
    return node_.optional<int>(key, fallback);
  }
  std::string choice(const std::string& key, const std::vector<std::string>& allowed) const override {
    return node_.require_child(key).as_choice(allowed);
  }
  std::vector<double> quantities(const std::string& key, const std::string& unit) const override;
  std::string text(const std::string& key, const std::string& fallback) const override {
    return node_.optional<std::string>(key, fallback);
  }
  bool boolean(const std::string& key, bool fallback) const override {
    return node_.optional<bool>(key, fallback);
  }
  int list_size(const std::string& key) const override;
  std::string json_text(const std::string& key) const override;
  std::unique_ptr<model::OptionReader> item(const std::string& key, int i) const override;
  // The directory of the config file (empty when the section came from a `--set`).
  std::string base_directory() const override;
  std::unique_ptr<model::OptionReader> child(const std::string& key) const override {
    return std::make_unique<ConfigOptionReader>(node_[key]);
  }
  [[noreturn]] void fail(const std::string& key, const std::string& message) const override {
    (key.empty() ? node_ : node_[key]).fail(message);
  }

 private:
  ConfigNode node_;
};

}  // namespace sigmaheart::app
