// Therapy prediction (docs/estimation.md s.12): the acute response of pacing therapies on a
// personalised model, with the uncertainty of its posterior propagated (propagation.h).
//
// Therapies: the baseline (intrinsic activation), then for every pacing mode (biventricular: an RV
// lead and an LV lead; LV-only) and every LV lead site a pacing plan (model/activation/pacing.h)
// with the device timing: the atrial event at -pr_interval on the intrinsic clock (t = 0 at the
// intrinsic QRS onset), the first ventricular stimulus av_delay after it, the LV lead vv_delay
// before the RV lead (vv_delay > 0: LV first; the RV lead fires at the AV delay). The intrinsic
// sequence stays on (fusion by the earliest arrival) unless `intrinsic_conduction` is false.
// After the map over the sites, an AV sweep and a VV sweep at the best site.
//
// Every therapy is run at every point of the posterior's propagation (sigma points, samples, or
// the mean); a point's responses are the beat's indices under the therapy and their change from the
// baseline at the same point (paired), so the uncertainty of the change is not that of two
// independent beats. AHR (acute haemodynamic response) = 100 (dP/dt max / dP/dt max at baseline -
// 1) [%], the clinical measure of CRT's acute effect; acute responders are usually those with an
// AHR above 10 % (the default threshold, configurable).
//
// A therapy whose runs fail (a point that diverges, a site that leaves a segment unactivated) is
// reported with its failure and no moments; the others are unaffected. A failed baseline fails
// every change.
#pragma once

#include "estimation/ensemble.h"
#include "estimation/propagation.h"
#include "model/activation/pacing.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation::therapy {

enum class Mode { kBiventricular, kLvOnly };
const char* to_string(Mode mode);  // "biv", "lv-only"
std::optional<Mode> parse_mode(const std::string& text);

// Device timing [s]. Ranges (validate): what CRT devices program (AV 40-350 ms, VV -80..80 ms) and
// a PR interval of 80-400 ms.
struct Timing {
  double pr_interval = 0.16;  // atrial event to the intrinsic QRS onset
  double av_delay = 0.12;     // atrial event to the first ventricular stimulus
  double vv_delay = 0.0;      // RV stimulus time minus LV stimulus time (> 0: the LV lead first)
  std::string validate() const;  // empty when valid, else a message naming the field
};

struct Therapy {
  std::string label;     // "baseline", "biv LV 5 (epicardium)", "biv LV 5, AV 100 ms"
  bool baseline = false;
  Mode mode = Mode::kBiventricular;
  int lv_site = -1;      // index into TherapyOptions::lv_sites
  Timing timing;
};

struct TherapyOptions {
  // The RV lead: segment 9 (mid inferoseptal) on the epicardium, the RV side of the mid septum.
  model::activation::LeadSite rv_site{9, model::activation::Surface::kEpicardium, std::nullopt};
  std::vector<model::activation::LeadSite> lv_sites;   // default (empty): the 17 segments, epicardium
  std::vector<Mode> modes = {Mode::kBiventricular};
  Timing timing;
  std::vector<double> av_sweep;  // [s] AV delays tried at the best site (biventricular)
  std::vector<double> vv_sweep;  // [s] VV delays tried there
  bool intrinsic_conduction = true;
  std::vector<int> scar;         // AHA segments that neither conduct nor capture
  model::activation::GraphPacingOptions graph;  // models paced through their segment times
  // `conduction_velocity: intrinsic`: the paced wave's velocity on the segment graph from the
  // intrinsic sequence at the posterior mean (activation::sequence_velocity, scar left out) instead
  // of graph.conduction_velocity; TherapySummary says which it used.
  bool velocity_from_sequence = false;
  PropagationOptions propagation;
  // The model's own AHR error against a reference (docs/estimation.md s.12.2): a validation
  // cohort's, which no posterior over the model's parameters shows. ahr_sd [%, AHR points] is added
  // to every therapy's AHR (std, interval, P(responder); add_response_error); `shared` is the
  // fraction of its variance common to every lead site (a heart's bias, which moves all sites
  // together and reorders none), the rest independent per site, which P(best) draws as well.
  struct ModelError {
    double ahr_sd = 0.0;
    double shared = 0.0;
  } model_error;
  double responder_threshold = 10.0;  // [%] AHR
  EnsembleOptions ensemble;
  // Warm starts across the points (docs/estimation.md s.12.3): per therapy one run at the posterior
  // mean hands on its periodic state and beat-map Jacobian (model::Simulator::run_warm), and the
  // points start from it. Only with a posterior of more than one point and a model that offers
  // warm starts (lumped-sphere, lumped-regional). kAuto: where they are expected to save beats
  // (warm_starts_pay); kNever: every run from the relaxed state.
  enum class WarmStarts { kAuto, kAlways, kNever };
  WarmStarts warm_starts = WarmStarts::kAuto;
  std::function<void(const std::string& phase, int members)> on_phase;  // before each phase
  std::string validate() const;
  // The LV sites, the default filled in.
  std::vector<model::activation::LeadSite> sites() const;
};

