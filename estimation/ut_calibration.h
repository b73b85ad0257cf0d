// Unscented-Transform calibration of a few global parameters (docs/estimation.md s.3; Marchesseau et
// al. 2013, Biomech Model Mechanobiol 12:815; the UT of Julier & Uhlmann, Proc IEEE 92:401, 2004).
//
// One iteration, all in eta (the unconstrained coordinates of each parameter's Transform):
//   eta_i = eta_c + S U_i (S S^T = P, U the unit sigma points),  theta_i = T(eta_i),
//   z_i = h(theta_i) on the Ensemble,  z_bar = sum wm_i z_i,
//   P_zz = sum wc_i (z_i - z_bar)(z_i - z_bar)^T,  P_tz = sum wc_i (eta_i - eta_c)(z_i - z_bar)^T,
//   K = P_tz (P_zz + R)^-1,  eta+ = eta_c + K (y - z_ref),  P+ = P - K (P_zz + R) K^T.
// The algebra runs in whitened observations (R = L L^T, z -> L^-1 z, R -> I) so mL, kPa and ms
// are commensurate; K, P_zz, P_tz are reported back in SI.
//
// Modes (which one ran is recorded in the Summary):
//  - kMap (default of the iterated modes): Gauss-Newton on statistically linearised models towards
//    the maximum a posteriori point of
//      Phi(eta) = 0.5 |L^-1 (y - h(T(eta)))|^2 + 0.5 (eta - eta0)^T P0^-1 (eta - eta0),
//    the iterated posterior linearisation (IPLF) of Garcia-Fernandez, Svensson, Morelande & Sarkka
//    2015 ("Posterior linearization filter: principles and implementation using sigma points",
//    IEEE Trans Signal Process 63(20):5561), without the linearisation-error covariance Omega so
//    that the fixed point is the MAP (the Gauss-Newton form, Bell & Cathey 1993): at iterate eta_c the sigma points of the CURRENT posterior
//    approximation P_c give A = P_tz^T P_c^-1 (z ~ A eta + b, b from the centre run h(eta_c)); the
//    update starts from the PRIOR: eta+ = eta0 + K (y - b - A eta0), K = P0 A^T (A P0 A^T + R)^-1,
//    P+ = P0 - K (A P0 A^T + R) K^T. Damped by Levenberg-Marquardt (Nielsen 1999, IMM-REP-1999-05):
//    the step d solves (A^T A + P0^-1 + lambda P0^-1) d = -grad Phi_lin; a candidate whose Phi is
//    not below Phi(eta_c) (or whose centre run fails) is rejected and lambda raised; no acceptable
//    step after max_rejections tries re-linearises the centre on a quarter of the spread (up to 3
//    times in a row), then ends the run (kDiverged). Converged: the damped step is below tolerance
//    and the undamped one promises a decrease of Phi below 0.5 (1 in chi^2). P+ at the last linearisation is the
//    Gauss-Newton Laplace covariance (P0^-1 + J^T R^-1 J)^-1 as sample_scale -> 0.
//    Options (docs/estimation.md s.3.3.2): secant_iterations linearises some iterations by
//    Broyden's update of A from the accepted step's own run (every stop is decided on sigma
//    points); geodesic_acceleration adds the second-order correction along the step.
//    Neither changes the fixed point.
//  - kOneShot: one update from the prior, z_ref = z_bar (the paper's method).
//  - kIterateKeepSpread: re-centre at eta+ and sample again with the PRIOR covariance P0; z_ref =
//    h(eta_c). No prior term: its fixed point fits the data (a maximum-likelihood point) and its P+
//    is not a posterior. Kept for comparison.
//  - kIterateInflate: re-centre at eta+ and sample with inflation * P+ (re-uses the data at every
//    iteration: the stds collapse). Kept for comparison.
// In the keep-spread / inflate modes a step that raises the data misfit at the new centre is
// halved back towards the previous centre (up to 4 times); if it still raises it the run ends
// (kDiverged): a worse centre is never accepted.
// Stop when max_j |d_j| / sigma0_j < tolerance (sigma0 = prior std in eta), or after
// max_iterations.
//
// Bounds: every parameter's transform maps R onto its bounds (Prior::validate refuses a bounded
// parameter with a wider transform), so no sigma point and no estimate leaves them.
//
// Outcomes (UtTermination; ok() only for kConverged and kCompleted): after the run, in this order,
// a non-finite estimate or fit -> kNonFinite; an estimate within bound_margin of a bound ->
// kAtBound; a fit worse than the prior's -> kWorseThanPrior; a one-shot update whose normalised
// innovation squared exceeds the chi-square quantile chi2_m(1 - nis_alpha) -> kOneShotNotTrusted.
//
// Global start (UtOptions::global_start): a Sobol' screen (estimation/sensitivity/sobol_sequence.h)
// of `samples` points of the box eta0 +- width sigma0, Phi evaluated at each (and at the prior
// mean), then a local run from each of the best `keep`; the summary is the local run with the
// lowest final Phi, with every start listed in UtSummary::starts. With probe_iterations the local
// runs are probes of that many iterations and only the best probe is continued to the end.
// The local runs are independent, so on one rank with several threads they run side by side, one
// per thread (UtGlobalStart::concurrent): a local run's single-run steps (candidates, secant
// iterations) then leave no thread idle, and the numbers are those of the runs one after another.
//
// Failure policy (docs/estimation.md s.8), every action recorded in Summary::actions:
//  - kAbort: the first iteration with a failed member ends the run (kAbortedFailures) with the
//    failed members' parameters and messages in Summary::failed and Summary::message.
//  - kShrinkAndRetry (default): re-sample the same iteration with the spread multiplied by
//    shrink_factor (P by its square), up to max_retries times, then abort as above. The shrunk
//    ensemble measures the statistical linearisation over a smaller region; P_tz and P_zz are
//    divided by the squared factor so the prior covariance is unchanged (exact for a linear h).
//  In kMap a failed sigma point whose opposite point (U_j = -U_i) ran is first mirrored through
//  the centre, z_i = 2 z_c - z_j (a one-sided slope along that axis; exact for a linear h, the
//  weights unchanged; kMirror), before any shrink. In kMap a failed candidate centre is a rejected step (damp and retry), never an abort; so are
//  sigma points that still fail at a centre reached by a step (UtAction::kRevert: back to the
//  previous centre). Only a failed starting point, or failed sigma points there, abort.
//  No drop-member-and-reweight: a rule with one point removed no longer satisfies U w = 0 and
//  U W U^T = I (p points cannot have zero mean and identity covariance in p dimensions; dropping
//  one of a +-pair loses that direction), so no reweighting gives a valid UT.
//
// MPI: every rank calls run() with the same inputs; the Ensemble gathers results everywhere, so
// every rank holds the same Summary (only rank 0 should write it). With several ranks per node
// set ensemble.threads explicitly (0 means all cores in every rank).
#pragma once

