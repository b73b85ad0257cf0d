#include "estimation/least_squares.h"

#include "estimation/enum_names.h"
#include "estimation/sensitivity/sobol_sequence.h"

#include <Eigen/Cholesky>
#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr size_t kMaxFailureMessages = 10;

// The state shared by the Ceres cost function and the driver: the ensemble, the whitened data,
// the caches of the last centre run and Jacobian, and the run counters.
class MapProblem {
 public:
  MapProblem(const ForwardModel& model, const Prior& prior,
             const observers::ObservationSet& observations, const LeastSquaresOptions& options)
      : prior_(prior),
        options_(options),
        ensemble_(model, options.ensemble),
        p_(prior.size()),
        m_(observations.size()),
        y_(observations.y),
        L_(Eigen::LLT<Eigen::MatrixXd>(observations.R).matrixL()),
        L0_(prior.sqrt_covariance_eta()),
        eta0_(prior.mean_eta()),
        step_(options.relative_step * prior.std_eta()) {}

  int p() const { return p_; }
  int m() const { return m_; }

  // Whitened data residual L^-1 (z - y) and prior residual L0^-1 (eta - eta0).
  Eigen::VectorXd data_residual(const Eigen::VectorXd& z) const {
    return L_.triangularView<Eigen::Lower>().solve(z - y_);
  }
  Eigen::VectorXd prior_residual(const Eigen::VectorXd& eta) const {
    return L0_.triangularView<Eigen::Lower>().solve(eta - eta0_);
  }
  double cost(const Eigen::VectorXd& eta, const Eigen::VectorXd& z) const {
    return 0.5 * (data_residual(z).squaredNorm() + prior_residual(eta).squaredNorm());
  }
  // L0^-1, the prior residual's Jacobian.
  Eigen::MatrixXd prior_jacobian() const {
    return L0_.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(p_, p_));
  }

  // Rows of etas through the model as one ensemble: z rows (NaN when failed) and statuses.
  EnsembleResult run(const Eigen::MatrixXd& etas) {
    Eigen::MatrixXd thetas(etas.rows(), p_);
    for (Eigen::Index r = 0; r < etas.rows(); ++r) {
      thetas.row(r) = prior_.to_theta(etas.row(r).transpose()).transpose();
    }
    EnsembleResult out = ensemble_.evaluate(thetas);
    simulations_ += static_cast<int>(etas.rows());
    for (const auto& s : out.status) {
      if (s.ok()) continue;
      ++failures_;
      last_failure_ = std::string(model::to_string(s.code)) + ": " + s.message;
      if (failure_messages_.size() < kMaxFailureMessages &&
          std::find(failure_messages_.begin(), failure_messages_.end(), last_failure_) ==
              failure_messages_.end()) {
        failure_messages_.push_back(last_failure_);
      }
    }
    return out;
  }

  // The model at eta (cached): false when the run failed.
  bool center(const Eigen::VectorXd& eta, Eigen::VectorXd& z, model::Status* status = nullptr) {
    if (!(center_eta_.size() == p_ && center_eta_ == eta)) {
      const EnsembleResult r = run(eta.transpose());
      center_eta_ = eta;
      center_z_ = r.Z.row(0).transpose();
      center_status_ = r.status[0];
    }
    z = center_z_;
    if (status) *status = center_status_;
    return center_status_.ok();
  }

  // z at eta and the whitened data Jacobian L^-1 dz/deta by finite differences (cached): centre
  // and perturbations in one ensemble. False when any of these runs failed.
  bool jacobian(const Eigen::VectorXd& eta, Eigen::VectorXd& z, Eigen::MatrixXd& J) {
    if (jacobian_eta_.size() == p_ && jacobian_eta_ == eta) {
      z = jacobian_z_;
      J = jacobian_;
      return true;
    }
    if (failed_eta_.size() == p_ && failed_eta_ == eta) return false;
    const bool need_center = !(center_eta_.size() == p_ && center_eta_ == eta);
    // Rows: [centre,] then per coordinate eta + h e_j (and eta - h e_j for central differences).
    const bool central = options_.difference == FiniteDifference::kCentral;
    const int per = central ? 2 : 1;
    const int first = need_center ? 1 : 0;
    Eigen::MatrixXd etas = eta.transpose().replicate(first + per * p_, 1);
    for (int j = 0; j < p_; ++j) {
      etas(first + per * j, j) += step_(j);
      if (central) etas(first + per * j + 1, j) -= step_(j);
    }
    const EnsembleResult res = run(etas);
    if (need_center) {
      center_eta_ = eta;
      center_z_ = res.Z.row(0).transpose();
      center_status_ = res.status[0];
    }
    if (!center_status_.ok() || res.failures() > 0) {
      failed_eta_ = eta;
      return false;
    }
    Eigen::MatrixXd dz(m_, p_);
    for (int j = 0; j < p_; ++j) {
      const Eigen::VectorXd zp = res.Z.row(first + per * j).transpose();
      dz.col(j) = central ? Eigen::VectorXd((zp - res.Z.row(first + per * j + 1).transpose()) / (2 * step_(j)))
                          : Eigen::VectorXd((zp - center_z_) / step_(j));
    }
    J = L_.triangularView<Eigen::Lower>().solve(dz);
    z = center_z_;
    if (!J.allFinite()) {
      failed_eta_ = eta;
      return false;
    }
    jacobian_eta_ = eta;
    jacobian_z_ = z;
    jacobian_ = J;
    return true;
  }

  int simulations() const { return simulations_; }
  int failures() const { return failures_; }
  const std::string& last_failure() const { return last_failure_; }
  const std::vector<std::string>& failure_messages() const { return failure_messages_; }

 private:
  const Prior& prior_;
  const LeastSquaresOptions& options_;
  Ensemble ensemble_;
  int p_, m_;
  Eigen::VectorXd y_;
  Eigen::MatrixXd L_, L0_;
  Eigen::VectorXd eta0_, step_;
  Eigen::VectorXd center_eta_, center_z_;
  model::Status center_status_;
  Eigen::VectorXd jacobian_eta_, jacobian_z_, failed_eta_;
  Eigen::MatrixXd jacobian_;
  int simulations_ = 0, failures_ = 0;
  std::string last_failure_;
  std::vector<std::string> failure_messages_;
};

