// Morris elementary effects (Morris 1991, Technometrics 33:161), with mu* of Campolongo, Cariboni
// & Saltelli (2007, Environ Model Softw 22:1509) (docs/estimation.md s.6).
//
// Design: r trajectories of p + 1 points on the grid {0, 1/(L-1), ..., 1} of the unit cube, L
// even. Trajectory t (stream make_stream(seed, t)): a random direction d_i = +-1 per parameter,
// a random base level per parameter from which a step d_i Delta stays on the grid, a random
// order of the parameters; step s moves parameter order[s] by d_i Delta, Delta = L / (2 (L - 1))
// (Morris 1991, s.3). Grid points map to physical theta through each uniform PriorParameter (in
// the physical or eta space). Runs: r (p + 1), trajectory-major.
//
// Elementary effects are in unit-cube coordinates: EE_i = (y(x + d_i Delta e_i) - y(x)) / (d_i Delta),
// i.e. the change of the output when the parameter crosses its whole range, per unit. For
// y = sum c_i u_i, EE_i = c_i exactly.
// Statistics over trajectories: mu = mean EE, mu* = mean |EE|, sigma = sample standard deviation
// of EE (divisor r - 1); 95 % percentile-bootstrap intervals resampling whole trajectories.
// Failures: a trajectory with any failed run is dropped whole and listed.
#pragma once

#include "estimation/ensemble.h"
#include "estimation/sensitivity/design.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace sigmaheart::estimation::sensitivity {

struct MorrisOptions {
  int trajectories = 20;  // r; 10-50 is usual
  int levels = 4;         // L, even, >= 2
  std::uint64_t seed = 1;
  int bootstrap_samples = 1000;  // 0: no intervals
  double confidence = 0.95;
  EnsembleOptions ensemble;
  double delta() const { return levels / (2.0 * (levels - 1)); }
  std::string validate() const;
};

struct MorrisSummary : StudySummary {
  // status kFailedRuns when no trajectory survived. Layout: "trajectory <t>", row = step.
  int trajectories_requested = 0;
  std::vector<int> used_trajectories;     // indices of trajectories that entered the statistics
  std::vector<int> dropped_trajectories;  // trajectories dropped for a failed run
  Eigen::MatrixXd unit_design;  // r (p + 1) x p, grid points in [0, 1]
  std::vector<Eigen::MatrixXd> effects;  // per used trajectory: p x m elementary effects
  // p x m tables (parameter x output), and their bootstrap intervals (NaN without bootstrap).
  Eigen::MatrixXd mu, mu_star, sigma;
  Eigen::MatrixXd mu_low, mu_high, mu_star_low, mu_star_high, sigma_low, sigma_high;

  // Parameters of one output by decreasing mu* (NaN last).
  std::vector<int> ranking(int output) const { return rank_by(mu_star, output); }
  std::string report() const;
};

// The unit-cube design (r (p + 1) rows, trajectory-major).
Eigen::MatrixXd morris_design(int p, const MorrisOptions& options);

// Block labels of the r (p + 1) runs.
DesignLayout morris_layout(int trajectories, int p);

// Runs the design through an Ensemble (options.ensemble). Throws std::invalid_argument on invalid
// options or prior (before any run); run failures drop trajectories.
MorrisSummary run_morris(const ForwardModel& model, const Prior& prior, const MorrisOptions& options);

}  // namespace sigmaheart::estimation::sensitivity