#include "estimation/ensemble.h"
#include "estimation/fit_metrics.h"
#include "estimation/noise_scale.h"
#include "estimation/prior.h"
#include "estimation/sigma_points.h"
#include "estimation/transform.h"
#include "model/simulator.h"
#include "observers/observer.h"

#include <Eigen/Core>

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

// How a run ended; only kCompleted and kConverged are a success (UtSummary::ok()).
enum class UtTermination {
  kCompleted,          // one-shot update done (and trusted, and not worse than the prior)
  kConverged,          // step < tolerance
  kMaxIterations,      // stopped at the iteration limit
  kAbortedFailures,    // the failure policy gave up (or the starting point failed)
  kNumericalFailure,   // singular P_zz + R or non-finite update
  kDiverged,           // no step lowers the objective (kMap: after max_rejections dampings)
  kNonFinite,          // NaN / infinite estimate or misfit at the estimate
  kWorseThanPrior,     // the estimate's data misfit is above the prior mean's
  kAtBound,            // the estimate is stuck at a parameter bound
  kOneShotNotTrusted,  // one-shot NIS far outside its chi-square band
};
const char* to_string(UtTermination termination);

enum class UtMode { kOneShot, kIterateKeepSpread, kIterateInflate, kMap };
const char* to_string(UtMode mode);
// "one-shot", "iterate-keep-spread", "iterate-inflate", "map"
std::optional<UtMode> parse_ut_mode(const std::string& text);

enum class UtFailurePolicy { kAbort, kShrinkAndRetry };
const char* to_string(UtFailurePolicy policy);
std::optional<UtFailurePolicy> parse_ut_failure_policy(const std::string& text);  // "abort", "shrink-and-retry"

// Which observation the innovation compares y with.
enum class UtInnovation {
  kAuto,       // kSigmaMean for kOneShot, kCenter for the iterate modes
  kSigmaMean,  // y - z_bar
  kCenter,     // y - h(T(eta_c)), needs the centre run
};

