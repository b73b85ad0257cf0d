#include "app/errors.h"

namespace sigmaheart::app {

std::string Location::str() const {
  std::string s = file;
  if (line > 0) {
    s.push_back(':');
    s.append(std::to_string(line));
    if (column > 0) {
      s.push_back(':');
      s.append(std::to_string(column));
    }
  }
  return s;
}

InputError::InputError(Location where, const std::string& message)
    : std::runtime_error(where.str().empty() ? message : where.str() + ": " + message),
      where_(std::move(where)),
      message_(message) {}

}  // namespace sigmaheart::app
