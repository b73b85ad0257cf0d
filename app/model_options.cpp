#include "app/model_options.h"

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