// Residuals [L^-1 (h(T(eta)) - y); L0^-1 (eta - eta0)] for Ceres; a failed run returns false
// (an unsuccessful step, Ceres cost_function.h).
class MapCost final : public ceres::CostFunction {
 public:
  explicit MapCost(MapProblem& problem) : problem_(problem), prior_jacobian_(problem.prior_jacobian()) {
    set_num_residuals(problem.m() + problem.p());
    mutable_parameter_block_sizes()->push_back(problem.p());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int p = problem_.p();
    const int m = problem_.m();
    const Eigen::VectorXd eta = Eigen::Map<const Eigen::VectorXd>(parameters[0], p);
    if (!eta.allFinite()) return false;
    // The Jacobian runs with every trial point, in the same ensemble: Ceres ends the solve when
    // the Jacobian fails at a point it already accepted, so a point whose Jacobian cannot be
    // computed must be refused as a trial step. Runs for a rejected step are the price.
    Eigen::VectorXd z;
    Eigen::MatrixXd J;
    if (!problem_.jacobian(eta, z, J)) return false;
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    Eigen::Map<Eigen::VectorXd> r(residuals, m + p);
    r.head(m) = problem_.data_residual(z);
    r.tail(p) = problem_.prior_residual(eta);
    if (!r.allFinite()) return false;
    if (want_jacobian) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> out(
          jacobians[0], m + p, p);
      out.topRows(m) = J;
      out.bottomRows(p) = prior_jacobian_;
    }
    return true;
  }

 private:
  MapProblem& problem_;
  Eigen::MatrixXd prior_jacobian_;
};

class RecordIterations final : public ceres::IterationCallback {
 public:
  RecordIterations(int start, LeastSquaresSummary& summary, const LeastSquaresOptions& options)
      : start_(start), summary_(summary), options_(options) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    LsqIteration it;
    it.start = start_;
    it.iteration = s.iteration;
    it.cost = s.cost;
    it.gradient_max_norm = s.gradient_max_norm;
    it.step_norm = s.step_norm;
    it.trust_region_radius = s.trust_region_radius;
    it.step_is_successful = s.step_is_successful;
    summary_.iterations.push_back(it);
    if (options_.progress) options_.progress(it);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  int start_;
  LeastSquaresSummary& summary_;
  const LeastSquaresOptions& options_;
};

