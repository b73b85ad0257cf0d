// What a user needs to judge a fit (docs/estimation.md s.11): the residual per channel in noise
// standard deviations, clinical indices of the observed and fitted curves, which parameters the
// data informed, and where in the cardiac cycle a misfit sits (model discrepancy), with a summary
// in words. Also the beat's period from the data and the alignment of curves on end-diastole.
//
// Inputs are an ObservationSet (observers/observer.h) and the model output z at the estimate, in
// the same order, SI. Curves at frames are the entries named "<channel>@fNN" (NN the frame index
// into ObservationSet::frame_times, observers/curve_sampler.h); any other entry is a channel of
// its own (a typed-in index such as EDV). Residuals are normalised by the noise standard
// deviation sqrt(R_jj) (correlations in R are not used here). Numbers are SI (m^3, Pa, s; EF a
// fraction); app/io/fit_report_io.h converts them for display.
#pragma once

#include "estimation/prior_conflict.h"
#include "model/simulator.h"
#include "observers/observer.h"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::estimation {

// "V_lv@f07" -> {"V_lv", 7}; a name without "@f<digits>" -> {name, -1}.
struct ObservationKey {
  std::string channel;
  int frame = -1;
};
ObservationKey parse_observation_name(const std::string& name);

// ---------------------------------------------------------------------------------------------
// Per channel: RMS of (y - z) / sigma over the channel's entries.
struct ChannelFit {
  std::string channel;
  std::string unit;                    // SI
  int count = 0;
  double rms_normalised = 0.0;         // [noise std]
  double rms_residual = 0.0;           // [unit]
  double max_abs_normalised = 0.0;     // [noise std]
};

// Clinical indices of one beat sampled at frames (Lang et al. 2015, J Am Soc Echocardiogr 28:1,
// s.1 "LV measurements": EDV the largest and ESV the smallest LV volume of the cycle, SV = EDV -
// ESV, EF = SV / EDV). Peak pressure is the largest LV pressure, EDP the LV pressure at
// end-diastole, taken as the frame of largest volume of the same curve. At cine frame rates these
// are the sample extrema (no interpolation). NaN when a curve is missing.
struct ClinicalIndices {
  double edv = 0.0;   // [m^3]
  double esv = 0.0;   // [m^3]
  double sv = 0.0;    // [m^3]
  double ef = 0.0;    // [1]
  double p_max = 0.0; // [Pa]
  double edp = 0.0;   // [Pa]
};
// volume, pressure: the curve at the same frames (pressure may be empty).
ClinicalIndices clinical_indices(const Eigen::Ref<const Eigen::VectorXd>& volume,
                                 const Eigen::Ref<const Eigen::VectorXd>& pressure);

struct IndexComparison {
  std::string name;      // "EDV", "ESV", "SV", "EF", "P_max", "EDP"
  std::string unit;      // SI ("m^3", "Pa", "1")
  double observed = 0.0;
  double fitted = 0.0;
  double error = 0.0;    // fitted - observed
};

// ---------------------------------------------------------------------------------------------
// Phases of the cardiac cycle at each frame, classified from the observed curves:
//   v' = dV/dt by centred differences on the periodic frame grid (observers/beat.h derivative());
//   |v'| <= isovolumic_fraction * max_k |v'_k|  -> isovolumic, else
//   v' < 0 -> ejection,  v' > 0 -> filling.
// An isovolumic frame is contraction when dP/dt > 0 there and relaxation otherwise (Wiggers
// diagram: pressure rises with the valves closed before ejection, falls after it); without a
// pressure curve, by what precedes it: contraction after filling, relaxation after ejection.
// Limits: diastasis (slow filling below the threshold) counts as isovolumic, usually contraction;
// a frame at a phase boundary goes to either neighbour, so at 30 frames per beat the isovolumic
// contraction (~50 ms, 1-2 frames) is usually absorbed by filling and ejection.
enum class CyclePhase { kFilling, kIsovolumicContraction, kEjection, kIsovolumicRelaxation };
const char* to_string(CyclePhase phase);  // "filling", "isovolumic contraction", ...
inline constexpr int kCyclePhases = 4;

