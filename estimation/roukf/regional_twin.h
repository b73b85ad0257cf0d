// Twin experiment for regional personalisation (experiments/regional-personalization/README.md):
// synthetic regional-volume data from a 17-patch LBBB ventricle with an LAD-like infarct, and the
// ROUKF set-up that estimates one contractility per AHA segment from them (as Marchesseau et al.
// 2013, Med Image Anal 17:816, do with real cine MRI; 18 members per step). Any patch count works
// (model.area_shares, explicit activation): the fast test uses 5 patches.
//
// Shared by the test (shortened), the benchmark and the experiment so the three cannot drift.
#pragma once

#include "estimation/roukf/roukf.h"
#include "model/lumped/regional.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

struct RegionalTwinOptions {
  model::lumped::RegionalOptions model;         // default: LBBB, 17 AHA patches
  std::vector<int> infarct_segments = {1, 2, 7, 8, 13, 14, 17};  // LAD territory (1-based)
  double infarct_fraction = 0.4;   // truth sigma0 = fraction x nominal in the infarct
  int frames_per_beat = 30;        // cine-MRI-like sampling
  double noise_std = 0.05e-6;      // [m^3] per regional volume (0.05 mL)
  std::uint64_t seed = 2013;       // noise stream
  int warmup_beats = 8;            // beats before the first frame (spin-up of truth and members)
  int beats = 16;                  // data passes of the filter (the same measured beat), at most
  double prior_std_eta = 0.5;      // log-contractility prior spread (theta = sigma0_nom exp(eta))
  // The filter's R = (r_factor noise_std)^2 I and its fading memory (RoukfOptions::forgetting):
  // the true noise and no forgetting. The frames are split over at most `beats` passes
  // (RoukfPassMode::kSplit, first fraction 1e-3): one pass with the whole information locks in
  // errors of up to 55 % (mean NIS 334, band 15-19; docs/estimation.md s.4.2).
  double r_factor = 1.0;
  double forgetting = 1.0;
  double tempering = 0.0;     // RoukfOptions::tempering
  double sigma_scale = 1.0;   // RoukfOptions::sigma_scale
  RoukfPassMode pass_mode = RoukfPassMode::kSplit;  // RoukfOptions::pass_mode
  double first_fraction = 1e-3;                     // RoukfOptions::first_fraction
  std::string validate() const;
};

struct RegionalTwin {
  Eigen::VectorXd truth_theta;       // full parameter vector of the truth
  Eigen::VectorXd truth_sigma0;      // true contractility of every patch [Pa]
  double nominal_sigma0 = 0.0;       // prior (uniform) contractility [Pa]
  model::State truth_periodic;       // the truth's state after the warm-up beats
  RoukfData data;                    // the regional volumes at frames of the beat after the warm-up

  Prior prior;                       // the contractilities (log, centred on the nominal)
  RoukfOptions filter;               // R, beats, spin-up, refinement; truth = truth_sigma0
};

// Builds the truth, the noisy data, the prior and the filter options. The segments are found by
// their tags (parameters of family "contractility", channels of family "regional_volume").
// Throws std::runtime_error if the truth run fails.
RegionalTwin make_regional_twin(const model::lumped::RegionalVentricle& model,
                                const RegionalTwinOptions& options);

// Relative error |theta - truth| / truth of every segment after each beat of the filter (rows:
// beats, columns: segments), from the summary's last step of each beat.
Eigen::MatrixXd per_beat_relative_errors(const RoukfSummary& summary,
                                         const Eigen::VectorXd& truth_sigma0);

}  // namespace sigmaheart::estimation