// One Ceres solve from eta_start.
LsqStart solve_from(MapProblem& problem, const Eigen::VectorXd& eta_start, int start_index,
                    const LeastSquaresOptions& options, LeastSquaresSummary& summary,
                    bool& ceres_failed, bool& iteration_limit) {
  const int p = problem.p();
  LsqStart out;
  out.eta_start = eta_start;
  out.eta_end = eta_start;
  ceres_failed = false;
  iteration_limit = false;
  {
    // Ceres reports a start it cannot evaluate through its log; say it here instead.
    Eigen::VectorXd z;
    Eigen::MatrixXd J;
    if (!problem.jacobian(eta_start, z, J)) {
      out.initial_cost = out.final_cost = kNaN;
      out.ceres_termination = "not started: the model or its Jacobian fails at the start point";
      ceres_failed = true;
      return out;
    }
  }
  std::vector<double> eta(eta_start.data(), eta_start.data() + p);
  ceres::Problem cp;
  cp.AddResidualBlock(new MapCost(problem), nullptr, eta.data());
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_QR;
  so.num_threads = 1;  // parallelism is in the ensemble of each Jacobian
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.gradient_tolerance = options.gradient_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  RecordIterations record(start_index, summary, options);
  so.callbacks.push_back(&record);
  ceres::Solver::Summary cs;
  ceres::Solve(so, &cp, &cs);

  out.eta_end = Eigen::Map<const Eigen::VectorXd>(eta.data(), p);
  out.initial_cost = cs.initial_cost;
  out.final_cost = cs.termination_type == ceres::FAILURE || cs.termination_type == ceres::USER_FAILURE
                       ? kNaN : cs.final_cost;
  out.iterations = static_cast<int>(cs.iterations.size()) - 1;
  out.ceres_termination = std::string(ceres::TerminationTypeToString(cs.termination_type)) + ": " +
                          cs.message;
  ceres_failed = cs.termination_type == ceres::FAILURE || cs.termination_type == ceres::USER_FAILURE;
  iteration_limit = cs.termination_type == ceres::NO_CONVERGENCE;
  return out;
}

// eta of the Sobol' screen points (header): the starts beside the prior mean.
Eigen::MatrixXd screen_points(const Prior& prior, const LeastSquaresOptions& options) {
  const int p = prior.size();
  sensitivity::SobolSequenceOptions so;
  so.dimension = p;
  so.seed = options.seed;
  const Eigen::MatrixXd U = sensitivity::SobolSequence(so).points(0, static_cast<std::uint64_t>(options.screen_points));
  Eigen::MatrixXd etas(U.rows(), p);
  for (int j = 0; j < p; ++j) {
    const PriorParameter& par = prior[j];
    const bool box = std::isfinite(par.lower) && std::isfinite(par.upper);
    for (Eigen::Index i = 0; i < U.rows(); ++i) {
      const double u = std::clamp(U(i, j), 1e-6, 1.0 - 1e-6);
      if (box) {
        // to_eta may refuse a bound the transform cannot reach (log with lower 0): NaN, skipped.
        try {
          etas(i, j) = par.to_eta(par.lower + u * (par.upper - par.lower));
        } catch (const std::domain_error&) {
          etas(i, j) = kNaN;
        }
      } else {
        etas(i, j) = par.mean_eta + options.screen_width * par.std_eta * (2.0 * u - 1.0);
      }
    }
  }
  return etas;
}

