#include "app/model_options.h"

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

}  // namespace sigmaheart::app
