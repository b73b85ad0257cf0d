// Reduced-Order Unscented Kalman Filter (ROUKF) for joint state-parameter estimation
// (Moireau & Chapelle 2011, "Reduced-order Unscented Kalman Filtering with application to
// parameter identification in large-dimensional systems", ESAIM COCV 17:380; docs/estimation.md s.4).
//
// Augmented state x = (y, eta): y the simulator's flat model state, eta the estimated parameters
// in unconstrained coordinates (theta = T(eta), transform.h). The covariance is kept factored,
// P = L U^-1 L^T with L n x p and U p x p (p = number of estimated parameters), so only p x p
// systems are solved whatever the model size. One filter step between observation times:
//   sampling     C = chol(U^-1), L <- L C, x_i = x + L V_i          (M&C 2011, eq. 3.8 with
//                                                                    simplex points, Sec. 3.2)
//   prediction   x_i advanced to the next frame (r = p+1 members, in parallel), x- = sum a_i x_i,
//                L = [x_i] D_a V^T, U = I                            (eq. 3.9)
//   correction   z_i = H(x_i), HL = [z_i] D_a V^T, U = I + HL^T R^-1 HL,
//                x+ = x- + L U^-1 HL^T R^-1 (y - z-)                 (eq. 3.10)
// With simplex points one correction equals the Unscented-Transform update
// K = P_xz (P_zz + R)^-1 (docs/estimation.md s.3), and on a linear-Gaussian model the filter equals the
// Kalman filter; both are tests. The filter corrects the model state too.
//
// Far from the truth with a very informative first frame the one-step regression locks in wrong
// values (docs/estimation.md s.4.2). RoukfPassMode::kSplit assimilates the frames in passes with
// R / phi_b, sum phi_b = 1, each pass restarting the members from the initial state (multiple data
// assimilation, Emerick & Reynolds 2013); `tempering` splits one frame's analysis the same way
// (Zanetti 2012); `sigma_scale` narrows the points (Julier 2002). All three keep the Kalman filter
// on linear-Gaussian models (tests).
//
// Marchesseau et al. 2013 (Med Image Anal 17:816) use this filter to estimate one contractility
// per AHA zone from regional volume curves (p = 17, 18 members per step).
#pragma once

#include "estimation/channel_noise_scale.h"
#include "estimation/ensemble.h"
#include "estimation/prior.h"
#include "estimation/sigma_points.h"
#include "estimation/transform.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

// Measured channels of the simulator's sample() at frame times. A NaN entry is a missing value
// (that channel is not used at that frame); a frame with every entry missing is a prediction-only
// step.
struct RoukfData {
  std::vector<std::string> channels;  // names in simulator.channels()
  Eigen::VectorXd times;              // [s], strictly increasing, after the initial state's time
  Eigen::MatrixXd values;             // frames x channels, SI
  // Empty when sizes agree and times increase, else a message.
  std::string validate() const;
};

// What to do when an ensemble member fails (docs/estimation.md s.8). Every action is recorded.
enum class RoukfFailurePolicy {
  // Retry the member with a refined time step (Options::refine) up to max_retries times; if it
  // still fails, re-run the whole step with the sigma spread shrunk by `shrink`, skip the analysis
  // of that frame and inflate the covariance by `inflation`; abort if that fails too.
  kRetryThenSkip,
  // As above without retries.
  kSkipWithInflation,
  // Stop at the first failure (after retries), reporting the member's parameters.
  kAbort,
};
const char* to_string(RoukfFailurePolicy policy);
std::optional<RoukfFailurePolicy> parse_roukf_failure_policy(const std::string& text);
// "retry-then-skip", "skip", "abort"

// How repeated passes over the data count them (docs/estimation.md s.4.2).
enum class RoukfPassMode {
  // Pass b continues in time (times + b period) with the full R: the same data count `beats`
  // times, so the posterior spread is too narrow by about sqrt(beats) (Marchesseau et al. 2013).
  kRepeat,
  // Multiple data assimilation (Emerick & Reynolds 2013, Comput Geosci 55:3): every pass restarts
  // from the initial state with the current parameter spread and assimilates the frames with
  // R / phi_b, phi_1 = first_fraction, later phi_b chosen from the information the previous pass
  // added (pass_growth), sum phi_b = 1 (the last allowed pass takes the rest). The likelihoods
  // raised to phi_b multiply to the likelihood once: on a linear-Gaussian model the result is the
  // one-pass Kalman filter's. `beats` is the largest number of passes.
  kSplit,
};
const char* to_string(RoukfPassMode mode);
std::optional<RoukfPassMode> parse_roukf_pass_mode(const std::string& text);  // "repeat", "split"