std::vector<Eigen::VectorXd> pick_starts(MapProblem& problem, const Prior& prior,
                                         const LeastSquaresOptions& options) {
  std::vector<Eigen::VectorXd> starts{prior.mean_eta()};
  if (options.screen_points <= 0) return starts;
  const Eigen::MatrixXd etas = screen_points(prior, options);
  std::vector<Eigen::Index> usable;
  for (Eigen::Index i = 0; i < etas.rows(); ++i) {
    if (etas.row(i).allFinite()) usable.push_back(i);
  }
  Eigen::MatrixXd run_etas(static_cast<Eigen::Index>(usable.size()), prior.size());
  for (size_t k = 0; k < usable.size(); ++k) run_etas.row(static_cast<Eigen::Index>(k)) = etas.row(usable[k]);
  const EnsembleResult res = problem.run(run_etas);
  std::vector<std::pair<double, Eigen::Index>> ranked;
  for (Eigen::Index k = 0; k < run_etas.rows(); ++k) {
    if (!res.status[static_cast<size_t>(k)].ok()) continue;
    const double F = problem.cost(run_etas.row(k).transpose(), res.Z.row(k).transpose());
    if (std::isfinite(F)) ranked.emplace_back(F, k);
  }
  std::sort(ranked.begin(), ranked.end());  // ties by index: deterministic
  for (size_t k = 0; k < ranked.size() && static_cast<int>(k) < options.starts; ++k) {
    starts.push_back(run_etas.row(ranked[k].second).transpose());
  }
  return starts;
}

// Parameters within the bound tolerance of a finite bound (LeastSquaresOptions::bound_tolerance).
std::vector<std::string> parameters_at_bound(const Prior& prior, const Eigen::VectorXd& theta,
                                             const Eigen::VectorXd& theta_prior_std,
                                             double tolerance) {
  std::vector<std::string> out;
  for (int j = 0; j < prior.size(); ++j) {
    const PriorParameter& par = prior[j];
    const bool box = std::isfinite(par.lower) && std::isfinite(par.upper);
    auto near = [&](double bound) {
      if (!std::isfinite(bound)) return false;
      const double scale = box ? par.upper - par.lower : std::max(std::abs(bound), theta_prior_std(j));
      return std::abs(theta(j) - bound) <= tolerance * scale;
    };
    // A log transform with lower bound 0 approaches 0 only as eta -> -inf: that counts too.
    if (near(par.lower) || near(par.upper)) out.push_back(par.name);
  }
  return out;
}

// The final Gauss-Newton step (header): taken when its predicted decrease 0.5 g^T H^-1 g is at
// or below the function tolerance of F, where Ceres can no longer measure progress by the cost,
// and the model runs at the new point. Updates eta and cost; true when taken.
bool polish(MapProblem& problem, const LeastSquaresOptions& options, Eigen::VectorXd& eta,
            double& cost) {
  Eigen::VectorXd z;
  Eigen::MatrixXd J;
  if (!problem.jacobian(eta, z, J)) return false;
  const Eigen::MatrixXd Jp = problem.prior_jacobian();
  const Eigen::VectorXd g = J.transpose() * problem.data_residual(z) + Jp.transpose() * problem.prior_residual(eta);
  const Eigen::MatrixXd H = J.transpose() * J + Jp.transpose() * Jp;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  if (ldlt.info() != Eigen::Success) return false;
  const Eigen::VectorXd step = -ldlt.solve(g);
  const double predicted = -0.5 * g.dot(step);
  if (!step.allFinite() || !(predicted >= 0) || predicted > options.function_tolerance * cost) return false;
  const Eigen::VectorXd next = eta + step;
  Eigen::VectorXd z_next;
  if (!problem.center(next, z_next)) return false;
  const double c = problem.cost(next, z_next);
  if (!std::isfinite(c)) return false;
  eta = next;
  cost = c;
  return true;
}

UtFit make_fit(const observers::ObservationSet& obs, const Eigen::VectorXd& theta,
               const Eigen::VectorXd& z, const model::Status& status) {
  UtFit fit;
  fit.theta = theta;
  fit.z = z;
  fit.status = status;
  fit.residual = obs.y - z;
  fit.normalised = fit.residual.cwiseQuotient(obs.R.diagonal().cwiseSqrt());
  return fit;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

}  // namespace

SIGMAHEART_ENUM_TEXT(FiniteDifference, parse_finite_difference,
    {FiniteDifference::kForward, "forward"}, {FiniteDifference::kCentral, "central"})

