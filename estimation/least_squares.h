// Reference MAP / least-squares calibration with Ceres Solver (docs/estimation.md s.11): the
// point the UT calibration approximates, computed by a trust-region Gauss-Newton method.
//
// In the unconstrained coordinates eta of each parameter's Transform (transform.h), minimise
//   F(eta) = 0.5 ||L^-1 (y - h(T(eta)))||^2 + 0.5 ||L0^-1 (eta - eta0)||^2,
// R = L L^T the observation noise, P0 = L0 L0^T the prior covariance in eta (prior.h). This is the
// negative log posterior up to a constant (Tarantola 2005, Inverse Problem Theory and Methods
// for Model Parameter Estimation, s.3.2, the misfit function S(m), in whitened form), solved as one least-squares problem of m + p residuals: the data residuals and
// the prior residuals r_p = L0^-1 (eta - eta0) (Jacobian L0^-1, exact).
//
// Jacobian of h(T(eta)) by finite differences in eta, step h_j = relative_step * std_eta_j (the
// prior spread sets the scale of each coordinate): central (2p runs, O(h^2)) or forward (p runs),
// run as ONE Ensemble (ensemble.h) together with the centre, so threads and ranks are used as in
// the UT and the numbers do not depend on them. A failed run in the Jacobian or at a trial point
// makes Evaluate return false: Ceres treats the step as unsuccessful and shrinks the trust region
// (Ceres, cost_function.h); it is never a crash. The centre run and the last Jacobian are cached
// by eta, so Ceres' residual-then-Jacobian calls at an accepted point cost no second run.
//
// Bounds hold by construction: Prior::validate() (prior.h) accepts a bounded Gaussian parameter
// only with a transform whose range lies inside its bounds (logit, or log with lower bound <= 0),
// so every eta Ceres tries maps into the bounds and no Ceres parameter bounds are needed. A
// simulator whose own bounds are narrower fails the run (kOutOfBounds): an unsuccessful step.
// An estimate within bound_tolerance of a bound (logit eta -> +-inf) ends as kAtBound.
//
// Ceres stops on the function tolerance where the change of F, quadratic in the distance to the
// minimum, is lost in round-off while the gradient is still measurable (on a linear problem
// 2e-7 posterior std from the minimum). One Gauss-Newton step eta -= H^-1 g (H = J^T J + P0^-1,
// g the gradient of F) finishes the solve when its predicted decrease is at or below
// function_tolerance * F and the model runs there (LeastSquaresSummary::polished).
//
// After the solve: the Laplace covariance (J^T J + P0^-1)^-1 in eta (J the whitened data Jacobian
// at the estimate; the Gauss-Newton inverse Hessian of F, Tarantola 2005 s.3.3 "Estimating
// posterior uncertainties"), the delta-method theta std |T'(eta)| std_eta, and
// the fit at the estimate and at the prior mean.
//
// Multi-start (optional): `screen_points` points of a scrambled Sobol' sequence over the bounds
// (theta uniform in [lower, upper] when both are finite, else eta0 +- screen_width std_eta) are
// evaluated as one ensemble; the prior mean and the `starts` screen points of lowest F start a
// solve each; the lowest final F wins.
//
// Input errors throw std::invalid_argument (validate()); forward-model failures and numerical
// trouble end in a LsqTermination, never an exception. MPI: every rank calls solve_map() with the
// same inputs and gets the same summary.
#pragma once

#include "estimation/ensemble.h"
#include "estimation/fit_metrics.h"
#include "estimation/prior.h"
#include "estimation/ut_calibration.h"
#include "observers/observer.h"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

enum class FiniteDifference { kForward, kCentral };
const char* to_string(FiniteDifference difference);
std::optional<FiniteDifference> parse_finite_difference(const std::string& text);  // "forward", "central"

struct LsqIteration {
  int start = 0;                // which start (0 = the prior mean)
  int iteration = 0;            // Ceres' iteration number (0 = the start point)
  double cost = 0.0;            // F(eta) [1]
  double gradient_max_norm = 0.0;
  double step_norm = 0.0;       // in eta
  double trust_region_radius = 0.0;
  bool step_is_successful = false;
};

