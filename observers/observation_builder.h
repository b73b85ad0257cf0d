// Building ObservationSets from measured data (docs/estimation.md s.5): global indices computed from
// measured curves with the same GlobalIndices code the simulated beats go through, curves at the
// measured frames aligned on end-diastole, typed-in values with units; noise per entry as a
// standard deviation in any known unit, relative (% of the value), or a full covariance.
// Everything returned is SI; the units the user wrote are kept in display_units for reports.
// Bad input throws std::invalid_argument with a message naming the observation (tier 2: the
// caller adds the file and line it came from).
#pragma once

#include "observers/curve_sampler.h"
#include "observers/global_indices.h"
#include "observers/observer.h"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::observers {

// Unit strings model::units::to_si() knows, for "known units: ..." messages.
const std::vector<std::string>& known_units();
// "unknown unit 'x' (did you mean 'y'?); known units: ..." ready to be prefixed with a location.
std::string unknown_unit_message(const std::string& unit);

// Noise of one observation: an absolute standard deviation in a unit, or relative to the value.
struct Noise {
  enum class Kind { kAbsolute, kRelative };
  Kind kind = Kind::kAbsolute;
  double value = 0.0;  // absolute: the std in `unit`; relative: percent of |observed value|
  std::string unit;    // absolute only: any known unit of the observation's dimension

  static Noise absolute(double std_dev, std::string unit) {
    return {Kind::kAbsolute, std_dev, std::move(unit)};
  }
  static Noise relative(double percent) { return {Kind::kRelative, percent, {}}; }
  std::string describe() const;  // "5 mL", "10 %"
};

// Parses "5 mL", "0.5 mmHg", "20 ms", "0.03" (dimensionless) and "10 %" (relative: 10 % of the
// value). "%" always means relative here; an absolute noise on EF is written as a fraction
// ("0.03"). Throws std::invalid_argument for a missing or non-positive number or an unknown unit.
Noise parse_noise(const std::string& text);

// Standard deviation [SI] of an observation `name` with SI value and unit. Throws
// std::invalid_argument when the noise unit measures another dimension or the std would be 0.
double noise_std_si(const Noise& noise, const std::string& name, double value_si,
                    const std::string& si_unit);

// Noise per observation: by exact name first, then (for frame samples "V_lv@f07") by channel name
// ("V_lv"), then the fallback.
struct NoiseModel {
  std::map<std::string, Noise> by_name;
  std::optional<Noise> fallback;

  // Throws std::invalid_argument naming the observation when no rule applies.
  const Noise& for_name(const std::string& name) const;
};

// One typed-in observation (the calibrate config's inline indices, parsed from YAML by app/).
struct ObservationEntry {
  std::string name;   // e.g. "EDV"
  double value = 0.0; // in unit
  std::string unit;   // e.g. "mL"; "%" for EF in percent; "" or "1" for fractions
  Noise noise;
};

// y, diagonal R and units from typed-in entries. Each name must appear in `expected` (default:
// GlobalIndices::catalog(), with a did-you-mean) and its unit must measure the same dimension as
// the expected SI unit; values finite; names unique; noise positive.
ObservationSet observations_from_entries(const std::vector<ObservationEntry>& entries,
                                         const std::vector<model::Channel>& expected = {});

// (a) The global indices of measured curves (trajectory in SI, e.g. read by
// app/io/observation_file.h), computed by GlobalIndices with `options` (the same options the
// simulated beats are observed with) except that the measured curve is read as a beat by
// `measured_beat` (default: open frames, period inferred). display_units parallel to
// measured.channels (may be empty) pick each index's display unit (EDV in the volume's unit, dV/dt
// in that unit per second when known, EF in %, times in ms). frame_times = the measured times.
// Throws std::invalid_argument when the curves cannot be read as a beat.
ObservationSet observations_from_indices(const model::Trajectory& measured,
                                         const GlobalIndicesOptions& options,
                                         const NoiseModel& noise,
                                         const std::vector<std::string>& display_units = {},
                                         const BeatOptions& measured_beat = measured_frames());

// (b) Curves at the measured frames. The measured beat is made periodic by options.beat (frames
// are "open": the last frame is one frame before the next beat), end-diastole t_ED is found on
// alignment_channel exactly as GlobalIndices and CurveSampler find it (beat.h), and the frames are
// rotated so that frame 0 is the sample nearest to t_ED; frame j keeps its measured value and gets
// the time frame_times(j) = t(k0 + j) - t_ED (unwrapped, |frame_times(0)| <= half a frame).
struct MeasuredCurveOptions {
  std::vector<std::string> channels = {"V_lv"};
  // empty: no alignment; frame_times are the measured times themselves (times after the ECG
  // trigger, matched with the simulated beat's onset at t = 0)
  std::string alignment_channel = "V_lv";
  Interpolation interpolation = Interpolation::kLinear;  // for the returned sampler
  BeatOptions beat = measured_frames();                  // how to read the measured frames
};
struct CurveObservations {
  ObservationSet observations;  // names "<channel>@fNN", frame_times relative to ED
  // Options of the CurveSampler that extracts the same entries from a simulated beat (which
  // should have the measured period); its beat options are the defaults (a closed simulated
  // beat) with refine_extrema and plateau_tolerance kept.
  CurveSamplerOptions sampler;
  // [s] the measured frames' origin on the file's clock: frame j was measured at frame_origin +
  // frame_times(j) (the measured end-diastole with alignment, 0 without).
  double frame_origin = 0.0;
};
CurveObservations observations_from_curves(const model::Trajectory& measured,
                                           const MeasuredCurveOptions& options,
                                           const NoiseModel& noise,
                                           const std::vector<std::string>& display_units = {});

// Replaces R by a full covariance given in the units units[i] (R(i, j) in units[i] * units[j]);
// converts to SI and checks size, symmetry and positive definiteness (std::invalid_argument).
void set_covariance(ObservationSet& set, const Eigen::Ref<const Eigen::MatrixXd>& R,
                    const std::vector<std::string>& units);

// Empty when the observer's outputs and the set have the same names and SI units in the same
// order (what an estimator comparing z with y assumes); else a message naming the first
// difference. Reorder a set with ObservationSet::select(names of the outputs) first if needed.
std::string check_consistent(const Observer& observer, const ObservationSet& set);

// Sets one after another; R block-diagonal; frame_times of the first set that has them. Throws
// std::invalid_argument on a repeated name.
ObservationSet concatenate(const std::vector<ObservationSet>& sets);

}  // namespace sigmaheart::observers
