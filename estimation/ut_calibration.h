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
//  - kOneShot: one update from the prior, z_ref = z_bar (the paper's method).
//  - kIterateKeepSpread: re-centre at eta+ and sample again with the PRIOR covariance P0; z_ref =
//    h(eta_c), the model at the centre (a Gauss-Newton-like step damped by P0, whose fixed point
//    fits the data; with z_bar it would stop where the sigma-point mean fits, a biased point).
//    The data are used once per step, not accumulated: the reported covariance is the last P+.
//  - kIterateInflate: re-centre at eta+ and sample with inflation * P+ (the over-confident
//    iterated UT when inflation = 1); z_ref as above.
// In the iterate modes a step that raises the data misfit at the new centre is halved back towards
// the previous centre (up to 4 times; UtAction::kBacktrack records each).
// Stop when max_j |eta+_j - eta_c,j| / sigma0_j < tolerance (sigma0 = prior std in eta), or after
// max_iterations.
//
// Failure policy (docs/estimation.md s.8), every action recorded in Summary::actions:
//  - kAbort: the first iteration with a failed member ends the run (kAbortedFailures) with the
//    failed members' parameters and messages in Summary::failed and Summary::message.
//  - kShrinkAndRetry (default): re-sample the same iteration with the spread multiplied by
//    shrink_factor (P by its square), up to max_retries times, then abort as above. The shrunk
//    ensemble measures the statistical linearisation over a smaller region; P_tz and P_zz are
//    divided by the squared factor so the prior covariance is unchanged (exact for a linear h).
//  No drop-member-and-reweight: a rule with one point removed no longer satisfies U w = 0 and
//  U W U^T = I (p points cannot have zero mean and identity covariance in p dimensions; dropping
//  one of a +-pair loses that direction), so no reweighting gives a valid UT.
// A failed centre run (the fit) only matters in the iterate modes, where it aborts the run.
//
// MPI: every rank calls run() with the same inputs; the Ensemble gathers results everywhere, so
// every rank holds the same Summary (only rank 0 should write it). With several ranks per node
// set ensemble.threads explicitly (0 means all cores in every rank).
#pragma once

#include "estimation/ensemble.h"
#include "estimation/fit_metrics.h"
#include "estimation/prior.h"
#include "estimation/sigma_points.h"
#include "estimation/transform.h"
#include "model/simulator.h"
#include "observers/observer.h"

#include <Eigen/Core>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {


enum class UtMode { kOneShot, kIterateKeepSpread, kIterateInflate };
const char* to_string(UtMode mode);
std::optional<UtMode> parse_ut_mode(const std::string& text);  // "one-shot", "iterate-keep-spread", "iterate-inflate"

enum class UtFailurePolicy { kAbort, kShrinkAndRetry };
const char* to_string(UtFailurePolicy policy);
std::optional<UtFailurePolicy> parse_ut_failure_policy(const std::string& text);  // "abort", "shrink-and-retry"

// Which observation the innovation compares y with.
enum class UtInnovation {
  kAuto,       // kSigmaMean for kOneShot, kCenter for the iterate modes
  kSigmaMean,  // y - z_bar
  kCenter,     // y - h(T(eta_c)), needs the centre run
};
const char* to_string(UtInnovation innovation);

struct UtProgress {
  int iteration = 0;  // 0-based
  int attempt = 0;    // 0 = first sampling, k = k-th shrink retry
  int done = 0;       // members finished in this ensemble batch (this rank's share under MPI)
  int total = 0;
};

struct UtOptions {
  SigmaOptions sigma;                        // rule and its kappa / alpha / beta
  UtMode mode = UtMode::kOneShot;
  int max_iterations = 1;                    // iterate modes; kOneShot always runs 1
  double tolerance = 1e-4;                   // on max |d eta_j| / sigma0_j
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
  enum class Kind { kShrinkAndRetry, kAbort, kBacktrack };
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
};

enum class UtTermination {
  kCompleted,         // one-shot update done
  kConverged,         // step < tolerance
  kMaxIterations,
  kAbortedFailures,   // the failure policy gave up
  kNumericalFailure,  // singular P_zz + R or non-finite update
};
const char* to_string(UtTermination termination);

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

  bool ok() const;  // kCompleted, kConverged or kMaxIterations
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
  const ForwardModel& model_;
  Prior prior_;
  observers::ObservationSet observations_;
  UtOptions options_;
};

}  // namespace sigmaheart::estimation