// A space-filling start for priors far from the data (see the file comment).
struct UtGlobalStart {
  int samples = 0;     // Sobol' points screened; 0: no global start
  int keep = 1;        // local runs, from the best screened points
  double width = 3.0;  // half-width of the screened box in prior stds (eta), > 0
  // > 0: each local run first makes at most `probe_iterations` iterations; only the one with the
  // lowest Phi then goes on (from where it stopped) to the full max_iterations. 0: every local run
  // goes to the end. Starts that lead to the same basin then cost a few iterations, not a run.
  int probe_iterations = 0;
  // On one rank with several threads: the local runs side by side, each on threads / that many
  // threads (at least one), instead of one after another on all threads. Same numbers either way
  // (each local run depends only on its start); under several ranks always one after another.
  bool concurrent = true;
};
const char* to_string(UtInnovation innovation);

struct UtProgress {
  // 0-based; -1: the global start's screen; -2: its local runs side by side (done, total count
  // the finished local runs; UtGlobalStart::concurrent)
  int iteration = 0;
  int attempt = 0;    // 0 = first sampling, k = k-th shrink retry
  int done = 0;       // members finished in this ensemble batch (this rank's share under MPI)
  int total = 0;
};

struct UtOptions {
  SigmaOptions sigma;                        // rule and its kappa / alpha / beta
  UtMode mode = UtMode::kOneShot;
  int max_iterations = 1;                    // iterate modes; kOneShot always runs 1
  double tolerance = 1e-4;                   // on max |d eta_j| / sigma0_j
  // kMap, the objective-based stop (docs/estimation.md s.3.3): converged when Phi fell by less
  // than objective_tolerance per observation over the last two iterations and a finishing step
  // along the valley did not lower it (Phi is in squared noise units / 2, so 0.01 per observation
  // is a change of 0.02 in the mean squared normalised residual); the decrease the linearised Phi
  // still promised is stated in the message, not tested. 0: off (step only).
  double objective_tolerance = 0.01;
  // kMap: an unknown scale per observation channel with this inverse-gamma prior on its variance
  // multiplier, marginalised (noise_scale.h); nullopt: the stated noise is exact.
  std::optional<NoiseScalePrior> noise_scale;
  // kMap: rejected (damped) candidates allowed in one iteration before the run ends kDiverged.
  int max_rejections = 8;
  // kMap: up to this many iterations in a row linearised by a secant (Broyden) update of the last
  // linearisation from the accepted step's own run instead of by a new set of sigma points
  // (docs/estimation.md s.3.3.2); a rejected secant step, a poor gain ratio and every stop are
  // re-linearised on sigma points first, so no result rests on a secant slope. 0: off.
  int secant_iterations = 0;
  // kMap: add the geodesic acceleration to each damped step (one more run per candidate;
  // docs/estimation.md s.3.3.2): steps that follow a curved valley instead of creeping along it.
  bool geodesic_acceleration = false;
  // An estimate closer to a bound than bound_margin x (the prior's distance to it) is kAtBound.
  double bound_margin = 1e-3;
  // kOneShot: the update is not trusted when its NIS exceeds the chi2_m quantile of 1 - nis_alpha.
  double nis_alpha = 1e-3;
  UtGlobalStart global_start;
  double inflation = 1.0;                    // kIterateInflate: P_next = inflation * P+ (>= 1)
  UtInnovation innovation = UtInnovation::kAuto;
  // Spread of the sigma points relative to the covariance being sampled, in (0, 1]. P_tz and P_zz
  // are divided by its square, so the covariance of the update is unchanged (exact for a linear
  // h). 1: the standard UT (a secant linearisation over the whole prior). Smaller values approach
  // the local Jacobian, so the iterate modes converge like damped Gauss-Newton; with 1 they can
  // stall or oscillate on curved maps (a secant slope differs from the local one).
  double sample_scale = 1.0;
  UtFailurePolicy failure_policy = UtFailurePolicy::kShrinkAndRetry;
  double shrink_factor = 0.5;                // spread multiplier per retry, in (0, 1)
  int max_retries = 3;
  bool evaluate_fit = true;                  // run the model at each centre and at the result
  EnsembleOptions ensemble;                  // backend, threads (its progress is overridden)
  // Called (serialised, possibly from worker threads) after each finished member.
  std::function<void(const UtProgress&)> progress;
  // Twin experiments: the true theta (SI, one per estimated parameter); the Summary then carries
  // the estimate's relative errors against it.
  std::optional<Eigen::VectorXd> truth;
  std::string validate(int p) const;
};

