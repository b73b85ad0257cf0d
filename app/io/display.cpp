#include "app/io/display.h"

#include "model/units.h"

#include <charconv>
#include <sstream>
#include <utility>
#include <vector>

namespace sigmaheart::app::io {

DisplayUnit display_unit(const std::string& si_unit) {
  static const std::vector<std::pair<std::string, std::string>> clinical = {
      {"m^3", "mL"}, {"m^3/s", "mL/s"}, {"Pa", "mmHg"}, {"Pa/s", "mmHg/s"}};
  for (const auto& [si, shown] : clinical) {
    if (si == si_unit) return {shown, model::units::convert(1.0, si, shown)};
  }
  return {si_unit, 1.0};
}

DisplayUnit quantity_display_unit(const std::string& name, const std::string& si_unit) {
  if (name == "EF" && si_unit == "1") return {"%", 100.0};
  if (si_unit == "s") return {"ms", 1000.0};
  return display_unit(si_unit);
}

std::string format_number(double value, int significant) {
  std::ostringstream s;
  s.precision(significant);
  s << value;
  return s.str();
}

std::string format_exact(double value) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, value);
  return std::string(buf, r.ptr);
}

}  // namespace sigmaheart::app::io
