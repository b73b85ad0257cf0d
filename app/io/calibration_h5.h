// What `calibrate` writes: the HDF5 results file (kind "calibrate", read by
// scripts/sigmaplot_calibrate.py), the JSON summary and the terminal report, all from the
// UtSummary (which carries every number shown) and the problem it solved. Observations are shown
// in the units of their data file when compatible, else in display_unit() (app/io/display.h).
#pragma once

#include "app/calibration_setup.h"
#include "estimation/fit_report.h"
#include "estimation/least_squares.h"
#include "estimation/prior_conflict.h"
#include "app/io/results.h"
#include "estimation/ut_calibration.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

// Display unit and factor (display = SI * factor) of each observation.
struct ObservationDisplay {
  std::vector<std::string> units;
  Eigen::VectorXd factor;
};
ObservationDisplay observation_display(const observers::ObservationSet& observations);

struct CalibrationResults {
  const CalibrationProblem* problem = nullptr;
  const estimation::UtSummary* summary = nullptr;
  estimation::UtFailurePolicy failure_policy = estimation::UtFailurePolicy::kShrinkAndRetry;
  const model::ParameterSpace* space = nullptr;  // the simulator's parameters
  Eigen::VectorXd estimated_theta;               // full parameter vector at the estimate
  std::optional<model::Trajectory> prior_curves;       // the model at the prior mean
  std::optional<model::Trajectory> calibrated_curves;  // the model at the estimate
  // The same beats as the curve sampler reads them (observers::AlignedBeat): /fit/curves, drawn on
  // the data's time axis by the fit figure.
  std::optional<observers::AlignedBeat> prior_aligned, calibrated_aligned;
  // How the calibrated curves fit the data (estimation/fit_report.h): /fit_report, "fit_report".
  const estimation::FitReport* fit_report = nullptr;
  // The Ceres MAP run, when it was the method or the reference (least_squares.h): /map, "map".
  const estimation::LeastSquaresSummary* map = nullptr;
  // The estimate's distance from the prior and its physiological ranges (prior_conflict.h):
  // /estimate/prior_z, in_range; "prior_z", "in_range" per parameter; the report's column.
  std::optional<estimation::PriorConflict> prior_conflict;
};

// The results file (written atomically; provenance.end_utc is set here).
void write_calibration_h5(const std::filesystem::path& path, const CalibrationResults& results,
                          Provenance provenance);
// {"kind": "calibrate", "parameters": {...}, "fit": {...}, ..., "provenance": {...}}, written
// atomically (provenance_json, app/io/results.h; end_utc now if not set).
void write_calibration_json(const std::filesystem::path& path, const std::string& name,
                            const CalibrationResults& results, const Provenance& provenance);
// The brief report, the parameter table and the fit table for the terminal.
std::string calibration_report(const CalibrationResults& results);

}  // namespace sigmaheart::app::io