struct RoukfAction {
  int member = -1;           // -1: the whole step
  std::string what;          // "retried with refined step (level 1)", "shrunk spread", ...
  model::Status status;      // the failure that triggered it
};

// Per-step record. Vectors over parameters are in the order of the Prior; vectors
// over channels in the order of RoukfData::channels (NaN where missing).
struct RoukfStep {
  int index = 0;          // step number (0-based)
  int beat = 0;           // data pass
  int frame = 0;          // row of RoukfData
  double time = 0.0;      // [s]
  int observed = 0;       // channels used in the analysis (0: prediction only)
  bool analysis_skipped = false;  // data present but not used (failure policy)
  int subupdates = 0;     // tempered sub-updates of the analysis (1: one update; 0: none)
  Eigen::VectorXd eta;        // analysed mean
  Eigen::VectorXd eta_std;    // sqrt(diag P_eta)
  // theta = T(eta) (the median of theta under a Gaussian eta; not the mean of theta) and the
  // +-2 sigma interval T(eta -+ 2 std) (transforms are monotone).
  Eigen::VectorXd theta, theta_lower, theta_upper;
  Eigen::VectorXd forecast;     // z- (prior fitted observation)
  Eigen::VectorXd fitted;       // z- + HL U^-1 HL^T R^-1 (y - z-) (linearised posterior fit)
  Eigen::VectorXd innovation;   // y - z-
  double nis = 0.0;             // innovation^T S^-1 innovation, S = HL HL^T + R
  double log_likelihood = 0.0;  // log N(y; z-, S)
  std::vector<RoukfAction> actions;
  // Filled when RoukfOptions::record_factors.
  Eigen::VectorXd x;
  Eigen::MatrixXd L, U;
};

