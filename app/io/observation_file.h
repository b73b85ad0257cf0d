// Observation curves in CSV (docs/estimation.md s.5, "Observation files"): one header row of
// `name [unit]` columns, time first, then one row per frame:
//
//   # patient 07, cine MRI, 30 frames      <- comments start with '#', anywhere on a line
//   time [ms], V_lv [mL], P_lv [mmHg], V_seg07 [mL]
//   0,   142.1, 9.8, 8.31
//   33.3, 140.7,    , 8.27                 <- a missing value (empty, NaN, NA)
//   ...
//
// Header: the unit in brackets or parentheses ("V_lv (mL)"); the time column is named `time` or
// `t` in any case, in s or ms ("t [s]", "Time (ms)", also "t_ms", "time_s"). V_* columns take a
// volume unit (mL, L, m^3), P_* columns a pressure unit (mmHg, kPa, Pa), other columns any unit
// model::units knows (a heart rate in bpm or 1/min). Fields are separated by commas, blank lines
// are skipped. Values are converted to SI on reading; the units written in the header are kept
// for reports. A data cell that is empty, NaN/nan or NA is a missing value, kept as NaN in the
// trajectory (a missing time is an error). Times must increase strictly; at least kMinFrames
// rows are needed. Every error is an app::InputError "file:line:column: ..." saying what was
// expected.
//
// Missing values downstream: the observers refuse NaN samples (observers/beat.cpp: "a sample
// value is NaN or infinite"); drop_missing_frames() skips those frames first.
#pragma once

#include "model/simulator.h"

#include <filesystem>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

inline constexpr int kMinFrames = 3;

struct ObservationCurves {
  model::Trajectory trajectory;            // times [s]; channels in SI (their unit says which)
  std::string time_unit;                   // as written in the header ("ms" or "s")
  std::vector<std::string> display_units;  // per channel, as written in the header ("mL" ...)
  std::vector<int> lines;                  // per frame, its line in the file (for messages)
  int missing = 0;                         // missing values (NaN entries of trajectory.values)
};

// File column name -> channel name, applied to the header before any check ("LVV" -> "V_lv"),
// so that a channel's unit is checked under its new name. Every key must name a column.
using ColumnMapping = std::map<std::string, std::string>;

// Reads a file; throws app::InputError (with the path, line and column) on bad content or when the
// file cannot be opened.
ObservationCurves read_observation_csv(const std::filesystem::path& path,
                                       const ColumnMapping& rename = {});
// Same from a stream; `source` names it in messages.
ObservationCurves parse_observation_csv(std::istream& in, const std::string& source,
                                        const ColumnMapping& rename = {});

// Missing frames skipped: the curves without the frames where one of `channels` (all channels when
// empty) is missing, and the period of the full record (span + mean frame spacing, as
// observers::measured_frames() infers it), which the reduced record, no longer evenly spaced,
// must be read with (BeatOptions::period). Throws app::InputError naming `source` when fewer than
// kMinFrames frames remain.
struct PresentFrames {
  ObservationCurves curves;   // NaN left only in channels not asked for
  double period = 0.0;        // [s]
  std::vector<int> dropped;   // lines of the skipped frames
};
PresentFrames drop_missing_frames(const ObservationCurves& curves,
                                  const std::vector<std::string>& channels,
                                  const std::string& source);

// The frames must fit in one simulated beat of `period` [s] (the model's parameter 'period'): a
// frame later than origin + period, origin = min(0, first time) when the times are times after
// the ECG trigger (times_after_trigger), else the first time, is an input error naming `source`,
// the frame's line and the period; the simulated beat would otherwise be read there wrapped into
// its first beat. Half the smallest frame spacing is tolerated (a closed beat's repeated first
// frame). Throws app::InputError; curves.lines must hold one line per frame.
void check_frames_in_one_beat(const ObservationCurves& curves, double period,
                              const std::string& source, bool times_after_trigger);

// A measured activation map (an electro-anatomical map reduced to the AHA segments): one time per
// segment after the beat's electrical onset, in CSV with the header `segment, time [ms]` (any time
// unit), '#' comments, one row per segment (`7, 42.5`). Segments are >= 1 and distinct; the
// caller checks them against its model. InputError "file:line:column: ..." otherwise.
struct ActivationMap {
  std::vector<int> segments;   // 1-based
  std::vector<double> times;   // [s]
  std::vector<int> lines;      // per row, its line in the file
};
ActivationMap read_activation_map_csv(const std::filesystem::path& path);
ActivationMap parse_activation_map_csv(std::istream& in, const std::string& source);

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