// Model output at one point against the data, per observation (SI, in ObservationSet order).
struct UtFit {
  Eigen::VectorXd theta;       // where the model ran (estimated parameters, SI)
  Eigen::VectorXd z;           // model output; NaN if the run failed
  Eigen::VectorXd residual;    // y - z
  Eigen::VectorXd normalised;  // (y - z) / sqrt(R_jj)
  model::Status status;
  double misfit() const;       // 0.5 * sum normalised^2 (NaN if the run failed)
};

struct UtAction {
  // kBacktrack: an iterate-mode step raised the data misfit at the new centre and was halved.
  // kReject: a kMap candidate raised Phi (misfit) or its centre run failed (failed_members {-1});
  // the damping lambda was raised to spread_factor.
  // kRevert: kMap, the sigma points at a centre reached by an accepted step still failed after the
  // shrink retries (failed_members); the step is rejected, the run goes back to the previous
  // centre and its linearisation, lambda raised to spread_factor (counted in rejected_steps).
  // kMirror: kMap, failed sigma points whose opposite points ran get z_i = 2 z_c - z_mirror (a
  // one-sided slope along their axes, failed_members; counted in UtSummary::mirrored).
  enum class Kind { kShrinkAndRetry, kAbort, kBacktrack, kReject, kRevert, kMirror };
  Kind kind = Kind::kShrinkAndRetry;
  int iteration = 0;
  int attempt = 0;             // the attempt that failed
  double spread_factor = 1.0;  // factor of the next attempt (kShrinkAndRetry); of the step (kBacktrack)
  double misfit = 0.0;           // kBacktrack: misfit at the rejected centre
  double previous_misfit = 0.0;  // kBacktrack: misfit at the previous centre
  std::vector<int> failed_members;
  std::string describe() const;
};

struct UtMemberFailure {
  int iteration = 0;
  int attempt = 0;
  int member = 0;              // -1: the centre run
  Eigen::VectorXd theta;       // SI
  model::Status status;
};

struct UtIteration {
  int iteration = 0;
  int attempts = 1;                 // 1 + shrink retries
  double spread_factor = 1.0;       // of the accepted attempt (sample_scale x shrink factors)
  Eigen::VectorXd eta_center;       // centre of the sigma points
  Eigen::MatrixXd P_center;         // covariance sampled (before shrinking), eta
  Eigen::MatrixXd eta_members;      // r x p, accepted attempt
  Eigen::MatrixXd theta_members;    // r x p, SI
  Eigen::MatrixXd Z;                // r x m, SI (NaN rows for failed members)
  std::vector<model::Status> status;
  std::optional<UtFit> center_fit;  // the model at eta_center (when evaluate_fit or kCenter)
  Eigen::VectorXd z_bar;            // sigma-point mean of z
  Eigen::VectorXd innovation;       // y - z_ref, SI
  double nis = 0.0;                 // innovation^T (P_zz + R)^-1 innovation
  Eigen::MatrixXd P_zz;             // SI^2
  Eigen::MatrixXd P_tz;             // eta x SI
  Eigen::MatrixXd gain;             // K, eta per SI
  Eigen::VectorXd eta_mean;         // eta+
  Eigen::MatrixXd P;                // P+
  double step = 0.0;                // max |eta+_j - eta_c,j| / sigma0_j
  double objective = 0.0;           // Phi at eta_center (kMap; data misfit in the other modes)
  bool extrapolated = false;        // kMap: the centre came from the valley's finishing step
  bool secant = false;              // kMap: linearised by the secant update (no members ran)
  double lambda = 0.0;              // kMap: damping of the accepted step
  int rejected = 0;                 // kMap: candidates rejected in this iteration
};

// One start of a global start: where it began, the screen's Phi there and how its run ended.
struct UtStart {
  Eigen::VectorXd theta_start;      // SI
  double screen_objective = 0.0;    // Phi at the start
  double objective = 0.0;           // Phi at the run's estimate
  UtTermination termination{};
  int iterations = 0;
  int simulations = 0;
  Eigen::VectorXd theta;            // the run's estimate, SI
  std::vector<double> objectives;   // Phi at the start of each iteration, then at the estimate
  std::string message;              // how the run ended, in words
};


struct UtSummary {
  UtTermination termination = UtTermination::kCompleted;
  std::string message;                  // how it ended; failing members on abort
  UtMode mode = UtMode::kOneShot;
  UtInnovation innovation = UtInnovation::kSigmaMean;  // the one used (never kAuto)
  SigmaRule rule = SigmaRule::kSimplex;
  std::vector<std::string> names;       // parameters
  std::vector<std::string> observation_names;