struct PhaseOptions {
  double isovolumic_fraction = 0.1;  // [1] of the largest |dV/dt|, in (0, 1)
  double period = 0.0;               // [s]; 0: the frames are one open beat (beat.h kOpen)
};
// times [s] strictly increasing (one beat of frames), volume and (optional, may be empty)
// pressure at those times. Non-ok Status when the curves cannot be read as a beat.
model::Status classify_phases(const Eigen::Ref<const Eigen::VectorXd>& times,
                              const Eigen::Ref<const Eigen::VectorXd>& volume,
                              const Eigen::Ref<const Eigen::VectorXd>& pressure,
                              const PhaseOptions& options, std::vector<CyclePhase>& phases);

struct PhaseResidual {
  CyclePhase phase = CyclePhase::kFilling;
  int frames = 0;
  double rms_normalised = 0.0;  // [noise std], NaN with no frame
  double share = 0.0;           // [1] of the channel's total squared normalised residual
};
struct ChannelDiscrepancy {
  std::string channel;
  double rms_normalised = 0.0;
  std::vector<PhaseResidual> phases;  // kCyclePhases entries, in CyclePhase order
  CyclePhase dominant = CyclePhase::kFilling;  // largest share
};

// ---------------------------------------------------------------------------------------------
// Identifiability from a posterior covariance (any coordinates, e.g. eta) and the prior std in
// the same coordinates.
struct Identifiability {
  std::vector<std::string> names;
  Eigen::MatrixXd correlation;          // posterior correlation
  Eigen::VectorXd std_ratio;            // posterior std / prior std
  std::vector<std::string> uninformed;  // std_ratio > uninformed_ratio
  struct Pair {
    std::string a, b;
    double rho = 0.0;
  };
  std::vector<Pair> correlated;         // |rho| > correlation_threshold, i < j
};
Identifiability identifiability(const std::vector<std::string>& names,
                                const Eigen::Ref<const Eigen::MatrixXd>& posterior_covariance,
                                const Eigen::Ref<const Eigen::VectorXd>& prior_std,
                                double uninformed_ratio = 0.9, double correlation_threshold = 0.9);

// ---------------------------------------------------------------------------------------------
struct FitReportOptions {
  std::string volume_channel = "V_lv";
  std::string pressure_channel = "P_lv";
  // The data did not inform a parameter whose posterior std is above this fraction of its prior
  // std (the data reduced its variance by less than 1 - 0.9^2 = 19 %).
  double uninformed_ratio = 0.9;
  double correlation_threshold = 0.9;  // |rho| above it: a strongly correlated pair
  // A channel whose RMS is above this many noise std gets the phase report: at the noise level the
  // expected RMS is 1; twice that is beyond the chi-square spread of any channel of more than a
  // few frames (for 30 frames the 99.9 % quantile of the RMS is 1.5).
  double discrepancy_rms = 2.0;
  // A phase holding at least this share of the squared residual is where the misfit "concentrates".
  double concentration_share = 0.5;
  PhaseOptions phases;
  std::string validate() const;  // empty when valid
};

// The posterior for the identifiability section (from a UT or least-squares summary).
struct PosteriorSpread {
  std::vector<std::string> names;
  Eigen::MatrixXd covariance;  // p x p
  Eigen::VectorXd prior_std;   // p, same coordinates
};

// A channel observed at frames, as the report's writers and plots need it.
struct CurveResidual {
  std::string channel;
  std::string unit;                         // SI
  Eigen::VectorXd times;                    // [s] frame times
  Eigen::VectorXd observed, fitted, noise_std;  // [unit]
};