struct LeastSquaresOptions {
  int max_iterations = 50;              // per start (Ceres max_num_iterations)
  // Ceres: |dF| / F below this stops. dF is quadratic in the distance to the minimum, so this
  // leaves the estimate up to about sqrt(2 tol F) posterior std away; the final Gauss-Newton step
  // (header) removes that.
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;    // Ceres: max-norm of the projected gradient
  double parameter_tolerance = 1e-10;   // Ceres: |d eta| / (|eta| + tol)
  FiniteDifference difference = FiniteDifference::kCentral;
  double relative_step = 1e-4;          // h_j = relative_step * std_eta_j, in (0, 0.1]
  int screen_points = 0;                // Sobol' screen size (0: start at the prior mean only)
  int starts = 1;                       // best screen points started from (with the prior mean)
  double screen_width = 3.0;            // unbounded coordinates: eta0 +- width std_eta
  std::uint64_t seed = 0;               // of the scrambled Sobol' screen
  // A parameter whose estimate lies within bound_tolerance * (upper - lower) of a finite bound
  // (one finite bound: bound_tolerance * max(|bound|, prior theta std)) is "at a bound": the data
  // pull it outside.
  double bound_tolerance = 1e-6;
  EnsembleOptions ensemble;             // backend, threads, communicator
  // Called after every Ceres iteration (from the calling thread).
  std::function<void(const LsqIteration&)> progress;
  std::string validate() const;         // empty when valid
};

enum class LsqTermination {
  kConverged,         // a Ceres tolerance was met
  kMaxIterations,     // iteration limit of the best start
  kNoConvergence,     // Ceres failed (e.g. the model fails at the start point)
  kNonFinite,         // non-finite cost, estimate or covariance
  kWorseThanPrior,    // F at the estimate above F at the prior mean
  kAtBound,           // the estimate sits on a parameter bound
};
const char* to_string(LsqTermination termination);

struct LsqStart {
  Eigen::VectorXd eta_start;
  Eigen::VectorXd eta_end;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;
  std::string ceres_termination;        // Ceres' own TerminationType and message
};

struct LeastSquaresSummary {
  LsqTermination termination = LsqTermination::kNoConvergence;
  std::string message;                  // how it ended, in words
  std::vector<std::string> names;       // parameters
  std::vector<std::string> observation_names;

  Eigen::VectorXd eta_prior_mean, eta_prior_std;
  Eigen::VectorXd theta_prior;          // T(eta prior mean)
  Eigen::VectorXd eta;                  // MAP estimate
  Eigen::VectorXd theta;                // T(eta)
  Eigen::MatrixXd eta_covariance;       // Laplace (J^T J + P0^-1)^-1
  Eigen::VectorXd eta_std;
  Eigen::VectorXd theta_std;            // delta method |T'(eta)| eta_std
  Eigen::MatrixXd jacobian;             // whitened data Jacobian L^-1 dh/deta at the estimate (m x p)

  double cost = 0.0;                    // F at the estimate
  double prior_cost = 0.0;              // F at the prior mean
  bool polished = false;                // the final Gauss-Newton step was taken
  std::optional<UtFit> fit_estimate;    // the model at theta
  std::optional<UtFit> fit_prior;       // the model at T(eta0)
  FitMetrics metrics_estimate, metrics_prior;
  std::vector<std::string> at_bound;    // parameters on a bound

  std::vector<LsqStart> starts;         // in the order run (0 = prior mean)
  int best_start = 0;
  std::vector<LsqIteration> iterations; // every start's iterations
  int simulations = 0;                  // forward runs, Jacobians and screen included
  int failures = 0;                     // failed forward runs
  std::vector<std::string> failure_messages;  // distinct messages, first 10

  bool ok() const { return termination == LsqTermination::kConverged; }
  // One line, e.g. "MAP least squares (3 params, 60 obs, central differences): converged after 7
  // iterations, 52 runs, 0 failed, cost 812.4 -> 31.2".
  std::string brief_report() const;
};

// prior: one Gaussian parameter per ForwardModel input, same names and order; observations: the
// model's outputs, same names and order. Throws std::invalid_argument for inconsistent input.
LeastSquaresSummary solve_map(const ForwardModel& model, const Prior& prior,
                              const observers::ObservationSet& observations,
                              const LeastSquaresOptions& options = {});

// The MAP summary in the shape the calibration writers take (app/io/calibration_h5.h): the
// estimate, its Laplace spread (for both theta "means" and stds), the fits, the counts, and the
// termination mapped to its UtTermination (converged, iteration limit, diverged for Ceres'
// failure, non-finite, worse than the prior, stuck at a bound); headline = brief_report().
UtSummary as_calibration_summary(const LeastSquaresSummary& summary);

// Empty when the problem is consistent (sizes, names, Gaussian prior, valid R), else a message.
std::string validate_map_problem(const ForwardModel& model, const Prior& prior,
                                 const observers::ObservationSet& observations);

}  // namespace sigmaheart::estimation