constexpr std::array<EnumName<LsqTermination>, 6> kLsqTerminationNames{{
    {LsqTermination::kConverged, "converged"}, {LsqTermination::kMaxIterations, "max iterations"},
    {LsqTermination::kNoConvergence, "no convergence"}, {LsqTermination::kNonFinite, "non-finite"},
    {LsqTermination::kWorseThanPrior, "worse than prior"}, {LsqTermination::kAtBound, "at bound"},
}};
const char* to_string(LsqTermination termination) {
  return enum_to_string(kLsqTerminationNames, termination);
}

std::string LeastSquaresOptions::validate() const {
  std::ostringstream s;
  if (max_iterations < 1) {
    s << "least squares: max_iterations must be >= 1, got " << max_iterations;
  } else if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0)) {
    s << "least squares: tolerances must be >= 0";
  } else if (!(relative_step > 0 && relative_step <= 0.1)) {
    s << "least squares: relative_step must lie in (0, 0.1], got " << relative_step;
  } else if (screen_points < 0 || starts < 0) {
    s << "least squares: screen_points and starts must be >= 0, got " << screen_points << " and "
      << starts;
  } else if (!(screen_width > 0) || !std::isfinite(screen_width)) {
    s << "least squares: screen_width must be > 0, got " << screen_width;
  } else if (!(bound_tolerance >= 0 && bound_tolerance < 0.5)) {
    s << "least squares: bound_tolerance must lie in [0, 0.5), got " << bound_tolerance;
  } else {
    return ensemble.validate();
  }
  return s.str();
}

std::string validate_map_problem(const ForwardModel& model, const Prior& prior,
                                 const observers::ObservationSet& observations) {
  const std::string who = "least squares: ";
  if (prior.size() == 0) return who + "no parameters to estimate";
  if (const std::string e = prior.validate(); !e.empty()) return who + e;
  const auto inputs = model.input_names();
  if (inputs.size() != prior.parameters.size()) {
    return who + std::to_string(prior.size()) + " parameters but the forward model takes " +
           std::to_string(inputs.size());
  }
  for (int j = 0; j < prior.size(); ++j) {
    if (prior[j].kind != PriorKind::kGaussian) {
      return who + "parameter '" + prior[j].name + "' needs a Gaussian prior";
    }
    if (prior[j].name != inputs[static_cast<size_t>(j)]) {
      return who + "parameter " + std::to_string(j) + " is '" + prior[j].name +
             "' but the forward model's input is '" + inputs[static_cast<size_t>(j)] + "'";
    }
  }
  if (const std::string e = observations.validate(); !e.empty()) return who + e;
  std::vector<std::string> outputs;
  for (const auto& c : model.outputs()) outputs.push_back(c.name);
  if (outputs != observations.names) {
    return who + "the observations (" + join(observations.names) +
           ") are not the forward model's outputs in order (" + join(outputs) + ")";
  }
  return {};
}

std::string LeastSquaresSummary::brief_report() const {
  std::ostringstream s;
  s.precision(4);
  int its = 0;
  if (best_start >= 0 && best_start < static_cast<int>(starts.size())) {
    its = starts[static_cast<size_t>(best_start)].iterations;
  }
  s << "MAP least squares (" << names.size() << " params, " << observation_names.size() << " obs, "
    << starts.size() << (starts.size() == 1 ? " start" : " starts") << "): "
    << to_string(termination) << " after " << its << " iterations, " << simulations << " runs, "
    << failures << " failed, cost " << prior_cost << " -> " << cost;
  return s.str();
}

