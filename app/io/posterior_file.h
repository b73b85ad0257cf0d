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
//
// The wrappers `personalize` puts around the model (app/personalize_model.cpp) are rebuilt or
// accounted for here, so that a therapy simulates the model that was fitted:
//  - `shares: data` (model/regional_volume_shares.h): the file's /setup/volume_shares,
//    /setup/reference_shares and /setup attributes reference_volume, share_exponents give the
//    wrapper; its parameters vshare_basal/mid/apical/gamma (17 segments) follow the model's, so
//    the posterior may hold them. (A file written before the reference shares were stored gets
//    them from the model at the estimate: they are its wall-area shares, docs/models.md s.3.3.)
//  - `align: end-diastole` (model/time_shift.h): t_shift moves the observation clock only, not the
//    beat; a therapy's responses do not depend on it, so an estimated t_shift is marginalised
//    out of the posterior (its row and column of the eta covariance dropped: exact for a Gaussian)
//    and named in `marginalised`.
#pragma once

#include "app/config_node.h"
#include "estimation/propagation.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

// The volume-share wrapper of a personalisation (model::RegionalVolumeShares' arguments).
struct VolumeShareSetup {
  Eigen::VectorXd shares;          // omega_p, per regional channel of the model
  Eigen::VectorXd reference;       // s_p, the model's reference shares
  double reference_volume = 0.0;   // [m^3] V_ref of the share law (level_exponents only)
  bool level_exponents = false;    // vshare_basal/mid/apical/gamma appended to the parameters
};

struct PosteriorFile {
  std::string kind;            // "calibrate" or "personalize"
  std::string model;           // simulator.model of the result's config
  std::string status;          // its termination in words
  bool converged = false;      // calibrate: ok; personalize: completed
  // The parameters of the model a therapy runs: the config's model's, then the wrapper's
  // (vshare_*) when the personalisation fitted with `shares: data`.
  model::ParameterSpace space;
  std::optional<VolumeShareSetup> volume_shares;
  std::vector<std::string> marginalised;  // estimated but dropped from the posterior (t_shift)
  // personalize: the filter's mean NIS and its expectation (the number of observed channels);
  // NaN for a calibrate result.
  double nis_mean = std::nan("");
  double nis_expected = std::nan("");
  Eigen::VectorXd theta;       // every parameter of `space` at the estimate (SI)
  // Per posterior parameter the model parameters it sets: one, or every member of a zone.
  std::vector<std::vector<int>> estimated;
  estimation::Posterior posterior;
};

// `space` and `model` are those of the config that reads the file; `at` the config key that names
// it. Every problem (no such file, not a result of these commands, another model or other
// parameters, a missing dataset, a transform that cannot be rebuilt) is an InputError at `at`.
// `simulator` (the config's model, unwrapped) serves only an older file's reference shares.
PosteriorFile read_posterior(const std::filesystem::path& file, const model::ParameterSpace& space,
                             const std::string& model, const ConfigNode& at,
                             model::SteppableSimulator* simulator = nullptr);

// `inner` wrapped as the personalisation fitted it (RegionalVolumeShares for `shares: data`), or
// inner itself. Throws std::invalid_argument when the shares do not fit the model.
std::unique_ptr<model::SteppableSimulator> wrap_as_fitted(const PosteriorFile& file,
                                                          std::unique_ptr<model::SteppableSimulator> inner);

}  // namespace sigmaheart::app::io