struct FitReport {
  // Parameters that left their prior (> 3 prior std) or physiological range (note_prior_conflict):
  // "prior conflict: model discrepancy absorbed by PARAM (...)"; empty when none.
  std::string prior_conflict;
  std::vector<ChannelFit> channels;         // in order of first appearance
  std::vector<CurveResidual> curves;        // the channels observed at frames, same order
  std::vector<IndexComparison> indices;     // when the volume curve is observed at frames
  std::optional<Identifiability> identifiability;
  Eigen::VectorXd frame_times;              // [s] of the classified frames
  std::vector<CyclePhase> frame_phases;     // one per frame (empty: not classified)
  std::vector<ChannelDiscrepancy> discrepancies;  // channels above discrepancy_rms with frames
  std::vector<std::string> notes;           // what could not be computed and why
  std::string summary;                      // in words, for the log
};

// Throws std::invalid_argument when sizes disagree, the set is inconsistent or options are
// invalid. A z with NaN (failed run) gives NaN RMS values and a summary saying so.
FitReport make_fit_report(const observers::ObservationSet& observations,
                          const Eigen::Ref<const Eigen::VectorXd>& z,
                          const std::optional<PosteriorSpread>& posterior = std::nullopt,
                          const FitReportOptions& options = {});

// ---------------------------------------------------------------------------------------------
// The period of sampled curves. With more than one beat in the record: the lag of the first peak
// of the autocorrelation of the (linearly resampled, uniform) curve after it first drops below
// zero, refined by the parabola through the peak and its neighbours; accepted when the Pearson
// correlation of the overlapping parts at that lag is >= min_correlation and the lag is at most
// max_lag_fraction of the record (so at least 1 - 0.6 = 40 % of the record overlaps). Otherwise
// the record is one open beat: period = t_last - t_first + mean frame spacing (beat.h kOpen).
struct PeriodOptions {
  double min_correlation = 0.8;
  double max_lag_fraction = 0.6;
};
struct PeriodEstimate {
  enum class Method { kAutocorrelation, kTimeSpan };
  model::Status status;
  double period = 0.0;        // [s]
  double beats = 1.0;         // record span / period
  Method method = Method::kTimeSpan;
  double correlation = 0.0;   // at the period (kAutocorrelation)
  std::string describe() const;  // "0.8 s from the autocorrelation (3.0 beats, r = 0.999)"
};
PeriodEstimate estimate_period(const Eigen::Ref<const Eigen::VectorXd>& times,
                               const Eigen::Ref<const Eigen::VectorXd>& values,
                               const PeriodOptions& options = {});

// Alignment of measured curves on end-diastole: t = 0 at the sample of largest volume
// (kMaxVolume, the end-diastolic frame by Lang et al. 2015's definition) or at the ECG R-wave,
// i.e. the times as recorded (kTrigger); then `shift` [s] is subtracted (t = 0 at landmark +
// shift). With one beat in the record the samples are wrapped into [0, period) and rotated so
// time increases; with more than one (span >= period + one frame) the first complete beat after
// the landmark is kept and the rest dropped.
struct AlignmentOptions {
  enum class Landmark { kMaxVolume, kTrigger };
  Landmark landmark = Landmark::kMaxVolume;
  std::string channel = "V_lv";  // for kMaxVolume
  double shift = 0.0;            // [s]
  double period = 0.0;          // [s]; 0: estimate_period() on `channel` (or the first channel)
};
struct AlignedBeat {
  model::Status status;
  model::Trajectory trajectory;  // one beat, times in [0, period)
  double landmark_time = 0.0;    // [s] in the input's times, shift included
  double period = 0.0;           // [s]
};
AlignedBeat align_on_end_diastole(const model::Trajectory& measured,
                                  const AlignmentOptions& options = {});

// Adds the prior conflict (prior_conflict.h) to the report: FitReport::prior_conflict and the end
// of the summary in words; nothing when no parameter conflicts.
void note_prior_conflict(FitReport& report, const PriorConflict& conflict);

}  // namespace sigmaheart::estimation
