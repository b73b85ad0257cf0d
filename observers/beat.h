// One beat of sampled curves: the periodic time grid, centred derivatives, extrema and
// interpolation shared by every observer, so that indices and curves extracted from a measured
// curve (about 30 frames per beat) and from a simulated beat (a fine grid) are computed by the
// same code and stay comparable (docs/estimation.md s.5).
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <optional>
#include <string>

namespace sigmaheart::observers {

// How the samples of a beat close on themselves.
//  kClosed: the last sample is the first one a period later (a simulated beat on t in [0, T],
//           RunResult's convention; the default). T = t_last - t_first. The last sample is dropped
//           after the beat-to-beat mismatch x_last - x_first has been spread linearly over the
//           beat (x(t) - (x_last - x_first) (t - t_first) / T), so that a beat that settled only
//           to the simulator's periodicity tolerance has no jump, hence no dx/dt spike, at the wrap.
//  kOpen:   the last sample is one frame before the next beat's first (cine frames, the rows of an
//           observation file); T = t_last - t_first + mean frame spacing (n dt for uniform frames).
//  kNone:   not periodic: one-sided differences at both ends, no wrap-around.
//  kAuto:   with a given period, closed when t_last - t_first lies within half the smallest
//           spacing of the period, else open. Without one, a heuristic on values: closed when every
//           used channel has |x_last - x_first| <= closure_tolerance * (max x - min x). It fails
//           when the frames straddle a symmetric extremum (then x_last = x_first in an open record)
//           or when a simulated beat is far from periodic: say what the curves are when you know.
enum class Periodicity { kAuto, kClosed, kOpen, kNone };
const char* to_string(Periodicity periodicity);
std::optional<Periodicity> parse_periodicity(const std::string& text);  // auto|closed|open|none

struct BeatOptions {
  Periodicity periodicity = Periodicity::kClosed;
  double period = 0.0;               // [s]; 0 infers it from the samples (see Periodicity)
  double closure_tolerance = 1e-3;   // [1] relative to a channel's range, for kAuto without period
  // Refine every extremum (max/min of a curve or of its derivative) by the vertex of the parabola
  // through the extreme sample and its two neighbours. On a smooth extremum this removes the
  // frame-rate error of the sample max/min (O(h^4) instead of O(h^2): 0.2 mL -> 0.001 mL on a
  // 35 mL cosine at 30 frames). Off by default: LV volume and pressure extrema end in plateaus
  // (isovolumic phases) where the parabola through a kink overshoots (ESV 0.7 mL too low on the
  // lumped sphere at 30 frames) while the sample extremum is already exact.
  bool refine_extrema = false;
  // [1] Fraction of the volume range (SV) that delimits the end-diastolic and end-systolic
  // plateaus. The volume is flat during isovolumic contraction and relaxation, so "the time of
  // maximal volume" is ill-defined there (any sample of the plateau may win, and P_lv climbs
  // through it). End-diastole is therefore the onset of the ED plateau: walking back from the
  // largest volume, the time V last rose through EDV - plateau_tolerance * SV (linear
  // interpolation); end-systole (end of ejection) likewise the time V fell through
  // ESV + plateau_tolerance * SV. 0 uses the (refined) times of the extrema themselves.
  double plateau_tolerance = 0.05;

  std::string validate() const;  // empty when valid
};

// The unique sample times of a beat (a closed beat's repeated last sample removed) and its period.
struct BeatGrid {
  Eigen::VectorXd times;  // [s], strictly increasing
  double period = 0.0;    // [s], 0 when not periodic
  bool periodic = true;
  bool closed = false;    // the input's last sample repeated the first and was dropped