LeastSquaresSummary solve_map(const ForwardModel& model, const Prior& prior,
                              const observers::ObservationSet& observations,
                              const LeastSquaresOptions& options) {
  if (std::string e = validate_map_problem(model, prior, observations); !e.empty()) {
    throw std::invalid_argument(e);
  }
  if (std::string e = options.validate(); !e.empty()) throw std::invalid_argument(e);
  const int p = prior.size();
  const int m = observations.size();

  LeastSquaresSummary summary;
  summary.names = prior.names();
  summary.observation_names = observations.names;
  summary.eta_prior_mean = prior.mean_eta();
  summary.eta_prior_std = prior.std_eta();
  summary.theta_prior = prior.to_theta(summary.eta_prior_mean);
  const Eigen::VectorXd theta_prior_std = prior.prior_theta_std();

  MapProblem problem(model, prior, observations, options);
  auto finish_counts = [&] {
    summary.simulations = problem.simulations();
    summary.failures = problem.failures();
    summary.failure_messages = problem.failure_messages();
  };

  // The model at the prior mean: the reference every fit is judged against.
  Eigen::VectorXd z_prior;
  Eigen::MatrixXd J_prior;
  model::Status prior_status;
  problem.jacobian(summary.eta_prior_mean, z_prior, J_prior);  // the first Ceres evaluation, cached
  problem.center(summary.eta_prior_mean, z_prior, &prior_status);
  summary.fit_prior = make_fit(observations, summary.theta_prior, z_prior, prior_status);
  summary.prior_cost = prior_status.ok() ? problem.cost(summary.eta_prior_mean, z_prior) : kNaN;
  summary.metrics_prior = prior_status.ok()
                              ? fit_metrics(observations.y, z_prior, observations.R.diagonal().cwiseSqrt())
                              : missing_fit_metrics(m);

  // Starts and solves; the lowest finite final cost wins (ties: the earlier start).
  const std::vector<Eigen::VectorXd> starts = pick_starts(problem, prior, options);
  std::vector<char> failed(starts.size()), limited(starts.size());
  summary.best_start = -1;
  for (size_t k = 0; k < starts.size(); ++k) {
    bool f = false, l = false;
    summary.starts.push_back(solve_from(problem, starts[k], static_cast<int>(k), options, summary, f, l));
    failed[k] = f;
    limited[k] = l;
    const double c = summary.starts.back().final_cost;
    if (std::isfinite(c) &&
        (summary.best_start < 0 || c < summary.starts[static_cast<size_t>(summary.best_start)].final_cost)) {
      summary.best_start = static_cast<int>(k);
    }
  }

  if (summary.best_start < 0) {
    // No start produced a finite cost: report the prior mean, the Ceres reasons and the failures.
    summary.best_start = 0;
    summary.eta = summary.eta_prior_mean;
    summary.theta = summary.theta_prior;
    summary.cost = kNaN;
    summary.eta_covariance = prior.covariance_eta();
    summary.eta_std = summary.eta_prior_std;
    summary.theta_std = theta_prior_std;
    summary.metrics_estimate = missing_fit_metrics(m);
    summary.termination = LsqTermination::kNoConvergence;
    summary.message = "no start converged: " + summary.starts[0].ceres_termination;
    if (!problem.last_failure().empty()) summary.message += "; last failed run: " + problem.last_failure();
    finish_counts();
    return summary;
  }

  const LsqStart& best = summary.starts[static_cast<size_t>(summary.best_start)];
  summary.eta = best.eta_end;
  summary.theta = prior.to_theta(summary.eta);
  summary.cost = best.final_cost;
  summary.polished = !failed[static_cast<size_t>(summary.best_start)] &&
                     polish(problem, options, summary.eta, summary.cost);
  summary.theta = prior.to_theta(summary.eta);

  // Laplace covariance at the estimate.
  Eigen::VectorXd z;
  Eigen::MatrixXd J;
  const bool have_jacobian = problem.jacobian(summary.eta, z, J);
  model::Status estimate_status;
  problem.center(summary.eta, z, &estimate_status);
  summary.fit_estimate = make_fit(observations, summary.theta, z, estimate_status);
  summary.metrics_estimate = estimate_status.ok()
                                 ? fit_metrics(observations.y, z, observations.R.diagonal().cwiseSqrt())
                                 : missing_fit_metrics(m);
  summary.jacobian = have_jacobian ? J : Eigen::MatrixXd::Constant(m, p, kNaN);
  const Eigen::MatrixXd P0inv = prior.covariance_eta().inverse();
  Eigen::MatrixXd H = summary.jacobian.transpose() * summary.jacobian + P0inv;
  H = 0.5 * (H + H.transpose());
  Eigen::LLT<Eigen::MatrixXd> llt(H);
  if (have_jacobian && llt.info() == Eigen::Success) {
    summary.eta_covariance = llt.solve(Eigen::MatrixXd::Identity(p, p));
  } else {
    summary.eta_covariance = Eigen::MatrixXd::Constant(p, p, kNaN);
  }
  summary.eta_std = summary.eta_covariance.diagonal().cwiseSqrt();
  summary.theta_std = prior.theta_std(summary.eta, summary.eta_std);
  summary.at_bound = parameters_at_bound(prior, summary.theta, theta_prior_std, options.bound_tolerance);
  finish_counts();

  // Termination, the most serious first.
  std::ostringstream msg;
  msg.precision(6);
  const size_t b = static_cast<size_t>(summary.best_start);
  if (failed[b]) {
    summary.termination = LsqTermination::kNoConvergence;
    msg << "Ceres stopped without convergence (" << best.ceres_termination << ")";
    if (!problem.last_failure().empty()) msg << "; last failed run: " << problem.last_failure();
  } else if (!std::isfinite(summary.cost) || !summary.theta.allFinite() ||
             !summary.eta_covariance.allFinite()) {
    summary.termination = LsqTermination::kNonFinite;
    msg << "non-finite " << (!std::isfinite(summary.cost) ? "cost" : !summary.theta.allFinite()
                                                                     ? "estimate"
                                                                     : "covariance (model failed at the estimate or J^T J + P0^-1 singular)");
  } else if (!summary.at_bound.empty()) {
    summary.termination = LsqTermination::kAtBound;
    msg << "the estimate sits on a bound of " << join(summary.at_bound)
        << ": the data pull outside the allowed range; the covariance there is not a posterior";
  } else if (std::isfinite(summary.prior_cost) && summary.cost > summary.prior_cost) {
    summary.termination = LsqTermination::kWorseThanPrior;
    msg << "the estimate's cost " << summary.cost << " is above the prior mean's "
        << summary.prior_cost;
  } else if (limited[b]) {
    summary.termination = LsqTermination::kMaxIterations;
    msg << "iteration limit (" << options.max_iterations << ") reached before convergence";
  } else {
    summary.termination = LsqTermination::kConverged;
    msg << "converged (" << best.ceres_termination << ")";
  }
  msg << "; RMS residual " << summary.metrics_prior.rms_normalised_residual << " -> "
      << summary.metrics_estimate.rms_normalised_residual << " noise std";
  summary.message = msg.str();
  return summary;
}

