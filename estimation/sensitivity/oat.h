// One-at-a-time sensitivity (docs/estimation.md s.6; the thesis' study): each parameter moved to a low
// and a high value around nominal with the others at nominal; the effect on every output. 2p + 1
// runs: the nominal point, then low_1, high_1, low_2, high_2, ...
#pragma once

#include "estimation/ensemble.h"
#include "estimation/sensitivity/design.h"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation::sensitivity {

enum class OatMode {
  kRange,     // low = lower bound, high = upper bound of the prior parameter
  kRelative,  // low = nominal (1 - relative_change), high = nominal (1 + relative_change);
              // not clipped to the range (a value the model rejects is a failed run)
};
const char* to_string(OatMode mode);
std::optional<OatMode> parse_oat_mode(const std::string& text);  // "range", "relative"

struct OatOptions {
  OatMode mode = OatMode::kRelative;
  double relative_change = 0.1;  // kRelative: fraction of nominal, in (0, 1)
  EnsembleOptions ensemble;
  std::string validate() const;
};

struct TornadoBar {
  int parameter = 0;        // index into OatSummary::parameters
  double delta_low = 0.0;   // z(low) - z(nominal)
  double delta_high = 0.0;  // z(high) - z(nominal)
  double swing = 0.0;       // |z(high) - z(low)|, the bar length
};

struct OatSummary : StudySummary {
  // status kFailedNominal when the nominal run failed (no deltas then). Layout: run 0 "nominal",
  // then "low <name>", "high <name>" per parameter.
  Eigen::VectorXd theta_nominal, theta_low, theta_high;  // p
  Eigen::VectorXd z_nominal;                             // m
  Eigen::MatrixXd z_low, z_high;                         // p x m (NaN rows for failed runs)
  Eigen::MatrixXd delta_low, delta_high;                 // p x m, z - z_nominal
  Eigen::MatrixXd swing;                                 // p x m, |z_high - z_low|, the bar length
  // p x m: the elasticity ((z_high - z_low) / z_nominal) / ((theta_high - theta_low) / theta_nominal),
  // a central-difference estimate of d ln z / d ln theta; NaN where z_nominal or theta_nominal is 0.
  Eigen::MatrixXd normalised;

  // Bars of one output, parameters ordered by decreasing swing (failed parameters last).
  std::vector<TornadoBar> tornado(int output) const;
  // Parameter indices of one output by decreasing swing (NaN last).
  std::vector<int> ranking(int output) const { return rank_by(swing, output); }
  std::string report() const;
};

// The 2p + 1 points in physical units (nominal first, then low/high of each parameter).
Eigen::MatrixXd oat_design(const Prior& prior, const OatOptions& options);
// Block labels of the 2p + 1 runs.
DesignLayout oat_layout(const std::vector<std::string>& names);

// Runs the design through an Ensemble (options.ensemble). Throws std::invalid_argument on invalid
// options or prior (before any run); failed runs are listed, a failed nominal run is a status.
OatSummary run_oat(const ForwardModel& model, const Prior& prior, const OatOptions& options);

}  // namespace sigmaheart::estimation::sensitivity
