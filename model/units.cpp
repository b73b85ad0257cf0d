#include "model/units.h"

#include <map>
#include <stdexcept>

namespace sigmaheart::model::units {

std::optional<Conversion> to_si(const std::string& unit) {
  static const std::map<std::string, Conversion> table = {
      {"m^3", {1.0, "m^3"}},          {"L", {1e-3, "m^3"}},          {"l", {1e-3, "m^3"}},
      {"mL", {kMilliLitre, "m^3"}},   {"ml", {kMilliLitre, "m^3"}},  {"cm^3", {kMilliLitre, "m^3"}},
      {"Pa", {1.0, "Pa"}},            {"kPa", {1e3, "Pa"}},          {"mmHg", {kMmHg, "Pa"}},
      {"MPa", {1e6, "Pa"}},  // bulk moduli (lv-3d numerics: bulk_modulus)
      {"s", {1.0, "s"}},              {"ms", {1e-3, "s"}},
      {"m^3/s", {1.0, "m^3/s"}},      {"mL/s", {kMilliLitre, "m^3/s"}},
      {"ml/s", {kMilliLitre, "m^3/s"}}, {"L/min", {1e-3 / 60.0, "m^3/s"}},
      {"Pa/s", {1.0, "Pa/s"}},        {"kPa/s", {1e3, "Pa/s"}},      {"mmHg/s", {kMmHg, "Pa/s"}},
      {"1/s", {1.0, "1/s"}},          {"Hz", {1.0, "1/s"}},          {"s^-1", {1.0, "1/s"}},
      {"1/min", {1.0 / 60.0, "1/s"}}, {"bpm", {1.0 / 60.0, "1/s"}},  // heart rate: beats per min
      {"m", {1.0, "m"}},              {"mm", {1e-3, "m"}},           {"cm", {1e-2, "m"}},
      {"1", {1.0, "1"}},              {"-", {1.0, "1"}},             {"", {1.0, "1"}},
      {"%", {0.01, "1"}},
  };
  auto it = table.find(unit);
  if (it == table.end()) return std::nullopt;
  return it->second;
}

bool compatible(const std::string& a, const std::string& b) {
  auto ca = to_si(a);
  auto cb = to_si(b);
  return ca && cb && ca->si_unit == cb->si_unit;
}

double convert(double value, const std::string& from, const std::string& to) {
  auto cf = to_si(from);
  auto ct = to_si(to);
  if (!cf) throw std::invalid_argument("unknown unit '" + from + "'");
  if (!ct) throw std::invalid_argument("unknown unit '" + to + "'");
  if (cf->si_unit != ct->si_unit) {
    throw std::invalid_argument("cannot convert '" + from + "' (" + cf->si_unit + ") to '" + to +
                                "' (" + ct->si_unit + ")");
  }
  return value * cf->factor / ct->factor;
}

}  // namespace sigmaheart::model::units
