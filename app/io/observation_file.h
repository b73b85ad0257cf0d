// Observation curves in CSV (ESTIMATION.md s.5, "Observation files"): one header row of
// `name [unit]` columns, time first, then one row per frame:
//
//   # patient 07, cine MRI, 30 frames      <- comments start with '#', anywhere on a line
//   time [ms], V_lv [mL], P_lv [mmHg], V_seg07 [mL]
//   0,   142.1, 9.8, 8.31
//   33.3, 140.7, 12.4, 8.27
//   ...
//
// Time is `time [ms]` or `time [s]`; V_* columns take a volume unit, P_* columns a pressure unit,
// other columns any unit model::units knows. Fields are separated by commas, blank lines are
// skipped. Values are converted to SI on reading; the units written in the header are kept for
// reports. Times must increase strictly; at least kMinFrames rows are needed. Every error is an
// app::InputError "file:line:column: ..." saying what was expected.
#pragma once

#include "model/simulator.h"

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

inline constexpr int kMinFrames = 3;

struct ObservationCurves {
  model::Trajectory trajectory;            // times [s]; channels in SI (their unit says which)
  std::string time_unit;                   // as written in the header ("ms" or "s")
  std::vector<std::string> display_units;  // per channel, as written in the header ("mL" ...)
};

// Reads a file; throws app::InputError (with the path, line and column) on bad content or when the
// file cannot be opened.
ObservationCurves read_observation_csv(const std::filesystem::path& path);
// Same from a stream; `source` names it in messages.
ObservationCurves parse_observation_csv(std::istream& in, const std::string& source);

// Writes the same format atomically (temporary file, then rename). trajectory is SI (or in the
// units its channels name); time_unit is "ms" or "s"; display_units (one per channel, empty = the
// channel's unit) choose the columns' units. comment lines (without '#') go first. Values are
// written with the shortest text that reads back to the same double in the display unit.
// Throws std::invalid_argument for unknown or mismatched units, app::RunFailure when the file
// cannot be written.
void write_observation_csv(const std::filesystem::path& path, const model::Trajectory& trajectory,
                           const std::string& time_unit,
                           const std::vector<std::string>& display_units = {},
                           const std::vector<std::string>& comment = {});

}  // namespace sigmaheart::app::io