struct RoukfOptions {
  // Observation noise covariance over RoukfData::channels (SI^2), symmetric positive definite.
  // Missing values select the sub-matrix of the present channels.
  Eigen::MatrixXd R;
  // The data are assimilated `beats` times: pass b uses times + b * period (period > 0 when
  // beats > 1). Mirrors repeating one measured, periodic beat as Marchesseau et al. 2013 do.
  int beats = 1;
  double period = 0.0;  // [s], kRepeat
  RoukfPassMode pass_mode = RoukfPassMode::kRepeat;
  double first_fraction = 1e-3;  // kSplit: phi_1, in (0, 1]
  double pass_growth = 1.0;      // kSplit: information a pass may add, relative to the spread
  // kSplit: after the last pass, at most `map_iterations` damped Gauss-Newton steps on the
  // whole-data MAP objective Phi(eta) = sum_k r_k^T R^-1 r_k + (eta - eta0)^T P0^-1 (eta - eta0),
  // started at the filter's estimate (docs/estimation.md s.4.7). The split passes end about one
  // posterior std from the MAP on the regional twins; on foreign data several. The slopes are
  // central differences (2p whole-data members, step 0.1 filter posterior std), run in parallel
  // through the ensemble; the step is the Gauss-Newton one shortened by 1 + lambda, lambda from
  // the gain ratio, each candidate one whole-data run. Converged when the Gauss-Newton step is
  // shorter than `map_tolerance` posterior standard deviations (sqrt(d^T A d), A the Gauss-Newton
  // Hessian), or when Phi fell by less than `map_objective_tolerance` per observation over the
  // last two steps and a finishing step along the valley does not lower it (0: off). The
  // covariance reported is then the Laplace one, A^-1. The iteration limit with Phi still
  // falling, 9 rejected candidates in one step, a failed member of the slopes or a singular system
  // keep the last accepted point, say so in RoukfSummary::map_note and end the run as
  // kMapNotConverged (the estimate is not the MAP). 0: off.
  int map_iterations = 5;
  double map_tolerance = 0.01;
  double map_objective_tolerance = 0.002;  // per observation; 0: the step test only
  // Model error (docs/estimation.md s.4.8): with a value, the MAP refinement takes every observed
  // channel's noise covariance as s_c^2 R_c with s_c^2 ~ InvGamma(*noise_scale) and integrates the
  // scales out (estimation/channel_noise_scale.h): Gauss-Newton with each channel weighted by
  // E[1 / s_c^2] at the current point, the Laplace covariance with those weights. A channel the
  // model cannot fit then widens the posterior instead of dragging the parameters. Needs kSplit and
  // map_iterations > 0. RoukfSummary::noise_scale_mode reports the scales.
  std::optional<NoiseScalePrior> noise_scale;
  // Full parameter vector for the parameters that are not estimated; empty: the nominal values.
  Eigen::VectorXd base_theta;
  // Initial model state; empty: simulator.initial_state(theta at the prior mean).
  std::optional<model::State> initial_state;
  // When set (and initial_state is empty) every sigma point of the first prediction starts from
  // simulator.initial_state(theta_i) instead of the common initial state: the prior then carries
  // the state-parameter correlation of the initial condition (exact for a linear map
  // theta -> y0). With a first frame some beats after t = 0, that first prediction is a spin-up of
  // every member to its own periodic state (the regional twin experiment does this).
  bool initial_state_per_member = false;
  // Fading memory: after every prediction P <- P / forgetting, forgetting in (0, 1]. 1 is the
  // filter of Moireau & Chapelle as written; below 1 it keeps the filter from growing
  // over-confident when one measured beat is assimilated again and again (the same data then
  // count once per pass). The memory is about 1/(1 - forgetting) frames.
  double forgetting = 1.0;
  // Tempered analysis (docs/estimation.md s.4.2): each frame's information is assimilated in
  // sub-updates of the likelihood raised to phi_k (sum 1), each adding at most `tempering` times
  // the current spread's information in any direction (phi_k lambda_max(HL^T R^-1 HL) <=
  // tempering), the sigma points re-drawn at the previous frame and advanced again between
  // sub-updates (Zanetti 2012, IEEE TAC 57:1481, recursive update filter). 0: one update per
  // frame, the filter as published. Exact (the Kalman filter) on linear-Gaussian models for any
  // value; on a nonlinear model a first, very informative frame is then analysed over a spread
  // that narrows step by step instead of one regression over the whole prior.
  double tempering = 0.0;
  int max_subupdates = 64;  // per frame; the last one takes the rest of the frame's information
  // Scaled sigma points x + sigma_scale L V_i, deviations divided by sigma_scale after the
  // prediction (the scaling of Julier 2002, "The scaled unscented transformation", Proc. ACC,
  // applied to the simplex set without a centre point):
  // the same mean and covariance to first order over a narrower neighbourhood; exact on linear
  // models for any value in (0, 1].
  double sigma_scale = 1.0;
  SigmaRule sigma_rule = SigmaRule::kSimplex;  // a rule with equal mean and covariance weights
  double star_kappa = 0.5;                     // kStar only
  EnsembleOptions ensemble;

  RoukfFailurePolicy failure_policy = RoukfFailurePolicy::kRetryThenSkip;
  int max_retries = 2;      // refined retries per failed member (each halves the step again)
  double shrink = 0.5;      // sigma spread factor for the re-run after a failure, in (0, 1)
  double inflation = 0.1;   // covariance inflation when an analysis is skipped: P *= 1 + inflation
  // A copy of the simulator with its time step divided by 2^level, or nullptr when the simulator
  // offers no such control. Empty: no retries. refine_by_time_step() uses
  // SteppableSimulator::with_time_step_factor.
  std::function<std::unique_ptr<model::SteppableSimulator>(const model::SteppableSimulator&,
                                                           int level)>
      refine;

  bool record_factors = false;  // keep x, L, U after every step (tests, diagnostics)
  // Called after every step; return false to stop (termination kCancelled).
  std::function<bool(const RoukfStep&)> on_step;
  // Twin experiments: the true theta of every estimated parameter (Prior order, SI). The summary
  // then carries the relative error after each pass.
  std::optional<Eigen::VectorXd> truth;

  // Empty when the fields are consistent, else a message naming the field.
  std::string validate() const;
};

// How a run ended. Bad input is reported up front as kInvalidInput; failed members (past the
// failure policy), numerical failures (a covariance factor that is not positive definite, a
// non-finite update) and an analysed parameter outside the simulator's bounds
// (kEstimateOutOfBounds) end the run with the steps done so far; run_roukf never throws for them.
//
// kMapNotConverged: the filter completed but the MAP refinement after split passes
// (RoukfOptions::map_iterations) did not reach its tolerance (iteration limit, a failed member, a
// step that cannot lower the objective): the estimate is the last accepted point, not the MAP, and
// RoukfSummary::map_note says why. Like every outcome but kCompleted it is not a success.
enum class RoukfTermination {
  kCompleted, kMemberFailed, kCancelled, kInvalidInput, kNumericalFailure, kEstimateOutOfBounds,
  kMapNotConverged,
};
const char* to_string(RoukfTermination t);