UtSummary as_calibration_summary(const LeastSquaresSummary& m) {
  UtSummary s;
  switch (m.termination) {
    case LsqTermination::kConverged: s.termination = UtTermination::kConverged; break;
    case LsqTermination::kMaxIterations: s.termination = UtTermination::kMaxIterations; break;
    case LsqTermination::kNoConvergence: s.termination = UtTermination::kDiverged; break;
    case LsqTermination::kNonFinite: s.termination = UtTermination::kNonFinite; break;
    case LsqTermination::kWorseThanPrior: s.termination = UtTermination::kWorseThanPrior; break;
    case LsqTermination::kAtBound: s.termination = UtTermination::kAtBound; break;
  }
  s.message = m.message;
  s.headline = m.brief_report();
  s.mode = UtMode::kMap;
  s.names = m.names;
  s.observation_names = m.observation_names;
  s.eta_prior_mean = m.eta_prior_mean;
  s.eta_prior_std = m.eta_prior_std;
  s.theta_prior = m.theta_prior;
  s.eta_mean = m.eta;
  s.eta_covariance = m.eta_covariance;
  s.eta_std = m.eta_std;
  s.theta_of_eta_mean = m.theta;
  s.theta_sigma_mean = m.theta;  // no sigma points: the point estimate
  s.theta_std = m.theta_std;
  s.theta_sigma_std = m.theta_std;
  s.fit_before = m.fit_prior;
  s.fit_after = m.fit_estimate;
  s.metrics_before = m.metrics_prior;
  s.metrics_after = m.metrics_estimate;
  s.simulations = m.simulations;
  s.failures = m.failures;
  s.objective_prior = m.prior_cost;
  s.objective = m.cost;
  return s;
}

}  // namespace sigmaheart::estimation
