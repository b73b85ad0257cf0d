#include "estimation/ut_calibration.h"

#include "estimation/enum_names.h"

#include <Eigen/Cholesky>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace sigmaheart::estimation {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

template <class... Args>
void log_debug(const char* format, Args&&... args) {
  if (auto logger = spdlog::get("sigmaheart.estimation")) {
    logger->debug(fmt::runtime(format), std::forward<Args>(args)...);
  }
}

std::string join(const std::vector<int>& v) {
  std::ostringstream s;
  for (size_t i = 0; i < v.size(); ++i) s << (i ? ", " : "") << v[i];
  return s.str();
}

std::string format_theta(const std::vector<std::string>& names, const Eigen::VectorXd& theta) {
  std::ostringstream s;
  s.precision(6);
  for (Eigen::Index j = 0; j < theta.size(); ++j) {
    s << (j ? ", " : "") << names[static_cast<size_t>(j)] << " = " << theta(j);
  }
  return s.str();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
constexpr std::array<EnumName<UtMode>, 3> kUtModeNames{{
    {UtMode::kOneShot, "one-shot"}, {UtMode::kIterateKeepSpread, "iterate-keep-spread"},
    {UtMode::kIterateInflate, "iterate-inflate"},
}};
const char* to_string(UtMode mode) { return enum_to_string(kUtModeNames, mode); }
std::optional<UtMode> parse_ut_mode(const std::string& text) {
  return enum_from_string(kUtModeNames, text);
}

constexpr std::array<EnumName<UtFailurePolicy>, 2> kUtFailurePolicyNames{{
    {UtFailurePolicy::kAbort, "abort"}, {UtFailurePolicy::kShrinkAndRetry, "shrink-and-retry"},
}};
const char* to_string(UtFailurePolicy policy) {
  return enum_to_string(kUtFailurePolicyNames, policy);
}
std::optional<UtFailurePolicy> parse_ut_failure_policy(const std::string& text) {
  return enum_from_string(kUtFailurePolicyNames, text);
}

constexpr std::array<EnumName<UtInnovation>, 3> kUtInnovationNames{{
    {UtInnovation::kAuto, "auto"}, {UtInnovation::kSigmaMean, "sigma-mean"},
    {UtInnovation::kCenter, "center"},
}};
const char* to_string(UtInnovation innovation) {
  return enum_to_string(kUtInnovationNames, innovation);
}

constexpr std::array<EnumName<UtTermination>, 5> kUtTerminationNames{{
    {UtTermination::kCompleted, "completed"}, {UtTermination::kConverged, "converged"},
    {UtTermination::kMaxIterations, "max iterations"},
    {UtTermination::kAbortedFailures, "aborted (failed runs)"},
    {UtTermination::kNumericalFailure, "numerical failure"},
}};
const char* to_string(UtTermination termination) {
  return enum_to_string(kUtTerminationNames, termination);
}

std::string UtOptions::validate(int p) const {
  if (const std::string s = sigma.validate(p); !s.empty()) return s;
  std::ostringstream m;
  if (max_iterations < 1) {
    m << "ut calibration: max_iterations must be >= 1, got " << max_iterations;
  } else if (!(tolerance >= 0) || !std::isfinite(tolerance)) {
    m << "ut calibration: tolerance must be >= 0, got " << tolerance;
  } else if (!(inflation >= 1) || !std::isfinite(inflation)) {
    m << "ut calibration: inflation must be >= 1, got " << inflation;
  } else if (!(sample_scale > 0 && sample_scale <= 1)) {
    m << "ut calibration: sample_scale must lie in (0, 1], got " << sample_scale;
  } else if (!(shrink_factor > 0 && shrink_factor < 1)) {
    m << "ut calibration: shrink_factor must lie in (0, 1), got " << shrink_factor;
  } else if (max_retries < 0) {
    m << "ut calibration: max_retries must be >= 0, got " << max_retries;
  } else {
    return ensemble.validate();
  }
  return m.str();
}

double UtFit::misfit() const {
  if (!status.ok() || normalised.size() == 0) return kNaN;
  return 0.5 * normalised.squaredNorm();
}

std::string UtAction::describe() const {
  std::ostringstream s;
  if (kind == Kind::kBacktrack) {
    s << "iteration " << iteration << ": the step raised the misfit at the new centre ("
      << previous_misfit << " -> " << misfit << "); step halved (x" << spread_factor << ")";
    return s.str();
  }
  s << "iteration " << iteration << ", attempt " << attempt << ": members [" << join(failed_members)
    << "] failed; ";
  if (kind == Kind::kShrinkAndRetry) {
    s << "shrink the spread to " << spread_factor << " (x the sampled std) and re-sample";
  } else {
    s << "abort";
  }
  return s.str();
}

bool UtSummary::ok() const {
  return termination == UtTermination::kCompleted || termination == UtTermination::kConverged ||
         termination == UtTermination::kMaxIterations;
}

std::string UtSummary::brief_report() const {
  std::ostringstream s;
  s.precision(4);
  s << "UT calibration (" << to_string(mode) << ", " << to_string(rule) << ", "
    << names.size() << " params, " << observation_names.size() << " obs): "
    << to_string(termination) << " after " << iterations.size()
    << (iterations.size() == 1 ? " iteration" : " iterations") << ", " << simulations
    << " runs, " << failures << " failed, " << actions.size() << " policy actions";
  if (fit_before && fit_after) {
    s << ", misfit " << fit_before->misfit() << " -> " << fit_after->misfit();
  }
  return s.str();
}

std::string UtSummary::full_report() const {
  std::ostringstream s;
  s.precision(5);
  s << brief_report() << "\n" << message << "\n";
  for (size_t j = 0; j < names.size(); ++j) {
    const auto k = static_cast<Eigen::Index>(j);
    s << "  " << names[j] << ": eta " << eta_prior_mean(k) << " +- " << eta_prior_std(k) << " -> "
      << eta_mean(k) << " +- " << eta_std(k) << "; theta = T(eta mean) " << theta_of_eta_mean(k)
      << " +- " << theta_std(k) << " (delta), sigma-point mean " << theta_sigma_mean(k) << " +- "
      << theta_sigma_std(k) << "\n";
  }
  if (fit_before && fit_after) {
    for (size_t i = 0; i < observation_names.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      s << "  " << observation_names[i] << ": y " << fit_before->z(k) + fit_before->residual(k)
        << ", z before " << fit_before->z(k) << " (" << fit_before->normalised(k)
        << " sd), after " << fit_after->z(k) << " (" << fit_after->normalised(k) << " sd)\n";
    }
  }
  for (const auto& a : actions) s << "  policy: " << a.describe() << "\n";
  return s.str();
}

// ---------------------------------------------------------------------------------------------
UtCalibration::UtCalibration(const ForwardModel& model, Prior prior,
                             observers::ObservationSet observations, UtOptions options)
    : model_(model),
      prior_(std::move(prior)),
      observations_(std::move(observations)),
      options_(std::move(options)) {}

std::string UtCalibration::validate() const {
  const int p = prior_.size();
  if (p == 0) return "ut calibration: no parameters to estimate";
  if (p != model_.input_size()) {
    std::ostringstream s;
    s << "ut calibration: " << p << " parameters but the forward model takes "
      << model_.input_size();
    return s.str();
  }
  const auto inputs = model_.input_names();
  if (const std::string e = prior_.validate(); !e.empty()) return "ut calibration: " + e;
  for (int j = 0; j < p; ++j) {
    const auto& par = prior_[j];
    if (par.kind != PriorKind::kGaussian) {
      return "ut calibration: parameter '" + par.name + "' needs a Gaussian prior";
    }
    if (par.name != inputs[static_cast<size_t>(j)]) {
      return "ut calibration: parameter " + std::to_string(j) + " is '" + par.name +
             "' but the forward model's input is '" + inputs[static_cast<size_t>(j)] + "'";
    }
  }
  if (const std::string e = observations_.validate(); !e.empty()) return e;
  const auto outputs = model_.outputs();
  if (outputs.size() != observations_.names.size()) {
    std::ostringstream s;
    s << "ut calibration: " << observations_.names.size() << " observations but the forward model "
      << "produces " << outputs.size();
    return s.str();
  }
  for (size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].name != observations_.names[i]) {
      return "ut calibration: observation " + std::to_string(i) + " is '" +
             observations_.names[i] + "' but the forward model's output is '" + outputs[i].name +
             "' (ObservationSet::select reorders)";
    }
  }
  if (options_.truth && options_.truth->size() != p) {
    return "ut calibration: the truth has " + std::to_string(options_.truth->size()) +
           " values for " + std::to_string(p) + " parameters";
  }
  return options_.validate(p);
}

