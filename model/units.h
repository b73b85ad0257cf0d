// Unit conversion at the I/O boundary. Inside every model quantities are SI (m, m^3, Pa, s);
// configs, observation files and reports may use clinical units (mL, mmHg, kPa, ms).
#pragma once

#include <optional>
#include <string>

namespace sigmaheart::model::units {

inline constexpr double kMmHg = 133.322;      // Pa per mmHg (conventional mercury column)
inline constexpr double kMilliLitre = 1e-6;   // m^3 per mL

// Factor f with value_SI = f * value_in_unit, and the SI unit it converts to. Known units:
// volume m^3, L, mL (ml, cm^3); pressure Pa, kPa, mmHg; time s, ms; flow m^3/s, mL/s, L/min;
// pressure rate Pa/s, kPa/s, mmHg/s; rate 1/s, Hz, 1/min, bpm; dimensionless "1", "%", "-".
// std::nullopt for an unknown unit string.
struct Conversion {
  double factor = 1.0;
  std::string si_unit;
};
std::optional<Conversion> to_si(const std::string& unit);

// value in `from` expressed in `to`; throws std::invalid_argument when the units are unknown or of
// different dimensions (the message names both).
double convert(double value, const std::string& from, const std::string& to);

// True when both units are known and measure the same dimension.
bool compatible(const std::string& a, const std::string& b);

}  // namespace sigmaheart::model::units
