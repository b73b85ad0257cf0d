// Writers of a sensitivity study (app/commands/sensitivity.cpp): the /analysis group of the
// results file, the JSON summary and the terminal report, all from the setup and the Summary the
// estimator returned. Outputs are shown in clinical units (io::quantity_display_unit); parameters
// in SI. Layout of /analysis:
//   parameters/{names, units, sampling, lower, upper, nominal}
//   outputs/{names, units, si_units, from_si}
//   design/{theta, z, status, block, row}   every run; `layout` attribute
//   failed/{run, block, design_row, code, message, theta}   (attribute count)
//   oat/{theta_low, theta_high, z_nominal, delta_low, delta_high, swing, normalised}
//   morris/{mu, mu_star, sigma, *_low, *_high, dropped_trajectories}
//   sobol/{S1, ST, S1_low, S1_high, ST_low, ST_high, output_std}, attribute `estimators`,
//   sobol/convergence/n (sizes) and .../n<size>/... the same tables per prefix size
//   exact/{S1, ST} for the test functions
// Tables are parameter x output (row_names, column_names attributes).
#pragma once

#include "app/io/hdf5_writer.h"
#include "app/sensitivity_setup.h"

#include <nlohmann/json.hpp>

#include <string>

namespace sigmaheart::app::io {

// Writes /analysis (not the provenance).
void write_sensitivity_h5(Hdf5Writer& h5, const SensitivitySetup& setup,
                          const SensitivitySummary& summary);

// The JSON summary: parameters, outputs, per output the indices and ranking (display units),
// exact indices, validity, failed runs. `results_file` is recorded as given.
nlohmann::ordered_json sensitivity_json(const std::string& name, const SensitivitySetup& setup,
                                        const SensitivitySummary& summary,
                                        const std::string& results_file);

// The terminal report: design, failures, and per output the leading parameters.
std::string sensitivity_report(const SensitivitySetup& setup, const SensitivitySummary& summary);

}  // namespace sigmaheart::app::io