UtSummary UtCalibration::run() {
  if (const std::string e = validate(); !e.empty()) throw std::invalid_argument(e);
  const int p = prior_.size();
  const int m = observations_.size();
  const Eigen::VectorXd& y = observations_.y;

  UtSummary summary;
  summary.mode = options_.mode;
  summary.rule = options_.sigma.rule;
  summary.innovation = options_.innovation;
  if (summary.innovation == UtInnovation::kAuto) {
    summary.innovation = options_.mode == UtMode::kOneShot ? UtInnovation::kSigmaMean
                                                           : UtInnovation::kCenter;
  }
  summary.observation_names = observations_.names;
  summary.names = prior_.names();
  summary.eta_prior_mean = prior_.mean_eta();
  summary.eta_prior_std = prior_.std_eta();
  summary.theta_prior = prior_.nominal_theta();
  summary.theta_prior_std = prior_.prior_theta_std();
  const Eigen::VectorXd& sigma0 = summary.eta_prior_std;
  const Eigen::MatrixXd P0 = prior_.covariance_eta();

  auto to_theta = [&](const Eigen::VectorXd& eta) { return prior_.to_theta(eta); };
  // A covariance square root, or nullopt when P is not finite or not decomposable (a numerical
  // failure of the run, never an exception).
  auto safe_sqrt = [](const Eigen::MatrixXd& P, bool* used_fallback) -> std::optional<Eigen::MatrixXd> {
    if (!P.allFinite()) return std::nullopt;
    try {
      return covariance_sqrt(P, used_fallback);
    } catch (const std::runtime_error&) {
      return std::nullopt;
    }
  };
  const Eigen::VectorXd r_std = observations_.R.diagonal().cwiseSqrt();
  auto make_fit = [&](const Eigen::VectorXd& theta, const Eigen::VectorXd& z,
                      const model::Status& status) {
    UtFit fit;
    fit.theta = theta;
    fit.z = z;
    fit.status = status;
    fit.residual = y - z;
    fit.normalised = fit.residual.cwiseQuotient(r_std);
    return fit;
  };

  // Whitening: R = L L^T; every observation-space quantity below is in L^-1 units.
  const Eigen::MatrixXd L = Eigen::LLT<Eigen::MatrixXd>(observations_.R).matrixL();
  const auto Lt = L.triangularView<Eigen::Lower>();
  const Eigen::VectorXd yw = Lt.solve(y);

  const SigmaPoints sp = make_sigma_points(p, options_.sigma);
  const int r = sp.count();
  const bool need_center =
      options_.evaluate_fit || summary.innovation == UtInnovation::kCenter;

  int current_iteration = 0;
  int current_attempt = 0;
  EnsembleOptions ensemble_options = options_.ensemble;
  ensemble_options.progress = [&](int done, int total) {
    if (options_.progress) {
      options_.progress(UtProgress{current_iteration, current_attempt, done, total});
    }
  };
  Ensemble ensemble(model_, ensemble_options);

  auto abort_with = [&](const std::string& why) {
    summary.termination = UtTermination::kAbortedFailures;
    summary.message = why;
  };

  Eigen::VectorXd eta_c = summary.eta_prior_mean;
  Eigen::MatrixXd P_c = P0;
  Eigen::VectorXd eta_last = eta_c;
  Eigen::MatrixXd P_last = P0;
  std::optional<UtFit> first_center_fit;
  const int max_iterations = options_.mode == UtMode::kOneShot ? 1 : options_.max_iterations;
  bool stopped = false;

  // Backtracking of the iterate modes: a re-centred step that raises the data misfit at the new
  // centre is halved back towards the previous centre (up to kMaxBacktracks times, recorded as
  // actions). Without it the keep-spread iteration, a Levenberg-Marquardt-like step damped by the
  // prior covariance, can cycle between two points on a curved misfit (seen on the lumped heart).
  constexpr int kMaxBacktracks = 4;
  std::optional<UtFit> previous_center_fit;
  Eigen::VectorXd eta_previous = eta_c;

  for (int it = 0; it < max_iterations && !stopped; ++it) {
    current_iteration = it;
    UtIteration rec;
    rec.iteration = it;
    if (it > 0 && need_center && options_.mode != UtMode::kOneShot && previous_center_fit &&
        previous_center_fit->status.ok()) {
      for (int b = 0;; ++b) {
        const Eigen::VectorXd theta_try = to_theta(eta_c);
        const EnsembleResult one = ensemble.evaluate(Eigen::MatrixXd(theta_try.transpose()));
        summary.simulations += 1;
        summary.failures += one.failures();
        UtFit fit = make_fit(theta_try, one.Z.row(0).transpose(), one.status[0]);
        const double misfit = fit.misfit();
        if ((std::isfinite(misfit) && misfit <= previous_center_fit->misfit()) ||
            b == kMaxBacktracks) {
          rec.center_fit = fit;
          break;
        }
        UtAction action;
        action.kind = UtAction::Kind::kBacktrack;
        action.iteration = it;
        action.attempt = b;
        action.spread_factor = std::ldexp(1.0, -(b + 1));
        action.misfit = misfit;
        action.previous_misfit = previous_center_fit->misfit();
        summary.actions.push_back(action);
        log_debug("UT: {}", action.describe());
        eta_c = eta_previous + 0.5 * (eta_c - eta_previous);
      }
    }
    rec.eta_center = eta_c;
    rec.P_center = P_c;
    bool used_fallback = false;
    const std::optional<Eigen::MatrixXd> S_c = safe_sqrt(P_c, &used_fallback);
    if (!S_c) {
      summary.termination = UtTermination::kNumericalFailure;
      summary.message = "iteration " + std::to_string(it) + ": no square root of the covariance";
      break;
    }
    const Eigen::MatrixXd& S = *S_c;
    if (used_fallback) log_debug("UT iteration {}: covariance square root by eigen fallback", it);
    const Eigen::VectorXd theta_c = to_theta(eta_c);

    double factor = options_.sample_scale;
    bool accepted = false;
    for (int attempt = 0;; ++attempt) {
      current_attempt = attempt;
      const Eigen::MatrixXd eta_points = place_points(eta_c, factor * S, sp);  // p x r
      const bool run_center = need_center && !rec.center_fit;
      Eigen::MatrixXd thetas(r + (run_center ? 1 : 0), p);
      for (int i = 0; i < r; ++i) thetas.row(i) = to_theta(eta_points.col(i)).transpose();
      if (run_center) thetas.row(r) = theta_c.transpose();

      const EnsembleResult res = ensemble.evaluate(thetas);
      summary.simulations += static_cast<int>(thetas.rows());
      summary.failures += res.failures();
      if (run_center) {
        rec.center_fit = make_fit(theta_c, res.Z.row(r).transpose(), res.status[static_cast<size_t>(r)]);
        if (!res.status[static_cast<size_t>(r)].ok()) {
          summary.failed.push_back({it, attempt, -1, theta_c, res.status[static_cast<size_t>(r)]});
        }
      }
      std::vector<int> failed;
      for (int i = 0; i < r; ++i) {
        if (!res.status[static_cast<size_t>(i)].ok()) {
          failed.push_back(i);
          summary.failed.push_back(
              {it, attempt, i, thetas.row(i).transpose(), res.status[static_cast<size_t>(i)]});
        }
      }
      rec.eta_members = eta_points.transpose();
      rec.theta_members = thetas.topRows(r);
      rec.Z = res.Z.topRows(r);
      rec.status.assign(res.status.begin(), res.status.begin() + r);
      rec.attempts = attempt + 1;
      rec.spread_factor = factor;
      if (failed.empty()) {
        accepted = true;
        break;
      }
      UtAction action;
      action.iteration = it;
      action.attempt = attempt;
      action.failed_members = failed;
      if (options_.failure_policy == UtFailurePolicy::kShrinkAndRetry &&
          attempt < options_.max_retries) {
        factor *= options_.shrink_factor;
        action.kind = UtAction::Kind::kShrinkAndRetry;
        action.spread_factor = factor;
        summary.actions.push_back(action);
        log_debug("UT: {}", action.describe());
        continue;
      }
      action.kind = UtAction::Kind::kAbort;
      action.spread_factor = factor;
      summary.actions.push_back(action);
      std::ostringstream why;
      why << "iteration " << it << ": " << failed.size() << " of " << r
          << " sigma-point runs failed";
      if (options_.failure_policy == UtFailurePolicy::kShrinkAndRetry) {
        why << " after " << attempt << " shrink retries";
      }
      for (int i : failed) {
        why << "; member " << i << " (" << format_theta(summary.names, thetas.row(i).transpose())
            << "): " << model::to_string(res.status[static_cast<size_t>(i)].code) << ": "
            << res.status[static_cast<size_t>(i)].message;
      }
      abort_with(why.str());
      break;
    }
    if (it == 0) first_center_fit = rec.center_fit;
    if (!accepted) break;
    if (summary.innovation == UtInnovation::kCenter && !rec.center_fit->status.ok()) {
      UtAction action;
      action.kind = UtAction::Kind::kAbort;
      action.iteration = it;
      action.attempt = rec.attempts - 1;
      action.failed_members = {-1};
      summary.actions.push_back(action);
      abort_with("iteration " + std::to_string(it) + ": the centre run (" +
                 format_theta(summary.names, theta_c) + ") failed: " +
                 rec.center_fit->status.message);
      break;
    }

    // The update (Marchesseau et al. 2013; docs/estimation.md s.3) in whitened observations.
    const Eigen::MatrixXd Zw = Lt.solve(rec.Z.transpose());  // m x r
    const Eigen::VectorXd zbar_w = Zw * sp.wm;
    const Eigen::MatrixXd dZ = Zw.colwise() - zbar_w;
    const Eigen::MatrixXd dE = rec.eta_members.transpose().colwise() - eta_c;
    const double f2 = rec.spread_factor * rec.spread_factor;
    const Eigen::MatrixXd Pzz_w = dZ * sp.wc.asDiagonal() * dZ.transpose() / f2;
    const Eigen::MatrixXd Ptz_w = dE * sp.wc.asDiagonal() * dZ.transpose() / f2;
    const Eigen::MatrixXd Sw = Pzz_w + Eigen::MatrixXd::Identity(m, m);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(Sw);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
        !(ldlt.vectorD().array() > 0).all()) {
      summary.termination = UtTermination::kNumericalFailure;
      summary.message = "iteration " + std::to_string(it) +
                        ": P_zz + R is not positive definite (a negative centre weight?)";
      break;
    }
    const Eigen::MatrixXd Kw = ldlt.solve(Ptz_w.transpose()).transpose();  // p x m
    const Eigen::VectorXd zref_w = summary.innovation == UtInnovation::kCenter
                                       ? Eigen::VectorXd(Lt.solve(rec.center_fit->z))
                                       : zbar_w;
    const Eigen::VectorXd innovation_w = yw - zref_w;
    const Eigen::VectorXd eta_new = eta_c + Kw * innovation_w;
    Eigen::MatrixXd P_new = P_c - Kw * Sw * Kw.transpose();
    P_new = 0.5 * (P_new + P_new.transpose()).eval();
    if (!eta_new.allFinite() || !P_new.allFinite()) {
      summary.termination = UtTermination::kNumericalFailure;
      summary.message = "iteration " + std::to_string(it) + ": the update is not finite";
      break;
    }
    rec.z_bar = L * zbar_w;
    rec.innovation = L * innovation_w;
    rec.nis = innovation_w.dot(ldlt.solve(innovation_w));
    rec.P_zz = L * Pzz_w * L.transpose();
    rec.P_tz = Ptz_w * L.transpose();
    rec.gain = Lt.transpose().solve(Kw.transpose()).transpose();  // K = Kw L^-1
    rec.eta_mean = eta_new;
    rec.P = P_new;
    rec.step = ((eta_new - eta_c).cwiseAbs().cwiseQuotient(sigma0)).maxCoeff();
    log_debug("UT iteration {}: step {:.3g} prior stds, NIS {:.4g}", it, rec.step, rec.nis);
    summary.iterations.push_back(rec);
    eta_last = eta_new;
    P_last = P_new;

    if (options_.mode == UtMode::kOneShot) {
      summary.termination = UtTermination::kCompleted;
      stopped = true;
    } else if (rec.step < options_.tolerance) {
      summary.termination = UtTermination::kConverged;
      stopped = true;
    } else if (it + 1 == max_iterations) {
      summary.termination = UtTermination::kMaxIterations;
      stopped = true;
    }
    previous_center_fit = rec.center_fit;
    eta_previous = eta_c;
    eta_c = eta_new;
    P_c = options_.mode == UtMode::kIterateInflate ? Eigen::MatrixXd(options_.inflation * P_new)
                                                   : P0;
  }

  // Estimates: eta, and the two theta "means" (transform of the mean vs sigma-point mean).
  summary.eta_mean = eta_last;
  summary.eta_covariance = P_last;
  summary.eta_std = P_last.diagonal().cwiseMax(0.0).cwiseSqrt();
  summary.theta_of_eta_mean = to_theta(eta_last);
  summary.theta_std = prior_.theta_std(eta_last, summary.eta_std);
  if (const std::optional<Eigen::MatrixXd> S_last = safe_sqrt(P_last, nullptr)) {
    const Eigen::MatrixXd post = place_points(eta_last, *S_last, sp);
    Eigen::MatrixXd theta_post(p, r);
    for (int i = 0; i < r; ++i) theta_post.col(i) = to_theta(post.col(i));
    summary.theta_sigma_mean = theta_post * sp.wm;
    const Eigen::MatrixXd dT = theta_post.colwise() - summary.theta_sigma_mean;
    summary.theta_sigma_std =
        (dT.array().square().matrix() * sp.wc).cwiseMax(0.0).cwiseSqrt();
  } else {
    summary.theta_sigma_mean = Eigen::VectorXd::Constant(p, kNaN);
    summary.theta_sigma_std = Eigen::VectorXd::Constant(p, kNaN);
  }
  if (options_.truth) {
    summary.truth_error_percent = relative_errors_percent(summary.theta_of_eta_mean, *options_.truth);
  }

  if (options_.evaluate_fit) {
    summary.fit_before = first_center_fit;
    if (summary.iterations.empty()) {
      summary.fit_after = first_center_fit;
    } else {
      current_iteration = static_cast<int>(summary.iterations.size());
      current_attempt = 0;
      const EnsembleResult res = ensemble.evaluate(summary.theta_of_eta_mean.transpose());
      summary.simulations += 1;
      summary.failures += res.failures();
      summary.fit_after = make_fit(summary.theta_of_eta_mean, res.Z.row(0).transpose(), res.status[0]);
      if (!res.status[0].ok()) {
        summary.failed.push_back({current_iteration, 0, -1, summary.theta_of_eta_mean, res.status[0]});
      }
    }
  }
  auto metrics_of = [&](const std::optional<UtFit>& f) {
    return f && f->z.size() == m ? fit_metrics(y, f->z, r_std) : missing_fit_metrics(m);
  };
  summary.metrics_before = metrics_of(summary.fit_before);
  summary.metrics_after = metrics_of(summary.fit_after);
  if (summary.message.empty()) {
    std::ostringstream s;
    s << to_string(summary.termination);
    if (!summary.iterations.empty()) {
      s << " (last step " << summary.iterations.back().step << " prior stds)";
    }
    summary.message = s.str();
  }
  return summary;
}

}  // namespace sigmaheart::estimation