// One step of the MAP refinement (RoukfSummary::map_history; docs/estimation.md s.4.7). Lengths
// in posterior standard deviations, sqrt(s^T A s) with A the Gauss-Newton Hessian at the point the
// step starts from; objectives in the units of RoukfSummary::map_objective.
struct RoukfMapStep {
  double objective = 0.0;       // Phi after the step (the start point's when none was accepted)
  double gauss_newton_std = 0.0;  // the undamped Gauss-Newton step
  double step_std = 0.0;        // the step taken (or the last one tried)
  double predicted = 0.0;       // decrease of Phi the quadratic model promises for it
  double actual = 0.0;          // decrease of Phi it made (NaN when not run)
  double gain = 0.0;            // actual / predicted
  double damping = 0.0;         // Levenberg-Marquardt lambda the step was solved with
  double cos_previous = 0.0;    // cosine between this step and the last accepted one (A metric)
  int rejected = 0;             // candidates that did not lower Phi
  int out_of_bounds = 0;        // candidates outside the simulator's bounds (not run)
  bool accepted = false;
  bool extrapolated = false;    // a finishing step along the valley (Aitken)
};

struct RoukfSummary {
  RoukfTermination termination = RoukfTermination::kInvalidInput;
  std::string message;  // why it stopped; for kMemberFailed the member's parameters
  std::vector<std::string> parameter_names;
  std::vector<RoukfStep> steps;
  // Final estimate.
  Eigen::VectorXd eta, theta, theta_lower, theta_upper;
  Eigen::MatrixXd eta_covariance;  // P_eta = L_eta U^-1 L_eta^T
  Eigen::VectorXd theta_std;       // delta method: |T'(eta)| sqrt(diag P_eta)
  Eigen::VectorXd theta_prior;     // the prior's centre (PriorParameter::theta_nominal)
  Eigen::VectorXd theta_prior_std; // delta method at the prior mean
  // With RoukfOptions::truth: 100 |theta - truth| / |truth| after the last step of each pass
  // (rows: passes, NaN for a pass not reached), and the first pass (1-based) after which every
  // parameter is within 10 % (-1: never).
  Eigen::MatrixXd pass_error_percent;
  int passes_to_within_10_percent = -1;
  // With RoukfOptions::truth: 100 |theta - truth| / |truth| of the final estimate (after the MAP
  // refinement when it ran; else the last row of pass_error_percent).
  Eigen::VectorXd error_percent;
  // With RoukfOptions::truth and an estimate: e = eta - to_eta(truth), its standardised components
  // e_i / sqrt(P_eta,ii), and the joint statistic d2 = e^T P_eta^-1 e. For a right posterior d2 is
  // chi-square with p = size(eta) degrees of freedom, so d2 <= chi2_0.95(p) (truth_d2_limit) with
  // probability 0.95: the joint form of "every parameter inside its +-2 std", which for p
  // independent parameters holds only with probability 0.954^p (0.45 at p = 17).
  Eigen::VectorXd truth_z;
  double truth_d2 = std::numeric_limits<double>::quiet_NaN();
  double truth_d2_limit = std::numeric_limits<double>::quiet_NaN();
  model::State state;              // final analysed model state
  Eigen::MatrixXd L, U;            // final factors (x = (state.x, eta))
  int members = 0;                 // r
  int member_runs = 0;
  int retries = 0;
  int skipped_analyses = 0;
  int subupdates = 0;              // tempered sub-updates over all analysed frames
  // Filter consistency: the NIS averaged over the analysed frames and its 95 % band. With a
  // consistent filter the sum of the NIS over frames is chi-square with nis_dof = sum of the
  // observed channel counts degrees of freedom (Bar-Shalom, Li & Kirubarajan 2001, Estimation with
  // Applications to Tracking and Navigation, s.5.4.2), so the mean lies in
  // [chi2_0.025(nis_dof), chi2_0.975(nis_dof)] / nis_frames with probability 0.95.
  double nis_mean = 0.0;
  int nis_frames = 0;
  int nis_dof = 0;
  double nis_band_lower = 0.0, nis_band_upper = 0.0;
  // What the NIS above is: "sequential innovations" (kRepeat: the steps' NIS) or, for kSplit,
  // "whole data at the estimate (2 x MAP objective)": map_statistic = sum_k r_k^T R^-1 r_k +
  // (eta - eta0)^T P0^-1 (eta - eta0) from one run at the estimate, which on a linear-Gaussian
  // model equals the sum of the NIS of one exact pass (same chi-square band).
  std::string nis_source;
  double map_statistic = 0.0;
  int map_dof = 0, map_frames = 0;
  // kSplit with map_iterations > 0: the Gauss-Newton refinement after the passes. map_steps
  // accepted steps; map_shift_std the distance of the final estimate from the filter's, in the
  // filter's posterior standard deviations (sqrt(d^T P_filter^-1 d)); map_last_step_std the last
  // step's length in posterior std (below map_tolerance when map_converged); map_runs the whole-data
  // members run; map_note how it ended, in words. eta_filter and eta_covariance_filter keep the
  // filter's own estimate.
  int map_steps = 0;
  bool map_converged = false;
  double map_shift_std = std::numeric_limits<double>::quiet_NaN();
  double map_last_step_std = std::numeric_limits<double>::quiet_NaN();
  double map_statistic_filter = std::numeric_limits<double>::quiet_NaN();  // Phi at the filter's estimate
  double map_objective = std::numeric_limits<double>::quiet_NaN();  // Phi at the last accepted point
  int map_runs = 0;
  std::string map_note;
  std::vector<RoukfMapStep> map_history;
  Eigen::VectorXd eta_filter;
  Eigen::MatrixXd eta_covariance_filter;
  // kSplit, from the run at the estimate: per observed channel (RoukfData::channels order) the
  // chi-square sum_k w_k,c^2 of its whitened residuals with the stated noise, and the entries in it
  // (its frames). A channel the model fits within the noise has channel_chi2 / channel_frames in
  // [chi2_0.025, chi2_0.975](frames) / frames with probability 0.95.
  Eigen::VectorXd channel_chi2;
  Eigen::VectorXi channel_frames;
  // With RoukfOptions::noise_scale: per channel, the posterior mode of s_c^2 at the estimate
  // (1: the stated noise; 9: residuals three times the stated noise).
  Eigen::VectorXd noise_scale_mode;
  // Per parameter: the posterior std of eta over the prior std (1: the data did not inform it;
  // kUninformedStdRatio and above: "not informed" in the reports).
  Eigen::VectorXd std_ratio;
  std::vector<double> pass_fractions;  // kSplit: phi_b of every pass run
  double wall_seconds = 0.0;

