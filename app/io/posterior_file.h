// The posterior of a personalisation result, read back (docs/estimation.md s.12.1): what `therapy`
// propagates. One function, so that a change of the calibrate or personalize files (issues 45, 46)
// is adapted here only.
//
// From a `calibrate` result: /estimate/names, /estimate/transform, /estimate/eta_mean,
// /estimate/mean (= T(eta_mean)), /estimate/eta_covariance, /summary attribute `ok`. From a
// `personalize` result: /estimate/eta, /estimate/value, /estimate/eta_covariance, /summary attribute
// `termination` ("completed"). Both: /parameters/names and /values (every model parameter at the
// estimate) and the config in the root attribute `config` (its simulator.model). A personalisation
// by zones (`personalize.estimate.<family>.zones`, model/zoned_simulator.h) wrote the zoned parameters:
// each zone parameter `<family>_<zone>` sets every segment of its zone.
//
// The transforms are rebuilt from what the files hold: identity; log with reference
// value / exp(eta); logit on the bounds that reproduce value = T(eta) (to 1e-9 relative), tried in
// order: the config's `bounds:` of the parameter, the model's bounds with the lower one raised to
// 0 (a log prior on a bounded parameter, calibration_setup.h), the model's bounds.
#pragma once

#include "app/config_node.h"
#include "estimation/propagation.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <filesystem>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

struct PosteriorFile {
  std::string kind;            // "calibrate" or "personalize"
  std::string model;           // simulator.model of the result's config
  std::string status;          // its termination in words
  bool converged = false;      // calibrate: ok; personalize: completed
  Eigen::VectorXd theta;       // every model parameter at the estimate (SI)
  // Per posterior parameter the model parameters it sets: one, or every member of a zone.
  std::vector<std::vector<int>> estimated;
  estimation::Posterior posterior;
};

// `space` and `model` are those of the config that reads the file; `at` the config key that names
// it. Every problem (no such file, not a result of these commands, another model or other
// parameters, a missing dataset, a transform that cannot be rebuilt) is an InputError at `at`.
PosteriorFile read_posterior(const std::filesystem::path& file, const model::ParameterSpace& space,
                             const std::string& model, const ConfigNode& at);

}  // namespace sigmaheart::app::io
