// Writers of the fit report (estimation/fit_report.h; docs/estimation.md s.11): into a JSON
// summary and into a group of an HDF5 results file (read by scripts/sigmaplot_discrepancy.py).
// Numbers are written in display units (app/io/display.h: mL, mmHg, EF in %), each with its unit.
//
// HDF5 layout under `group` (e.g. "/fit_report"):
//   @summary, @discrepancy_rms                     the sentence for the log; the threshold [noise std]
//   notes                                          strings: what could not be computed
//   channels/{names, units, count, rms_normalised [noise std], rms_residual [see units],
//             max_abs_normalised [noise std]}
//   indices/{names, units, observed, fitted, error}                    (volume curve at frames)
//   phases/{time [s], phase (int, CyclePhase), phase_name, names}      (classified frames)
//   curves/<channel>/{time [s], observed, fitted, noise_std [unit], normalised_residual [noise std]}
//   discrepancy/<channel>/{phase_names, frames, rms_normalised [noise std], share [1]},
//             @rms_normalised, @dominant
//   identifiability/{names, correlation [1], std_ratio [1], uninformed, correlated_a,
//             correlated_b, correlated_rho [1]}, @uninformed_ratio, @correlation_threshold
//
// The MAP least-squares summary (estimation/least_squares.h) under its own group (e.g. "/map"):
//   @termination, @message, @report, @simulations, @failures, @best_start, @polished, @cost,
//   @prior_cost
//   names, units, theta, theta_std, theta_prior [per parameter, see units], eta, eta_std,
//   eta_prior_mean, eta_prior_std [1], eta_covariance [1], jacobian [1] (whitened, obs x params)
//   fit/{estimate, prior} [SI, per observation], iterations/{start, iteration, cost,
//   gradient_max_norm, step_norm, successful}, starts/{final_cost, iterations, termination},
//   failures (strings)
#pragma once

#include "app/io/hdf5_writer.h"
#include "estimation/fit_report.h"
#include "estimation/least_squares.h"

#include <nlohmann/json.hpp>

#include <string>

namespace sigmaheart::app::io {

// parent["fit_report"] = {"summary", "channels": [...], "indices": [...], "discrepancy": [...],
// "identifiability": {...}, "notes": [...]}; values in display units with a "unit" next to them.
void add_fit_report_json(nlohmann::ordered_json& parent, const estimation::FitReport& report,
                         const estimation::FitReportOptions& options = {});

// The layout above under `group` (created; absolute path).
void write_fit_report_h5(Hdf5Writer& h5, const std::string& group,
                         const estimation::FitReport& report,
                         const estimation::FitReportOptions& options = {});

// The layout above under `group`; units: the prior's SI units per parameter.
void write_least_squares_h5(Hdf5Writer& h5, const std::string& group,
                            const estimation::LeastSquaresSummary& summary,
                            const std::vector<std::string>& units);
// parent["map"] = {"termination", "message", "parameters": {name: {value, std, prior, unit}},
// "simulations", "failures", "cost", "prior_cost", "rms_noise_std_before", "..._after"}.
void add_least_squares_json(nlohmann::ordered_json& parent,
                            const estimation::LeastSquaresSummary& summary,
                            const std::vector<std::string>& units);

}  // namespace sigmaheart::app::io