  bool ok() const { return termination == RoukfTermination::kCompleted; }
  bool has_estimate() const { return theta.size() == static_cast<Eigen::Index>(parameter_names.size()); }
  std::string brief_report() const;  // one line
  std::string full_report() const;   // per parameter: estimate, +-2 sigma
};

// A parameter whose posterior std is at least this fraction of its prior std (in eta) is reported
// as not informed by the data: they did not even halve its spread.
inline constexpr double kUninformedStdRatio = 0.5;

// Runs the filter. prior: one Gaussian parameter per estimated simulator parameter (by name).
// The simulator is the prototype: each worker gets its own clone; the prototype itself is not
// advanced. Never throws for bad input, member or numerical failures (see termination).
RoukfSummary run_roukf(const model::SteppableSimulator& simulator, const Prior& prior,
                       const RoukfData& data, const RoukfOptions& options);

// Quantile of the chi-square distribution with `dof` degrees of freedom at probability `prob`, by the
// Wilson-Hilferty cube-root normal approximation (Wilson & Hilferty 1931, PNAS 17:684, eq. 2;
// relative error below 1 % for dof >= 10 at 2.5 % and 97.5 %). prob in {0.025, 0.95, 0.975}
// (the normal quantiles -+1.959964, 1.644854); other values throw std::invalid_argument.
double chi_square_quantile(int dof, double prob);

// RoukfOptions::refine through SteppableSimulator::with_time_step_factor(2^-level).
std::unique_ptr<model::SteppableSimulator> refine_by_time_step(const model::SteppableSimulator& s,
                                                               int level);

// 100 |theta - truth| / |truth| after the last step of each pass (rows: `passes`), NaN rows for
// passes not reached.
Eigen::MatrixXd pass_errors_percent(const RoukfSummary& summary, const Eigen::VectorXd& truth,
                                    int passes);
// First pass (1-based) whose row is finite and at most `percent` everywhere; -1 when none.
int passes_to_within(const Eigen::MatrixXd& pass_error_percent, double percent);

}  // namespace sigmaheart::estimation
