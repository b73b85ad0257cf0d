// The pieces every results file shares (docs/architecture.md, "Results files"): provenance on the root,
// the config text, the parameters, trajectories, and summaries of named values with units.
//
// Units convention of results files, CSV, JSON and the terminal: curves and indices are written
// in clinical units (mL, mmHg, mL/s, mmHg/s; time in s), the SI values of the models converted by
// display_unit(); parameters keep the SI unit their model declares. Every numeric dataset carries
// a `units` attribute naming the unit its numbers are in, so readers never guess.
#pragma once

#include "app/io/display.h"
#include "app/io/hdf5_writer.h"
#include "model/simulator.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app::io {


// "0.1.0" and the `git describe` of the build.
std::string version();
std::string git_describe();
// Now, as ISO 8601 UTC with seconds: "2026-11-21T05:50:31Z".
std::string utc_now();

// Root attributes of every results file.
struct Provenance {
  std::string kind;                    // "simulate", "calibrate", ... (scripts/plot dispatches on it)
  std::string name;                    // the config's name
  std::string config_file;
  std::string config_text;             // the whole file, as read
  std::vector<std::string> overrides;  // "--set key=value" in order
  std::string command_line;
  std::optional<std::uint64_t> seed;
  std::string start_utc;
  std::string end_utc;
  int threads = 1;
  int ranks = 1;
};
// The same fields as a JSON object, the `provenance` key of every JSON summary: sigmaheart_version,
// git_describe, kind, name, config_file, config (the text), overrides, command_line, seed (null if
// none), start_utc, end_utc (now, if not yet set), threads, ranks, units_convention.
nlohmann::ordered_json provenance_json(const Provenance& p);

// `value` zero-padded to the number of digits of `largest`, so numbered HDF5 groups sort in
// order as text (h5py and xarray list members alphabetically): padded_number(7, 12) = "07".
std::string padded_number(long long value, long long largest);

// Root attributes (sigmaheart_version, git_describe, kind, name, config_file, config, overrides,
// command_line, seed if any, start_utc, end_utc, threads, ranks, units_convention) and the
// /config text dataset.
void write_provenance(Hdf5Writer& out, const Provenance& p);

// <group>/names, units, values, lower, upper (values in each parameter's own unit).
void write_parameters(Hdf5Writer& out, const std::string& group,
                      const model::ParameterSpace& space,
                      const Eigen::Ref<const Eigen::VectorXd>& values);

// <group>/time [s] and one dataset per channel in its display unit (attributes `units`, `doc`);
// the group's `channels` attribute lists the channel names in order.
void write_trajectory(Hdf5Writer& out, const std::string& group, const model::Trajectory& t);

// CSV with a header row "time [s],V_lv [mL],..." in display units, written atomically.
void write_trajectory_csv(const std::filesystem::path& path, const model::Trajectory& t);

// A named value with its unit (already in the unit shown).
struct Indicator {
  std::string name;
  double value = 0.0;
  std::string unit;
  std::string doc;
};

// Attributes "<name>" (value) and "<name>.units" on `group` (created if missing).
void write_indicators(Hdf5Writer& out, const std::string& group,
                      const std::vector<Indicator>& indicators);
// {"status": "not-periodic", "EDV": {"value": 142.1, "unit": "mL"}, ..., "provenance": {...}}
// ("status" only when `status` is not empty, "provenance" only when `provenance` is given),
// written atomically.
void write_indicators_json(const std::filesystem::path& path,
                           const std::vector<Indicator>& indicators,
                           const Provenance* provenance = nullptr, const std::string& status = {});
// An aligned table "name  value unit  doc" for the terminal.
std::string format_indicators(const std::vector<Indicator>& indicators);

}  // namespace sigmaheart::app::io
