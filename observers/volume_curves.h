// Cavity and AHA regional volume curves from images (sigmaheart observe, docs/models.md s.5.1):
// the checks a tracking or segmentation failure shows, end-diastole, regional ejection fractions,
// and the trajectory the observation CSV is written from. No file I/O.
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace sigmaheart::observers {

inline constexpr int kAhaSegments = 17;

struct VolumeCurves {
  Eigen::VectorXd times;     // [s] per frame, strictly increasing
  Eigen::VectorXd cavity;    // [m^3] V_lv per frame
  Eigen::MatrixXd regional;  // [m^3] frames x 17, segment s in column s-1
};

struct VolumeCheckOptions {
  // A segment whose volume changes between consecutive frames by more than this fraction of its
  // largest volume (or of the mean segment volume at ED, EDV/17, when larger) is a tracking
  // failure: a normal beat at 25-30 frames changes a segment by at most ~15 % per frame (EF <= 75 %
  // over >= 5 ejection frames). `observe` uses 0.5 for label images, whose 8-10 mm slices move a
  // segment's volume in steps.
  double jump_fraction = 0.25;
  // |sum of the regional volumes - V_lv| / V_lv above this is reported as a finding (the two agree
  // exactly when the base ring is flat and normal to the axis: docs/models.md s.5).
  double sum_tolerance = 0.01;
  int end_diastole = -1;     // frame index; -1: the frame of largest V_lv
  std::string validate() const;
};

struct VolumeFinding {
  int frame = 0;      // 0-based
  int segment = 0;    // 1..17, 0 for the cavity
  std::string what;   // "negative volume -1.2 mL", ...
};

struct VolumeChecks {
  int end_diastole = 0, end_systole = 0;          // frame indices (ES: smallest V_lv)
  double edv = 0, esv = 0, ef = 0;                // [m^3], [m^3], [1]
  std::array<double, kAhaSegments> regional_ef{};  // (V_s(ED) - V_s(ES)) / V_s(ED); NaN when V_s(ED) = 0
  double max_sum_error = 0;                       // max over frames of |sum_s V_s - V_lv| / V_lv
  int max_sum_error_frame = 0;
  std::vector<VolumeFinding> findings;            // tracking failures; empty when all is well
  bool ok() const { return findings.empty(); }
  // One line per finding ("frame 12: segment 7 (mid anterior): ..."), frames counted from 0.
  std::string report() const;
};

// Checks the curves: a volume that is negative or not finite, a segment jumping by more than
// jump_fraction, a sum error above sum_tolerance; end-diastole/systole and ejection fractions.
// Throws std::invalid_argument for curves of inconsistent sizes or an end_diastole out of range.
VolumeChecks check_volume_curves(const VolumeCurves& curves, const VolumeCheckOptions& options);

// The curves as a trajectory with channels V_lv and V_seg01..V_seg17 (SI, m^3), the names
// `calibrate` and `personalize` read.
model::Trajectory volume_trajectory(const VolumeCurves& curves);

}  // namespace sigmaheart::observers