  Eigen::VectorXd eta_prior_mean, eta_prior_std;
  Eigen::VectorXd theta_prior;          // the prior's centre in theta (PriorParameter::theta_nominal)
  Eigen::VectorXd theta_prior_std;      // delta method at the prior mean
  Eigen::VectorXd eta_mean;             // final estimate (last accepted eta+; prior if none)
  Eigen::MatrixXd eta_covariance;       // last P+ (prior if none)
  Eigen::VectorXd eta_std;
  // Two different "means" of theta: the transform of the eta mean (the point estimate, where
  // fit_after runs) and the sigma-point estimate of E[theta] = sum wm_i T(eta_i) over the
  // posterior sigma points. They differ for nonlinear transforms.
  Eigen::VectorXd theta_of_eta_mean;
  Eigen::VectorXd theta_sigma_mean;
  Eigen::VectorXd theta_std;            // delta method: |T'(eta_mean)| eta_std
  Eigen::VectorXd theta_sigma_std;      // sigma-point std of theta (posterior points)

  std::optional<UtFit> fit_before;      // at the prior mean
  std::optional<UtFit> fit_after;       // at theta_of_eta_mean
  // Relative errors and RMS normalised residual of the two fits (NaN when a fit is missing).
  FitMetrics metrics_before, metrics_after;
  // 100 |theta_of_eta_mean - truth| / |truth| per parameter, when UtOptions::truth was given.
  std::optional<Eigen::VectorXd> truth_error_percent;

  std::vector<UtIteration> iterations;
  std::vector<UtAction> actions;
  std::vector<UtMemberFailure> failed;
  int simulations = 0;                  // forward runs, including retries and fits
  int failures = 0;                     // failed forward runs
  int rejected_steps = 0;               // kMap candidates rejected (raised Phi or failed)
  int retries = 0;                      // shrink-and-retry re-samplings
  int mirrored = 0;                     // kMap: failed sigma points mirrored (UtAction::kMirror)
  // Phi (kMap objective: data misfit + prior term) at the prior mean and at the estimate.
  double objective_prior = std::numeric_limits<double>::quiet_NaN();
  double objective = std::numeric_limits<double>::quiet_NaN();
  double nis_threshold = std::numeric_limits<double>::quiet_NaN();  // kOneShot: chi2 quantile
  std::vector<UtStart> starts;          // global start: every start (empty without one)
  // kMap with UtOptions::noise_scale: each channel's variance-multiplier posterior at the estimate.
  std::optional<NoiseScalePosterior> noise_scale;
  int extrapolations = 0;               // kMap: valley finishing steps tried (docs/estimation.md s.3.3)

  // Set when another estimator reports through this summary (least_squares.h,
  // as_calibration_summary): brief_report() returns it.
  std::string headline;

  bool ok() const;  // kCompleted or kConverged
  // One line, e.g. "UT calibration (one-shot, simplex, 3 params, 5 obs): completed after 1
  // iteration, 6 runs, 0 failed, 0 policy actions, misfit 12.3 -> 0.41".
  std::string brief_report() const;
  // The brief line, then one line per parameter (prior -> posterior, both theta means, stds) and
  // per observation (y, z before, z after, in SI), then the policy actions. For logs.
  std::string full_report() const;
};

class UtCalibration {
 public:
  // model must outlive the UtCalibration (run() clones it, once per worker). prior: one Gaussian
  // parameter per ForwardModel input, same names and order; observations: same names and order
  // as ForwardModel::outputs(). Checked in validate()/run().
  UtCalibration(const ForwardModel& model, Prior prior,
                observers::ObservationSet observations, UtOptions options = {});

  // Empty when the problem and options are consistent, else the first problem found.
  std::string validate() const;
  // Throws std::invalid_argument when validate() is not empty (bad input); member failures and
  // numerical failures never throw, they end the run with a termination (UtSummary::ok()).
  UtSummary run();

 private:
  struct Start;  // a local run's starting point and what is known there
  UtSummary run_local(const Start& start);
  // With the ensemble options of this run and whether it reports progress (a local run of the
  // global start side by side with others does not).
  UtSummary run_local(const Start& start, const EnsembleOptions& ensemble, bool report_progress);
  UtSummary run_global();

  const ForwardModel& model_;
  Prior prior_;
  observers::ObservationSet observations_;
  UtOptions options_;
};

}  // namespace sigmaheart::estimation