// Whether warm starts are expected to save beats for a therapy's `followers` points started from a
// seed whose Jacobian costs `unknowns` beats (plus a cold solve when the seed is an extra run, not a
// point): each warm point saves about kColdBeats - kWarmBeats against a cold run (measured: 15.0
// against 4.5 on the regional lead-site map, 22 against 4.8 on the sphere's calibration).
inline constexpr int kColdBeats = 15;
inline constexpr int kWarmBeats = 5;
bool warm_starts_pay(int followers, int unknowns, bool extra_seed);

// The pacing plan of a therapy.
model::activation::PacingPlan pacing_plan(const Therapy& therapy, const TherapyOptions& options);

// Names and SI units of a therapy's responses: the beat's (raw) and their change from the baseline.
struct ResponseNames {
  std::vector<std::string> raw, raw_units, change, change_units;
};

struct TherapyOutcome {
  Therapy therapy;
  std::vector<bool> captured;  // per stimulus
  // The activation under the therapy at the base parameters (segment means [s], intrinsic clock).
  std::array<double, model::activation::kSegments> segment_times{};
  std::string note;            // e.g. "LV lead in scar segment 7: no capture"
  Eigen::MatrixXd raw;         // points x raw responses (NaN rows: failed points)
  std::vector<model::Status> status;  // per point
  ResponseMoments raw_moments;
  Eigen::MatrixXd change;      // points x change responses (the baseline: zeros)
  ResponseMoments change_moments;  // with the model error on AHR, when one is given
  double ahr_std_posterior = 0.0;  // AHR's standard deviation from the posterior alone [%]
  double p_responder = 0.0;    // P(AHR > responder threshold)
  std::string failure;         // empty when the therapy has moments
  bool ok() const { return failure.empty(); }
};

enum class Termination { kOk, kSomeFailed, kBaselineFailed };
const char* to_string(Termination termination);  // "ok", "some-therapies-failed", "baseline-failed"

struct TherapySummary {
  ResponseNames names;
  PropagationPoints points;   // theta: the estimated parameters only (no columns without posterior)
  TherapyOutcome baseline;
  std::vector<TherapyOutcome> map;    // modes x sites, mode-major
  int sites = 0;
  int best = -1;                      // index into map (first mode): the largest mean AHR; -1: none
  Eigen::VectorXd p_best;             // per site of the first mode: P(it has the largest AHR)
  std::vector<TherapyOutcome> sweep;  // AV then VV at the best site
  int simulations = 0;                // runs, the warm starts' seeds and cold retries included
  int failures = 0;                   // failed runs
  // The paced wave's velocity on the segment graph [m/s] (0 for models paced by their own
  // capability, lv-3d) and where it came from ("configured", or the intrinsic sequence's fit).
  double conduction_velocity = 0.0;
  std::string conduction_source;
  long long beats = 0;                // beats integrated by the runs that finished
  int seed_runs = 0;                  // runs at the posterior mean that are not points (warm starts)
  int cold_retries = 0;               // warm runs that failed and were run again cold
  Termination termination = Termination::kOk;
  std::string message;
  bool ok() const { return termination == Termination::kOk; }
  // The AHR column of the change responses.
  static constexpr int kAhr = 0;
};

// model: a simulator that can be paced (activation::PacedSimulator::route not empty); base_theta
// its full parameter vector; with a posterior, `estimated` holds per posterior parameter (in its
// order) the model indices it sets (one, or the members of a zone) and every point replaces them in
// base_theta; without one the therapies run once at base_theta (method point). Throws std::invalid_argument for invalid options or a
// plan the model refuses (a site outside the mesh, a point on the segment graph).
TherapySummary run_therapy_study(const model::Simulator& model, const Eigen::VectorXd& base_theta,
                                 const std::vector<std::vector<int>>& estimated,
                                 const std::optional<Posterior>& posterior,
                                 const TherapyOptions& options);

// The beat of one therapy at a full parameter vector (the PV loops of the report).
model::RunResult therapy_beat(const model::Simulator& model, const Eigen::VectorXd& theta, const Therapy& therapy,
                              const TherapyOptions& options);

}  // namespace sigmaheart::estimation::therapy
