#include "app/model_options.h"

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <filesystem>

namespace sigmaheart::app {

std::vector<double> ConfigOptionReader::quantities(const std::string& key,
                                                   const std::string& unit) const {
  const ConfigNode list = node_.require_child(key);
  if (!list.is_sequence()) {
    list.fail(list.path() + ": expected a list of numbers in " + unit + ", got " + list.describe());
  }
  std::vector<double> out;
  out.reserve(list.size());
  for (size_t i = 0; i < list.size(); ++i) out.push_back(list[i].as_quantity(unit));
  return out;
}



namespace {

// A YAML value as JSON: a scalar that reads as an integer, a number or true/false becomes one
// (unless it was quoted), null stays null, everything else is a string.
nlohmann::json to_json(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Map: {
      nlohmann::json j = nlohmann::json::object();
      for (const auto& kv : node) j[kv.first.as<std::string>()] = to_json(kv.second);
      return j;
    }
    case YAML::NodeType::Sequence: {
      nlohmann::json j = nlohmann::json::array();
      for (const auto& v : node) j.push_back(to_json(v));
      return j;
    }
    case YAML::NodeType::Scalar: {
      const std::string text = node.Scalar();
      if (node.Tag() == "!") return text;  // quoted: a string
      long long i = 0;
      double d = 0.0;
      bool b = false;
      if (YAML::convert<long long>::decode(node, i)) return i;
      if (YAML::convert<double>::decode(node, d)) return d;
      if (YAML::convert<bool>::decode(node, b)) return b;
      return text;
    }
    default:
      return nullptr;
  }
}

}  // namespace

std::string ConfigOptionReader::json_text(const std::string& key) const {
  const ConfigNode value = node_[key];
  if (!value.defined()) return "{}";
  return to_json(value.yaml()).dump();
}

int ConfigOptionReader::list_size(const std::string& key) const {
  const ConfigNode list = node_[key];
  if (!list.defined()) return 0;
  if (!list.is_sequence()) list.fail(list.path() + ": expected a list, got " + list.describe());
  return static_cast<int>(list.size());
}

std::unique_ptr<model::OptionReader> ConfigOptionReader::item(const std::string& key, int i) const {
  const ConfigNode list = node_.require_child(key);
  if (!list.is_sequence()) list.fail(list.path() + ": expected a list, got " + list.describe());
  if (i < 0 || static_cast<size_t>(i) >= list.size()) {
    list.fail(list.path() + ": expected an item " + std::to_string(i) + ", the list has " +
              std::to_string(list.size()));
  }
  return std::make_unique<ConfigOptionReader>(list[static_cast<size_t>(i)]);
}

std::string ConfigOptionReader::base_directory() const {
  const std::string file = node_.location().file;
  if (file.empty() || file.rfind("--set", 0) == 0) return {};
  return std::filesystem::path(file).parent_path().string();
}

}  // namespace sigmaheart::app
