// The calibration problem of a config: which observations (a curve file or typed-in indices, and
// their noise), which parameters (prior, spread, transform) and which estimator options. Parsed
// and validated here, in one place, for `calibrate`, `specificity` and `validate`.
//
//   observations:
//     file: data/volunteer03.csv        # relative to the config; header `name [unit]`, one row per frame
//     indices: [EDV, ESV, EF, P_max, dPdt_max, dVdt_min]   # computed from the curves like the simulated ones
//     curves: [V_lv]                    # optional: the curves themselves at the measured frames
//     align: ecg                        # frame times are after the ECG trigger (default), or end-diastole
//     noise: {EDV: 3 mL, ESV: 3 mL, EF: 0.02, P_max: 3 mmHg, V_lv: 3 mL, default: 5 %}
//   # or, without a file:
//   #  values: {EDV: {value: 142 mL, noise: 5 mL}, EF: {value: 58 %, noise: 0.02}}
//   # or named outputs of a model that returns values (observers/output_values.h):
//   #  outputs: {"y[0]": {value: 0.1, noise: 1}, "y[1]": {value: 4, noise: 1}}
//   #  covariance: [[1, 0.5], [0.5, 1]]   # optional full noise covariance (replaces the noises)
//   estimate:
//     sigma0: {prior: 1.0e5, spread: 30 %, transform: log}      # prior defaults to the config value
//     R_p:    {spread: "1.0e7 Pa s/m^3", transform: logit, bounds: [1.0e6, 2.0e8]}
//   # a `log` prior on a parameter with a finite upper bound becomes logit on [max(lower, 0),
//   # upper] (docs/estimation.md s.3.1, Bounds): no member or estimate leaves the model's bounds
//   calibration:
//     sigma_points: simplex      # simplex | canonical | star | scaled (kappa, alpha, beta)
//     mode: map                  # map (default) | one-shot | iterate-keep-spread | iterate-inflate
//     max_iterations: 20         # default 20 (one-shot: 1)
//     tolerance: 1.0e-3          # on the largest step in prior standard deviations
//     max_rejections: 8          # map: damped candidates per iteration before "diverged"
//     bound_margin: 1.0e-3       # "stuck at a bound" within this fraction of the prior's distance
//     global_start: {samples: 32, keep: 3, width: 3}   # optional Sobol' screen, docs s.3.4
//     failure_policy: shrink-and-retry   # or abort (shrink_factor, max_retries)
//     method: unscented          # unscented (default) | least-squares: the Ceres MAP solver
//                                # (estimation/least_squares.h, docs/estimation.md s.11) instead
//     reference: least-squares   # optional with unscented: the Ceres MAP as a check of the UT
//     least_squares: {max_iterations: 50, difference: central, relative_step: 1.0e-4}
//                                # global_start above sets its multi-start screen too
#pragma once

#include "app/config.h"
#include "estimation/least_squares.h"
#include "estimation/ut_calibration.h"
#include "observers/curve_sampler.h"
#include "observers/observer.h"

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app {

struct CalibrationProblem {
  // The measured curves when the observations came from a file (SI), with the units the file used.
  std::optional<model::Trajectory> measured;
  std::vector<std::string> measured_display_units;
  std::filesystem::path observation_file;

  // Curve observations: how the frames are read from a simulated beat and where the measured
  // frames' origin lies on the file's clock (the fit figure draws the model on the data's axis).
  std::optional<observers::CurveSamplerOptions> curve_sampling;
  double frame_origin = 0.0;                       // [s]
  observers::ObservationSet observations;          // SI, display units kept
  std::unique_ptr<observers::Observer> observer;   // same names and order as observations
  estimation::Prior prior;                         // the estimated parameters, in config order
  estimation::UtOptions options;
  bool least_squares_method = false;               // calibration.method: least-squares
  bool least_squares_reference = false;            // calibration.reference: least-squares
  estimation::LeastSquaresOptions least_squares;   // its options (ensemble set by the command)
};

// Parses `observations:`, `estimate:` and `calibration:` of a config whose simulator section is
// already parsed. Every problem is an InputError at the offending key (file:line:column).
// observation_file, when not empty, replaces `observations.file` (a cohort study calibrates every
// case with one config; relative paths are taken relative to the config file, like the key's).
CalibrationProblem parse_calibration_problem(const Config& config,
                                             const std::filesystem::path& observation_file = {});

// A `log` prior on a parameter with a finite upper bound becomes logit on the model's bounds, so
// that no member and no estimate leaves them (docs/estimation.md s.1.1). Used by calibrate and
// personalize.
estimation::PriorParameter bounded_by_the_model(estimation::PriorParameter c, const model::Parameter& p);

// One Gaussian prior parameter from {prior, spread, transform, bounds} with the conventions above:
// prior defaults to the parameter's nominal value; spread "30 %" (relative), "2e4 Pa" (absolute,
// any unit of the parameter's dimension) or "0.3 eta"; transform log (default), logit (bounds
// default to the parameter's own) or identity. Keys are not checked here (callers allow their own
// extra keys). `personalize` uses it too, so both commands read priors the same way. The prior's
// bounds are the transform's range (the parameter's own bounds are checked for the prior mean).
estimation::PriorParameter parse_estimated_parameter(const model::Parameter& p,
                                                           const ConfigNode& node);

// A scalar "<number> <unit>" (or a bare number: empty unit) split into its value and unit text.
std::pair<double, std::string> number_and_unit(const ConfigNode& node);


}  // namespace sigmaheart::app
