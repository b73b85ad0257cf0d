// The start of a personalisation from a calibrate result (personalize: start:, docs/estimation.md
// s.4.9): the global calibration's posterior as the prior of the global parameters, which the
// filter then holds or co-estimates, as Marchesseau et al. (2013, Med Image Anal 17:816) start the
// regional filter from the calibrated global state.
//
//   personalize:
//     start:
//       file: results/calibrate-lv.h5   # written by `sigmaheart calibrate` (app/io/calibration_h5.h)
//       globals: estimate               # estimate (posterior = their prior, co-estimated) | hold
//
// Read from the calibrate HDF5: /estimate/names, /estimate/transform, /estimate/eta_mean,
// /estimate/eta_covariance (the posterior in the transformed coordinates eta), /estimate/mean
// (T(eta_mean)) and the model named in /config. A calibrated parameter is matched by name; a global
// one without a namesake (the sphere's sigma0) onto the per-segment family of the same stem
// (sigma0_01..17): it then centres that family's prior (and sets it when held). Any other
// parameter, a file that is not a calibrate result, or a transform that does not reproduce the
// stored estimate is an InputError at `file:` (file:line:column).
#pragma once

#include "app/config.h"
#include "estimation/prior.h"

#include <Eigen/Core>

#include <filesystem>
#include <string>
#include <vector>

namespace sigmaheart::app {

struct CalibratedStart {
  std::filesystem::path file;
  std::string model;               // the calibrate config's model
  bool estimate_globals = true;    // false: held at the posterior mean
  // The calibrated parameters matched by name (Gaussian in eta: posterior mean, std and the
  // correlation between them), with the transforms the calibration used.
  estimation::Prior globals;
  // Calibrated global parameters that centre a per-segment family: (family stem, theta).
  std::vector<std::pair<std::string, double>> family_centres;
};

// The regional parameters (in segment order) of the per-segment family a config key names: the
// family tag itself ("contractility") or the common stem "<key>_" of its parameters' names
// ("sigma0" for sigma0_01..17); empty when it names none.
std::vector<int> per_segment_family(const model::ParameterSpace& space, const std::string& key);

// Parses `start:` and reads its file against `space` (the personalisation's parameters) and
// `model` (its model's name). Every problem is an InputError at the offending key.
CalibratedStart parse_calibrated_start(const ConfigNode& start, const std::filesystem::path& base,
                                       const model::ParameterSpace& space, const std::string& model);

}  // namespace sigmaheart::app
