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
//   sobol/{S1, S1_conf, ST, ST_conf, S1_percentile_low, S1_percentile_high, ST_percentile_low,
//          ST_percentile_high, output_std}  (SALib's names; *_conf = z x bootstrap std),
//   sobol/{S2, S2_conf}/<output>  p x p per output with second_order (NaN on/below the diagonal),
//   attributes `estimators`, `second_order`; sobol/convergence/n (sizes) and
//   .../n<size>/... the same tables per prefix size, <size> zero-padded to the width of N
//   exact/{S1, ST, S2} for the test functions
// Tables are parameter x output (row_names, column_names attributes), and /analysis/parameters/names
// and /analysis/outputs/names are attached to their axes as HDF5 dimension scales.
#pragma once

#include "app/io/hdf5_writer.h"
#include "app/io/results.h"
#include "app/sensitivity_setup.h"

#include <nlohmann/json.hpp>

#include <string>

namespace sigmaheart::app::io {

// Writes /analysis (not the provenance).
void write_sensitivity_h5(Hdf5Writer& h5, const SensitivitySetup& setup,
                          const SensitivitySummary& summary);

// The JSON summary: parameters, outputs, per output the indices and ranking (display units),
// exact indices, validity, failed runs, and the provenance (provenance_json, app/io/results.h).
// `results_file` is recorded as given.
nlohmann::ordered_json sensitivity_json(const std::string& name, const SensitivitySetup& setup,
                                        const SensitivitySummary& summary,
                                        const std::string& results_file, const Provenance& provenance);

// The terminal report: design, failures, and per output the leading parameters.
std::string sensitivity_report(const SensitivitySetup& setup, const SensitivitySummary& summary);

}  // namespace sigmaheart::app::io
