// The `personalize:` section of a config, parsed and validated in one place: regional volume
// curves and their noise, the estimated parameters (per-segment families found by their tags,
// model::Parameter::family/segment, and global parameters) with their Prior, the ROUKF options and
// an optional truth (twin experiments).
//
//   personalize:
//     observations:
//       file: data/regional-lad-infarct.csv   # time [ms], V_seg01 [mL], ..., V_seg17 [mL]
//       channels: all            # or [V_seg01, V_seg07]: columns of the file to assimilate
//       noise: 0.05 mL           # or {default: 0.05 mL, V_seg17: 0.1 mL}; "%" = of the column mean
//       start_beats: 8           # file time 0 = this many beats after the model's initial state
//       align: ecg               # ecg: file times are after the ECG trigger (the model's t = 0);
//                                # end-diastole: the data's ED frame meets the model's ED
//       period: model            # model: the model's period | data: the frames' beat (span +
//                                # mean spacing) sets the model's period
//       shares: model            # model | data: the regional volumes re-weighted by the volume
//                                # shares of the data over its beat (docs/models.md s.3.3);
//                                # with 17 segments also the share law's exponents vshare_basal,
//                                # vshare_mid, vshare_apical (0 unless estimated)
//     start:                     # optional: a calibrate result (app/personalize_start.h)
//       file: results/calibrate.h5
//       globals: estimate        # estimate (co-estimated, its posterior as prior) | hold
//     activation:                # optional: a measured activation map, Td_XX per segment
//       file: data/activation-map.csv   # segment, time [ms]
//     estimate:                  # per-segment families and global parameters
//       sigma0: {segments: all, prior: 5.3e4, spread: 50 %, transform: log}
//       # or zones: one estimated parameter <key>_<zone> per zone sets all its segments
//       # (model/zoned_simulator.h), e.g. {zones: {lad: [1, 2, 7, 8, 13, 14, 17], rest: [3, 4]}}
//       R_p: {spread: 20 %}      # a global parameter (no segments:)
//     filter:
//       beats: 16                # passes over the measured beat (split: at most)
//       passes: split            # split (R / phi per pass, sum phi = 1) | repeat (data re-used)
//       first_fraction: 1.0e-3   # split: phi of the first pass
//       pass_growth: 1           # split: information a pass may add, relative to the spread
//       tempering: 0             # > 0: sub-updates per frame (RoukfOptions::tempering)
//       sigma_scale: 1           # scaled sigma points, (0, 1]
//       forgetting: 1            # fading memory per frame, (0, 1]
//       r_inflation: 1           # the filter's R = (r_inflation x noise)^2
//       sigma_points: simplex    # simplex | canonical | star
//       spin_up: per-member      # per-member | common (initial state of the first prediction)
//       failure_policy: retry-then-skip   # retry-then-skip | skip | abort
//       max_retries: 2
//       shrink: 0.5
//       inflation: 0.1
//       threads: 2               # --threads overrides
//       noise_scale: estimate    # optional: an unknown noise scale per channel, InvGamma(3, 4) on
//                                # s^2 (or {shape: 3, scale: 4}); docs/estimation.md s.4.8
//     truth:                     # optional (twin experiments): per family a list or one value
//       sigma0: [21.2 kPa, 21.2 kPa, 53 kPa, ...]
//
// A family key names a family tag ("contractility") or the common stem of its parameters'
// names ("sigma0" for sigma0_01..17); the heart period is the parameter tagged "period".
#pragma once

#include "app/config.h"
#include "app/io/observation_file.h"
#include "app/personalize_start.h"
#include "estimation/prior.h"
#include "estimation/roukf/roukf.h"
#include "model/zoned_simulator.h"

#include <Eigen/Core>

#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app {

struct PersonalizeProblem {
  estimation::RoukfData data;             // SI, times on the model's clock
  estimation::Prior prior;                // the estimated parameters, in config order
  estimation::RoukfOptions filter;        // truth set when the config gives one
  std::filesystem::path observation_file;
  Eigen::VectorXd file_times;             // [s] as in the file (beat-local)
  std::vector<std::string> display_units; // per channel ("mL")
  Eigen::VectorXd display_factor;         // display = SI * factor
  Eigen::VectorXd noise_si;               // per channel, the measurement noise std
  double r_inflation = 1.0;
  int start_beats = 0;
  double period = 0.0;
  std::string spin_up = "per-member";
  std::vector<int> segments;              // per estimated parameter: 1-based segment, 0 = global
  std::vector<std::string> families;      // per estimated parameter: the config key
  std::vector<model::ParameterZone> zones; // tied segments (empty: none); wrap the simulator
  model::ParameterSpace space;            // the simulator's, zoned when zones are given
  io::ObservationCurves file_curves;      // the whole observation file (SI)
  bool align_end_diastole = false;        // observations: align: end-diastole
  bool shares_from_data = false;          // observations: shares: data
  bool share_exponents = false;           // ... with 17 segments: vshare_basal/mid/apical parameters
  bool period_from_data = false;          // observations: period: data
  std::optional<CalibratedStart> start;   // personalize: start:
  std::filesystem::path activation_file;  // personalize: activation: file:
  // What the set-up did to the data and the model (alignment, shares, period, start), in words, for
  // the report and the results files; filled by parse_personalize and prepare_personalize_model.
  std::vector<std::string> notes;
  double data_ed_time = std::nan("");     // [s] file time of the data's end-diastole (align)
  double model_ed_time = std::nan("");    // [s] the model's end-diastole in its beat (align)
  Eigen::VectorXd volume_shares;          // shares: data, per regional channel of the model
  Eigen::VectorXd reference_shares;       // ... the model's reference shares s_p (the wrapper's)
  double reference_volume = std::nan(""); // ... [m^3] the data's end-diastolic volume, V_ref
};

// Every problem is an InputError at the offending key (file:line:column).
PersonalizeProblem parse_personalize(const Config& config);

// The simulator `personalize` runs and the model times of the frames (docs/estimation.md s.4.9):
// `simulator` in a ZonedSimulator for the zones, in a RegionalVolumeShares for `shares: data`, and
// problem.data.times moved so that the data's end-diastole meets the model's (`align:
// end-diastole`). Both need one run of the model at the prior mean (its periodic beat). Adds to
// problem.notes. InputError at the offending key when the data or the model cannot serve (no
// regional volume channels, unobserved segments without V_lv in the file, a run that fails).
std::unique_ptr<model::SteppableSimulator> prepare_personalize_model(
    const Config& config, PersonalizeProblem& problem, std::unique_ptr<model::SteppableSimulator> simulator);

}  // namespace sigmaheart::app
