// How numbers are shown: the one place that decides display units and number formats for the
// terminal, CSV, JSON and HDF5 (docs/architecture.md, "Units"). Curves and indices are shown in
// clinical units (mL, mmHg, mL/s, mmHg/s); parameters keep the SI unit their model declares.
#pragma once

#include <string>

namespace sigmaheart::app::io {

// The unit a quantity is shown in, and the factor from SI: shown = si_value * from_si.
struct DisplayUnit {
  std::string unit;
  double from_si = 1.0;
};
// m^3 -> mL, m^3/s -> mL/s, Pa -> mmHg, Pa/s -> mmHg/s; any other unit is shown as is.
DisplayUnit display_unit(const std::string& si_unit);

// A named quantity of a beat (a global index, an observation): display_unit(si_unit), except the
// ejection fraction (EF, unit 1) in % and durations within a beat (unit s) in ms.
DisplayUnit quantity_display_unit(const std::string& name, const std::string& si_unit);

// A number with `significant` significant digits in the shortest of fixed and scientific
// notation ("5.3e+04", "0.289", "1051"); non-finite values as "nan", "inf", "-inf".
std::string format_number(double value, int significant = 4);
// The shortest text that reads back to the same double (CSV and round trips).
std::string format_exact(double value);

}  // namespace sigmaheart::app::io