  int samples() const { return static_cast<int>(times.size()); }
  // Time of sample k for any integer k, unwrapped: times(k mod n) + floor(k / n) * period.
  double time(long k) const;
  // t mapped into [times(0), times(0) + period) for a periodic beat; t itself otherwise.
  double wrap(double t) const;
  // The samples of a column (as long as the input times) on this grid: for a closed beat the
  // mismatch is spread over the beat and the last sample dropped (see kClosed).
  Eigen::VectorXd unique_samples(const Eigen::Ref<const Eigen::VectorXd>& column) const;
};

// The options that read measured frames (rows of an observation file): open, period inferred.
inline BeatOptions measured_frames() {
  BeatOptions b;
  b.periodicity = Periodicity::kOpen;
  return b;
}

// Builds the grid from sample times and the columns used (for closure detection). Fails with a
// Status when there are fewer than 3 unique samples, the times do not increase, values are not
// finite, or the period does not fit the samples.
model::Status make_beat_grid(const Eigen::Ref<const Eigen::VectorXd>& times,
                             const Eigen::Ref<const Eigen::MatrixXd>& columns,
                             const BeatOptions& options, BeatGrid& grid);

// dx/dt at every sample by the centred three-point formula on a non-uniform grid,
//   x'_i = (h-^2 (x_{i+1} - x_i) + h+^2 (x_i - x_{i-1})) / (h- h+ (h- + h+)),
// the slope at t_i of the parabola through the three samples (second order; (x_{i+1} -
// x_{i-1}) / 2h on a uniform grid). A periodic beat wraps at the ends; otherwise the ends use the
// one-sided three-point formula. x holds grid.samples() values.
Eigen::VectorXd derivative(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x);

struct Extremum {
  double time = 0.0;   // [s], inside [times(0), times(0) + period) for a periodic beat
  double value = 0.0;
  int index = 0;       // the extreme sample
};
// Largest / smallest sample, refined by the parabola vertex when options.refine_extrema (the first
// sample wins ties).
Extremum find_max(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x, bool refine);
Extremum find_min(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x, bool refine);

// Walking back in time from sample `from`, the time x crosses `level` (linear interpolation
// between the two samples around the crossing), unwrapped: it may precede times(0) in a periodic
// beat. A non-periodic record stops at its first sample; a periodic beat that never crosses gives
// times(from) - period.
double crossing_before(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x, int from,
                       double level);

// The landmarks of a volume curve v (see BeatOptions::plateau_tolerance). es_time and
// ejection_start are found walking back from the minimum, so ejection_start <= es_time; ed_time
// walking back from the maximum. All are unwrapped times; t_ES = (es_time - ed_time) modulo the
// period.
struct VolumeLandmarks {
  Extremum max, min;          // the (refined) extrema: EDV = max.value, ESV = min.value
  double ed_time = 0.0;       // [s] end-diastole: onset of the ED plateau
  double ejection_start = 0;  // [s] V falls through EDV - tol * SV (end of isovolumic contraction)
  double es_time = 0.0;       // [s] end-systole: V falls through ESV + tol * SV (end of ejection)
};
VolumeLandmarks volume_landmarks(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& v,
                                 const BeatOptions& options);

// End-diastole of a volume curve sampled at `times` and read as a beat by `options`: the onset
// of its end-diastolic plateau (VolumeLandmarks::ed_time), wrapped into [times(0), times(0) +
// period) when the beat is periodic: end-diastole as `calibrate` finds it (observations_from_curves,
// CurveSampler), for `personalize` (align: end-diastole). Fails like make_beat_grid.
model::Status end_diastole_time(const Eigen::Ref<const Eigen::VectorXd>& times,
                                const Eigen::Ref<const Eigen::VectorXd>& volume,
                                const BeatOptions& options, double& t_ed);

enum class Interpolation {
  kLinear,  // piecewise linear between samples
  kCubic,   // cubic Hermite with the centred-difference slopes of derivative(): C1, exact on
            // quadratics
};
const char* to_string(Interpolation interpolation);
std::optional<Interpolation> parse_interpolation(const std::string& text);  // linear|cubic

// x at time t (wrapped into the beat when periodic). dxdt (the output of derivative()) is needed
// for kCubic only. Returns std::nullopt when t lies outside a non-periodic record.
std::optional<double> interpolate(const BeatGrid& grid, const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::VectorXd* dxdt, double t,
                                  Interpolation interpolation);

// A channel in SI: the column converted from its unit when that unit is a known non-SI unit of the
// expected dimension (e.g. "mL" for "m^3"); an empty unit is taken as SI. A missing channel or a
// unit of another dimension is a non-ok Status naming it.
model::Status channel_in_si(const model::Trajectory& trajectory, const std::string& name,
                            const std::string& si_unit, Eigen::VectorXd& column);

}  // namespace sigmaheart::observers
