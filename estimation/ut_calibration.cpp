#include "estimation/ut_calibration.h"

#include "estimation/damping.h"
#include "estimation/enum_names.h"
#include "estimation/sensitivity/sobol_sequence.h"

#include <Eigen/Cholesky>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
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

// A number to 3 significant digits, for messages.
std::string format_number(double x) {
  std::ostringstream s;
  s.precision(3);
  s << x;
  return s.str();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
SIGMAHEART_ENUM_TEXT(UtMode, parse_ut_mode,
    {UtMode::kOneShot, "one-shot"}, {UtMode::kIterateKeepSpread, "iterate-keep-spread"},
    {UtMode::kIterateInflate, "iterate-inflate"}, {UtMode::kMap, "map"},
    {UtMode::kMap, "iterate-map"})

SIGMAHEART_ENUM_TEXT(UtFailurePolicy, parse_ut_failure_policy,
    {UtFailurePolicy::kAbort, "abort"}, {UtFailurePolicy::kShrinkAndRetry, "shrink-and-retry"})

constexpr std::array<EnumName<UtInnovation>, 3> kUtInnovationNames{{
    {UtInnovation::kAuto, "auto"}, {UtInnovation::kSigmaMean, "sigma-mean"},
    {UtInnovation::kCenter, "center"},
}};
const char* to_string(UtInnovation innovation) {
  return enum_to_string(kUtInnovationNames, innovation);
}

constexpr std::array<EnumName<UtTermination>, 10> kUtTerminationNames{{
    {UtTermination::kCompleted, "completed"}, {UtTermination::kConverged, "converged"},
    {UtTermination::kMaxIterations, "stopped at the iteration limit"},
    {UtTermination::kAbortedFailures, "aborted (failed runs)"},
    {UtTermination::kNumericalFailure, "numerical failure"},
    {UtTermination::kDiverged, "diverged (no step lowers the objective)"},
    {UtTermination::kNonFinite, "non-finite result (NaN)"},
    {UtTermination::kWorseThanPrior, "worse than the prior"},
    {UtTermination::kAtBound, "stuck at a bound"},
    {UtTermination::kOneShotNotTrusted, "one-shot update not trusted"},
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
  } else if (max_rejections < 0) {
    m << "ut calibration: max_rejections must be >= 0, got " << max_rejections;
  } else if (secant_iterations < 0) {
    m << "ut calibration: secant_iterations must be >= 0, got " << secant_iterations;
  } else if (!(bound_margin >= 0 && bound_margin < 1)) {
    m << "ut calibration: bound_margin must lie in [0, 1), got " << bound_margin;
  } else if (!(nis_alpha > 0 && nis_alpha < 0.5)) {
    m << "ut calibration: nis_alpha must lie in (0, 0.5), got " << nis_alpha;
  } else if (global_start.samples < 0 || global_start.keep < 1 ||
             (global_start.samples > 0 && global_start.keep > global_start.samples + 1)) {
    m << "ut calibration: global_start needs samples >= 0 and 1 <= keep <= samples + 1, got "
      << global_start.samples << " samples, keep " << global_start.keep;
  } else if (!(global_start.width > 0) || !std::isfinite(global_start.width)) {
    m << "ut calibration: global_start width must be > 0 prior stds, got " << global_start.width;
  } else if (!(objective_tolerance >= 0) || !std::isfinite(objective_tolerance)) {
    m << "ut calibration: objective_tolerance must be >= 0, got " << objective_tolerance;
  } else if (noise_scale && mode != UtMode::kMap) {
    m << "ut calibration: an estimated noise scale needs mode map";
  } else if (noise_scale && !noise_scale->validate().empty()) {
    m << "ut calibration: noise scale prior: " << noise_scale->validate();
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
  if (kind == Kind::kReject) {
    s << "iteration " << iteration << ", candidate " << attempt << ": ";
    if (failed_members.empty()) {
      s << "the step raised the objective (" << previous_misfit << " -> " << misfit << ")";
    } else {
      s << "the run at the candidate failed";
    }
    s << "; rejected, damping raised to lambda = " << spread_factor;
    return s.str();
  }
  if (kind == Kind::kMirror) {
    s << "iteration " << iteration << ", attempt " << attempt << ": members [" << join(failed_members)
      << "] failed; their outputs mirrored through the centre from the opposite points (one-sided slope)";
    return s.str();
  }
  if (kind == Kind::kRevert) {
    s << "iteration " << iteration << ": members [" << join(failed_members) << "] at the new centre (Phi "
      << misfit << ") failed after " << attempt << " shrink retries; the step that reached it is rejected, "
      << "back to the previous centre (Phi " << previous_misfit << "), damping raised to lambda = "
      << spread_factor;
    return s.str();
  }
  if (kind == Kind::kBacktrack) {
    s << "iteration " << iteration << ": the step raised the misfit at the new centre ("
      << previous_misfit << " -> " << misfit << "); step halved (x" << spread_factor << ")";
    return s.str();
  }
  if (kind == Kind::kShrinkAndRetry && failed_members.empty()) {  // kMap: re-linearisation
    s << "iteration " << iteration << ": no damped step lowered the objective; re-linearise at the "
      << "same centre on a spread x" << spread_factor;
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
  return termination == UtTermination::kCompleted || termination == UtTermination::kConverged;
}

std::string UtSummary::brief_report() const {
  if (!headline.empty()) return headline;
  std::ostringstream s;
  s.precision(4);
  s << "UT calibration (" << to_string(mode) << ", " << to_string(rule) << ", "
    << names.size() << " params, " << observation_names.size() << " obs): "
    << to_string(termination) << " after " << iterations.size()
    << (iterations.size() == 1 ? " iteration" : " iterations") << ", " << simulations
    << " runs, " << failures << " failed";
  if (mirrored > 0) s << " (" << mirrored << " sigma points mirrored)";
  s << ", " << actions.size() << " policy actions";
  if (fit_before && fit_after) {
    s << ", misfit " << fit_before->misfit() << " -> " << fit_after->misfit();
  }
  if (mode == UtMode::kMap) s << ", MAP objective " << objective_prior << " -> " << objective;
  if (!starts.empty()) s << ", best of " << starts.size() << " starts";
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
  for (size_t k = 0; k < starts.size(); ++k) {
    s << "  start " << k << ": " << format_theta(names, starts[k].theta_start) << " (Phi "
      << starts[k].screen_objective << ") -> Phi " << starts[k].objective << ", "
      << to_string(starts[k].termination) << "\n";
  }
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

namespace {

// Upper quantile of the chi-square distribution with k degrees of freedom at probability 1 -
// alpha: exact for k = 1 (z_(alpha/2)^2) and k = 2 (-2 ln alpha), else the Wilson-Hilferty
// cube-root normal approximation (Wilson & Hilferty 1931, PNAS 17:684: (X/k)^(1/3) ~
// N(1 - 2/(9k), 2/(9k)); 0.1 % high at k = 60, alpha = 1e-3). Normal quantiles by bisection on erfc.
double normal_upper_quantile(double alpha) {
  double lo = -40.0, hi = 40.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double chi2_upper_quantile(int k, double alpha) {
  if (k == 1) return std::pow(normal_upper_quantile(0.5 * alpha), 2);
  if (k == 2) return -2.0 * std::log(alpha);
  const double z = normal_upper_quantile(alpha);
  const double v = 2.0 / (9.0 * k);
  return k * std::pow(std::max(0.0, 1.0 - v + z * std::sqrt(v)), 3);
}

// The data misfit, the prior term and the MAP objective Phi of docs/estimation.md s.3.3. With a
// noise scale per channel (noise_scale.h) the data term is the marginal's, in whitened residuals.
struct Objective {
  Eigen::VectorXd y, r_std, eta0;
  Eigen::LLT<Eigen::MatrixXd> P0;
  Eigen::MatrixXd L;  // R = L L^T
  std::optional<NoiseScalePrior> noise;
  ChannelGroups groups;

  UtFit fit(const Eigen::VectorXd& theta, const Eigen::VectorXd& z, const model::Status& status) const {
    UtFit f;
    f.theta = theta;
    f.z = z;
    f.status = status;
    f.residual = y - z;
    f.normalised = f.residual.cwiseQuotient(r_std);
    return f;
  }
  double prior_term(const Eigen::VectorXd& eta) const {
    const Eigen::VectorXd d = eta - eta0;
    return 0.5 * d.dot(P0.solve(d));
  }
  Eigen::VectorXd whitened(const UtFit& f) const {
    return L.triangularView<Eigen::Lower>().solve(f.residual);
  }
  // NaN when the run failed.
  double data_term(const UtFit& f) const {
    return noise ? marginal_misfit(*noise, groups, whitened(f)) : f.misfit();
  }
  double phi(const UtFit& f, const Eigen::VectorXd& eta) const { return data_term(f) + prior_term(eta); }
};

Objective make_objective(const Prior& prior, const observers::ObservationSet& obs,
                         const std::optional<NoiseScalePrior>& noise) {
  return {obs.y, obs.R.diagonal().cwiseSqrt(), prior.mean_eta(),
          Eigen::LLT<Eigen::MatrixXd>(prior.covariance_eta()), Eigen::LLT<Eigen::MatrixXd>(obs.R).matrixL(),
          noise, channel_groups(obs.names)};
}

// A covariance square root, or nullopt when P is not finite or not decomposable (a numerical
// failure of the run, never an exception).
std::optional<Eigen::MatrixXd> safe_sqrt(const Eigen::MatrixXd& P, bool* used_fallback) {
  if (!P.allFinite()) return std::nullopt;
  try {
    return covariance_sqrt(P, used_fallback);
  } catch (const std::runtime_error&) {
    return std::nullopt;
  }
}

// The honest outcome of a finished local run (docs/estimation.md s.3.4), in this order: a
// non-finite estimate or fit, an estimate stuck at a bound, a fit worse than the prior's, an
// untrusted one-shot update. A run the policy or the numerics already ended keeps its termination.
void classify(UtSummary& s, const UtOptions& o, const Prior& prior, int m) {
  if (s.mode == UtMode::kOneShot) s.nis_threshold = chi2_upper_quantile(m, o.nis_alpha);
  const bool ended = s.termination == UtTermination::kAbortedFailures ||
                     s.termination == UtTermination::kNumericalFailure ||
                     s.termination == UtTermination::kDiverged;
  std::ostringstream why;
  why.precision(6);
  if (!ended) {
    const double before = s.fit_before ? s.fit_before->misfit() : kNaN;
    const double after = s.fit_after ? s.fit_after->misfit() : kNaN;
    std::ostringstream bound;
    bound.precision(6);
    for (int j = 0; j < prior.size() && bound.str().empty(); ++j) {
      const PriorParameter& par = prior[j];
      const double theta = s.theta_of_eta_mean(j);
      const double centre = s.theta_prior(j);
      const bool low = std::isfinite(par.lower) && theta - par.lower <= o.bound_margin * (centre - par.lower);
      const bool high = std::isfinite(par.upper) && par.upper - theta <= o.bound_margin * (par.upper - centre);
      if (low || high) {
        bound << par.name << " = " << theta << " " << par.unit << " is at its " << (low ? "lower" : "upper")
              << " bound " << (low ? par.lower : par.upper) << " " << par.unit << " (within "
              << o.bound_margin << " of the prior's distance to it)";
      }
    }
    if (!s.eta_mean.allFinite() || !s.theta_of_eta_mean.allFinite() ||
        (s.fit_after && !std::isfinite(after))) {
      s.termination = UtTermination::kNonFinite;
      why << "the estimate (" << format_theta(s.names, s.theta_of_eta_mean) << ") has a non-finite misfit "
          << after;
      if (s.fit_after && !s.fit_after->status.ok()) why << ": " << s.fit_after->status.message;
    } else if (!bound.str().empty()) {
      s.termination = UtTermination::kAtBound;
      why << bound.str();
    } else if (after > before) {
      s.termination = UtTermination::kWorseThanPrior;
      why << "the calibrated curves fit worse than the prior's: data misfit " << before << " -> " << after;
    } else if (s.mode == UtMode::kOneShot && !s.iterations.empty() &&
               s.iterations.front().nis > s.nis_threshold) {
      s.termination = UtTermination::kOneShotNotTrusted;
      why << "the normalised innovation squared " << s.iterations.front().nis << " exceeds the chi-square("
          << m << ") quantile " << s.nis_threshold << " at 1 - " << o.nis_alpha
          << ": the prior is far from the data, a single linear update cannot be trusted (use mode: map)";
    }
  }
  if (!why.str().empty()) {
    s.message = why.str() + (s.message.empty() ? std::string() : "; " + s.message);
  } else if (s.message.empty()) {
    why << to_string(s.termination);
    if (!s.iterations.empty()) why << " (last step " << s.iterations.back().step << " prior stds)";
    s.message = why.str();
  }
}

// kMap: a failed sigma point i whose mirror j (U_j = -U_i) ran gets the output of the straight
// line through the centre, z_i = 2 z_c - z_j. Its pair then measures a one-sided slope along that
// axis (a forward difference instead of a central one); the weights are unchanged, so U w = 0 and
// U W U^T = I still hold and A = P_tz^T P_c^-1 is exact for a linear h. Only the linearisation
// uses these outputs (the MAP iteration never takes P_zz as a covariance). False, and rec
// untouched, when some failed member has no mirror that ran (the policy then shrinks or gives up).
bool mirror_outputs(const SigmaPoints& sp, const Eigen::VectorXd& z_centre, const std::vector<int>& failed,
                    UtIteration& rec) {
  if (!z_centre.allFinite()) return false;
  std::vector<std::pair<int, int>> pairs;
  for (int i : failed) {
    int mirror = -1;
    for (int j = 0; j < sp.count() && mirror < 0; ++j) {
      const bool ran = rec.status[static_cast<size_t>(j)].ok();
      if (j != i && ran && (sp.unit.col(j) + sp.unit.col(i)).isZero(1e-12)) mirror = j;
    }
    if (mirror < 0) return false;
    pairs.emplace_back(i, mirror);
  }
  for (const auto& [i, j] : pairs) rec.Z.row(i) = (2.0 * z_centre - rec.Z.row(j).transpose()).transpose();
  return true;
}

}  // namespace

struct UtCalibration::Start {
  Eigen::VectorXd eta;             // where the run begins
  std::optional<UtFit> fit;        // the model there, when already run
  std::optional<UtFit> prior_fit;  // the model at the prior mean, when already run
  int max_iterations = 0;          // > 0: at most this many (a probe), else the options' count
  Eigen::VectorXd warm;            // the model's warm start at eta (with fit; empty: none)
};

UtSummary UtCalibration::run() {
  if (const std::string e = validate(); !e.empty()) throw std::invalid_argument(e);
  if (options_.global_start.samples > 0) return run_global();
  return run_local(Start{prior_.mean_eta(), std::nullopt, std::nullopt});
}

UtSummary UtCalibration::run_global() {
  const int p = prior_.size();
  const Objective objective = make_objective(prior_, observations_, options_.noise_scale);
  const UtGlobalStart& g = options_.global_start;
  // Row 0: the prior mean; rows 1..N: Sobol' points 2..N+1 mapped to eta0 + width sigma0 (2u - 1)
  // (point 0 is the box's corner, point 1 its centre, i.e. the prior mean again: screened twice,
  // it took two of the local runs).
  sensitivity::SobolSequenceOptions so;
  so.dimension = p;
  so.scrambling = sensitivity::Scrambling::kNone;
  const Eigen::MatrixXd U = sensitivity::SobolSequence(so).points(2, static_cast<std::uint64_t>(g.samples));
  const Eigen::VectorXd eta0 = prior_.mean_eta();
  const Eigen::VectorXd sigma0 = prior_.std_eta();
  Eigen::MatrixXd eta(g.samples + 1, p);
  eta.row(0) = eta0.transpose();
  for (int i = 0; i < g.samples; ++i) {
    eta.row(i + 1) = (eta0.array() + g.width * sigma0.array() * (2.0 * U.row(i).transpose().array() - 1.0))
                         .matrix()
                         .transpose();
  }
  Eigen::MatrixXd theta(eta.rows(), p);
  for (Eigen::Index i = 0; i < eta.rows(); ++i) theta.row(i) = prior_.to_theta(eta.row(i).transpose()).transpose();

  EnsembleOptions eo = options_.ensemble;
  eo.progress = [&](int done, int total) {
    if (options_.progress) options_.progress(UtProgress{-1, 0, done, total});
  };
  Ensemble ensemble(model_, eo);
  // In mode map the local runs start warm from their screened point (docs/estimation.md s.3.8).
  const bool warm_starts = options_.mode == UtMode::kMap && model_.warm_start_size() > 0;
  const EnsembleResult screen = ensemble.evaluate(theta, Eigen::VectorXd(), warm_starts);
  std::vector<UtFit> fits;
  std::vector<double> phi;
  for (Eigen::Index i = 0; i < eta.rows(); ++i) {
    fits.push_back(objective.fit(theta.row(i).transpose(), screen.Z.row(i).transpose(),
                                 screen.status[static_cast<size_t>(i)]));
    const double f = objective.phi(fits.back(), eta.row(i).transpose());
    phi.push_back(std::isfinite(f) ? f : std::numeric_limits<double>::infinity());
  }
  std::vector<int> order(phi.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return phi[static_cast<size_t>(a)] < phi[static_cast<size_t>(b)]; });

  std::optional<UtSummary> best;
  std::vector<UtStart> starts;
  int simulations = static_cast<int>(eta.rows());
  int failures = screen.failures();
  const bool probing = g.probe_iterations > 0 && g.probe_iterations < options_.max_iterations;
  // Local run k from the k-th best screened point, in its own checkpoint scope, so that its
  // members keep their keys whether the local runs go one after another or side by side.
  auto local_run = [&](int k, EnsembleOptions eo, bool report_progress) {
    const auto row = static_cast<Eigen::Index>(order[static_cast<size_t>(k)]);
    eo.checkpoint_scope = options_.ensemble.checkpoint_scope + "/local" + std::to_string(k);
    return run_local(Start{eta.row(row).transpose(), fits[static_cast<size_t>(row)], fits[0],
                           probing ? g.probe_iterations : 0,
                           warm_starts ? Eigen::VectorXd(screen.warm.row(row).transpose()) : Eigen::VectorXd()},
                     eo, report_progress);
  };
  std::vector<UtSummary> locals(static_cast<size_t>(g.keep));
  const int side_by_side = g.concurrent && ensemble.ranks() == 1 ? std::min(ensemble.workers(), g.keep) : 1;
  if (side_by_side > 1) {
    // One local run per thread (std::threads, not the WorkerPool: inside an OpenMP loop each run's
    // own ensemble team of threads / side_by_side would be a nested region of one thread), handed
    // out in order of the screen; the first failure (an interruption) stops the hand-out and is
    // rethrown once every thread has finished.
    EnsembleOptions inner = options_.ensemble;
    inner.backend = Backend::kThreads;
    inner.communicator = nullptr;
    inner.threads = std::max(1, ensemble.workers() / side_by_side);
    inner.progress = nullptr;
    std::atomic<int> next{0};
    std::atomic<bool> stop{false};
    std::mutex mutex;
    int finished = 0;
    std::vector<std::exception_ptr> errors(static_cast<size_t>(g.keep));
    auto worker = [&]() {
      for (int k = next++; k < g.keep && !stop; k = next++) {
        try {
          locals[static_cast<size_t>(k)] = local_run(k, inner, false);
        } catch (...) {
          errors[static_cast<size_t>(k)] = std::current_exception();
          stop = true;
        }
        const std::lock_guard<std::mutex> lock(mutex);
        ++finished;
        if (options_.progress && !stop) options_.progress(UtProgress{-2, 0, finished, g.keep});
      }
    };
    std::vector<std::thread> threads;
    for (int w = 0; w < side_by_side; ++w) threads.emplace_back(worker);
    for (std::thread& t : threads) t.join();
    for (const std::exception_ptr& e : errors) {
      if (e) std::rethrow_exception(e);
    }
  } else {
    for (int k = 0; k < g.keep; ++k) locals[static_cast<size_t>(k)] = local_run(k, options_.ensemble, true);
  }
  for (int k = 0; k < g.keep; ++k) {
    const auto i = static_cast<size_t>(order[static_cast<size_t>(k)]);
    const auto row = static_cast<Eigen::Index>(i);
    UtSummary& s = locals[static_cast<size_t>(k)];
    simulations += s.simulations;
    failures += s.failures;
    UtStart st;
    st.theta_start = theta.row(row).transpose();
    st.screen_objective = phi[i];
    st.objective = s.objective;
    st.termination = s.termination;
    st.iterations = static_cast<int>(s.iterations.size());
    st.simulations = s.simulations;
    st.theta = s.theta_of_eta_mean;
    for (const UtIteration& rec : s.iterations) st.objectives.push_back(rec.objective);
    st.objectives.push_back(s.objective);
    st.message = s.message;
    starts.push_back(st);
    const auto rank = [](const UtSummary& x) {
      return std::isfinite(x.objective) ? x.objective : std::numeric_limits<double>::infinity();
    };
    if (!best || rank(s) < rank(*best)) best = std::move(s);
  }
  std::string how = "best of " + std::to_string(g.keep) + " local runs";
  // The best probe goes on from where it stopped (unless it already ended for another reason than
  // its probe budget), with the full iteration count.
  if (probing && best->termination == UtTermination::kMaxIterations && best->fit_after) {
    UtSummary s = run_local(Start{best->eta_mean, best->fit_after, fits[0], 0});
    simulations += s.simulations;
    failures += s.failures;
    best = std::move(s);
    how = "the best of " + std::to_string(g.keep) + " probes of " +
          std::to_string(g.probe_iterations) + " iterations continued";
  }
  best->starts = std::move(starts);
  best->simulations = simulations;
  best->failures = failures;
  best->message += "; global start: " + std::to_string(g.samples) + " screened, " + how;
  return *best;
}

UtSummary UtCalibration::run_local(const Start& start) { return run_local(start, options_.ensemble, true); }

UtSummary UtCalibration::run_local(const Start& start, const EnsembleOptions& ensemble_opts, bool report_progress) {
  const int p = prior_.size();
  const int m = observations_.size();
  const Eigen::VectorXd& y = observations_.y;
  const Objective objective = make_objective(prior_, observations_, options_.noise_scale);
  const bool map = options_.mode == UtMode::kMap;

  UtSummary summary;
  summary.mode = options_.mode;
  summary.rule = options_.sigma.rule;
  summary.innovation = options_.innovation;
  if (summary.innovation == UtInnovation::kAuto || map) {
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
  const Eigen::VectorXd& eta0 = summary.eta_prior_mean;
  const Eigen::MatrixXd P0 = prior_.covariance_eta();

  auto to_theta = [&](const Eigen::VectorXd& eta) { return prior_.to_theta(eta); };

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
  EnsembleOptions ensemble_options = ensemble_opts;
  ensemble_options.progress = [&](int done, int total) {
    if (report_progress && options_.progress) {
      options_.progress(UtProgress{current_iteration, current_attempt, done, total});
    }
  };
  Ensemble ensemble(model_, ensemble_options);

  auto abort_with = [&](const std::string& why) {
    summary.termination = UtTermination::kAbortedFailures;
    summary.message = why;
  };
  // Warm starts (docs/estimation.md s.3.8), mode map only: every run starts from the warm start of
  // the current centre, and the runs that may become a centre hand on their own.
  const bool warm_starts = map && model_.warm_start_size() > 0;
  // One forward run (a centre or a candidate), counted and its failure recorded; from a warm start
  // `from` (empty: cold), its own written to `produce` when not null.
  auto run_one = [&](const Eigen::VectorXd& eta, int it, const Eigen::VectorXd& from = Eigen::VectorXd(),
                     Eigen::VectorXd* produce = nullptr) {
    const Eigen::VectorXd theta = to_theta(eta);
    const EnsembleResult one =
        ensemble.evaluate(Eigen::MatrixXd(theta.transpose()), from, produce != nullptr);
    if (produce) *produce = one.warm.row(0).transpose();
    summary.simulations += 1;
    summary.failures += one.failures();
    if (!one.status[0].ok()) summary.failed.push_back({it, 0, -1, theta, one.status[0]});
    return objective.fit(theta, one.Z.row(0).transpose(), one.status[0]);
  };

  auto numerical_failure = [&](int it, const std::string& what) {
    summary.termination = UtTermination::kNumericalFailure;
    summary.message = "iteration " + std::to_string(it) + ": " + what;
  };
  // The sigma points of (eta_c, P_c) with the failure policy (with z_centre, kMap: failed members
  // whose mirror point ran are mirrored first, mirror_outputs): fills rec's members; false when the
  // policy gave up or P_c has no square root (the summary then says why). With run_center the
  // centre joins the batch. With revertible (kMap at a centre reached by a step) a policy that
  // gives up does not abort: the failed members are left in gave_up and the caller rejects the step.
  std::vector<int> gave_up;
  auto sample = [&](int it, const Eigen::VectorXd& eta_c, const Eigen::MatrixXd& P_c,
                    UtIteration& rec, bool run_center, bool revertible = false,
                    const Eigen::VectorXd* z_centre = nullptr,
                    const Eigen::VectorXd& warm_from = Eigen::VectorXd()) {
    gave_up.clear();
    rec.eta_center = eta_c;
    rec.P_center = P_c;
    bool used_fallback = false;
    const std::optional<Eigen::MatrixXd> S_c = safe_sqrt(P_c, &used_fallback);
    if (!S_c) {
      numerical_failure(it, "no square root of the covariance");
      return false;
    }
    if (used_fallback) log_debug("UT iteration {}: covariance square root by eigen fallback", it);
    const Eigen::MatrixXd& S = *S_c;
    const Eigen::VectorXd theta_c = to_theta(eta_c);
    double factor = options_.sample_scale;
    for (int attempt = 0;; ++attempt) {
      current_attempt = attempt;
      const Eigen::MatrixXd eta_points = place_points(eta_c, factor * S, sp);  // p x r
      const bool with_center = run_center && !rec.center_fit;
      Eigen::MatrixXd thetas(r + (with_center ? 1 : 0), p);
      for (int i = 0; i < r; ++i) thetas.row(i) = to_theta(eta_points.col(i)).transpose();
      if (with_center) thetas.row(r) = theta_c.transpose();

      const EnsembleResult res = ensemble.evaluate(thetas, warm_from, false);
      summary.simulations += static_cast<int>(thetas.rows());
      summary.failures += res.failures();
      if (with_center) {
        const auto& st = res.status[static_cast<size_t>(r)];
        rec.center_fit = objective.fit(theta_c, res.Z.row(r).transpose(), st);
        if (!st.ok()) summary.failed.push_back({it, attempt, -1, theta_c, st});
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
      if (failed.empty()) return true;
      UtAction action;
      action.iteration = it;
      action.attempt = attempt;
      // The abort policy means what it says: the first failed member ends the run.
      const bool abort_policy = options_.failure_policy == UtFailurePolicy::kAbort;
      if (!abort_policy && z_centre && mirror_outputs(sp, *z_centre, failed, rec)) {
        action.kind = UtAction::Kind::kMirror;
        action.failed_members = failed;
        action.spread_factor = factor;
        summary.actions.push_back(action);
        summary.mirrored += static_cast<int>(failed.size());
        log_debug("UT: {}", action.describe());
        return true;
      }
      action.failed_members = failed;
      if (options_.failure_policy == UtFailurePolicy::kShrinkAndRetry &&
          attempt < options_.max_retries) {
        factor *= options_.shrink_factor;
        action.kind = UtAction::Kind::kShrinkAndRetry;
        action.spread_factor = factor;
        summary.actions.push_back(action);
        summary.retries += 1;
        log_debug("UT: {}", action.describe());
        continue;
      }
      if (revertible && !abort_policy) {
        gave_up = failed;
        return false;
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
      return false;
    }
  };

  // The statistical linearisation of rec's members in whitened units (docs/estimation.md s.3.1).
  struct Moments {
    Eigen::MatrixXd Zw, Pzz, Ptz;
    Eigen::VectorXd zbar;
  };
  auto moments = [&](const UtIteration& rec) {
    Moments mo;
    mo.Zw = Lt.solve(rec.Z.transpose());  // m x r
    mo.zbar = mo.Zw * sp.wm;
    const Eigen::MatrixXd dZ = mo.Zw.colwise() - mo.zbar;
    const Eigen::MatrixXd dE = rec.eta_members.transpose().colwise() - rec.eta_center;
    const double f2 = rec.spread_factor * rec.spread_factor;
    mo.Pzz = dZ * sp.wc.asDiagonal() * dZ.transpose() / f2;
    mo.Ptz = dE * sp.wc.asDiagonal() * dZ.transpose() / f2;
    return mo;
  };
  Eigen::VectorXd eta_last = start.eta;
  Eigen::MatrixXd P_last = P0;
  std::optional<UtFit> first_center_fit = start.fit;
  std::optional<UtFit> last_center_fit;  // kMap: the model at eta_last
  const int max_iterations = options_.mode == UtMode::kOneShot ? 1
                             : start.max_iterations > 0     ? start.max_iterations
                                                            : options_.max_iterations;

  if (map) {
    // ---- kMap: damped Gauss-Newton on statistically linearised models (file comment). ----
    Eigen::VectorXd eta_c = start.eta;
    Eigen::VectorXd warm_c = start.fit ? start.warm : Eigen::VectorXd();  // the centre's warm start
    UtFit fit_c = start.fit ? *start.fit
                            : run_one(eta_c, 0, Eigen::VectorXd(), warm_starts ? &warm_c : nullptr);
    first_center_fit = fit_c;
    double phi_c = objective.phi(fit_c, eta_c);
    const Eigen::MatrixXd P0inv = objective.P0.solve(Eigen::MatrixXd::Identity(p, p));
    Eigen::MatrixXd P_c = P0;
    double lambda = 0.0, nu = 2.0;
    // Phi = chi^2 / 2 + prior term: a decrease of 0.5 is a change of 1 in chi^2, the width of a
    // one-parameter 68 % confidence interval (Press et al. 2007, Numerical Recipes s.15.6.5).
    constexpr double kNegligibleDecrease = 0.5;
    // When no damped step lowers Phi the slope over the sigma points contradicts Phi (curvature
    // across a wide spread): the centre is re-linearised on a spread x kRelinearise (a statistical
    // linearisation tends to the Jacobian as its spread shrinks), up to kMaxRelinearisations times
    // in a row before "diverged".
    constexpr double kRelinearise = 0.25;
    constexpr int kMaxRelinearisations = 3;
    int relinearisations = 0;
    // Stationary although the linearised Phi still promises a decrease: over the last kStall
    // iterations every step was below the tolerance and together they lowered Phi by less than
    // kNegligibleDecrease. The promise is then the linearisation's, not Phi's (a kink of the
    // forward map, e.g. a valve event changing step, bounds the slope over the sigma points), and
    // damped steepest-descent steps have found no more: converged, and the message says so.
    constexpr int kStall = 5;
    std::vector<double> phi_history;  // Phi at the start of each iteration
    bool done = false;
    const double objective_limit = options_.objective_tolerance * m;
    // The valley's finishing step (docs/estimation.md s.3.3): when Phi creeps along a narrow
    // curved valley (parameters correlated at |rho| ~ 0.99) damped Gauss-Newton steps shrink
    // geometrically, each about q times the last. The centres then approach their limit like a
    // geometric series, whose remainder is q / (1 - q) times the last step (Aitken's
    // extrapolation of a linearly converging sequence; Brezinski & Redivo Zaglia 1991,
    // Extrapolation Methods, s.1.3): one run there (and at a quarter of it) instead of dozens of
    // iterations; taken only if it lowers Phi. Tried once per flat stretch, kMaxExtrapolations
    // times per run.
    constexpr double kMaxExtrapolation = 50.0;
    constexpr int kMaxExtrapolations = 5;
    bool valley_tried = false;
    // The last successful linearisation and its centre: where a rejected centre returns to.
    struct Linearisation {
      UtIteration rec;
      Eigen::VectorXd eta_c;
      UtFit fit_c;
      double phi_c;
      Eigen::MatrixXd P_c, H;
      Eigen::VectorXd g, eta_gn;
      Eigen::MatrixXd P_post;
      double lambda = 0.0, nu = 2.0;  // the damping of the step taken from this centre
      Eigen::VectorXd warm_c;         // the centre's warm start
      Eigen::MatrixXd A;              // the slope dz/deta there, whitened, before any channel weights
      Eigen::VectorXd sw;             // the channel weights' square roots per observation (1: none)
    };
    std::optional<Linearisation> lin;
    // Secant iterations (options_.secant_iterations, docs/estimation.md s.3.3.2): after an accepted
    // step whose gain ratio says the linear model held (rho >= kSecantTrust), the next slope is
    // the last one with Broyden's rank-one correction along the step, from the new centre's own
    // run: A+ = A + (dz - A d) (W d)^T / (d^T W d), W = diag(1 / sigma0^2), the update of least
    // change in the prior-scaled norm (Broyden 1965, Math Comp 19:577; in Levenberg-Marquardt:
    // Madsen, Nielsen & Tingleff 2004, "Methods for non-linear least squares problems", IMM DTU,
    // s.3.4). A candidate the secant slope proposes that Phi rejects, and every stop, is decided
    // again on sigma points at the same centre, so the estimate, its covariance and the
    // convergence claim always come from a full statistical linearisation.
    constexpr double kSecantTrust = 0.25;
    double secant_trust = 0.0;  // rho of the step that reached this centre (0: sample)
    int secant_run = 0;         // secant iterations since the last sampled one
    bool resampling = false;    // this iteration samples the centre a secant iteration stopped at
    auto finish_valley = [&](int it, UtIteration& rec) {
      const Eigen::VectorXd& e1 = summary.iterations.back().eta_center;
      const Eigen::VectorXd& e0 = summary.iterations[summary.iterations.size() - 2].eta_center;
      const Eigen::VectorXd d1 = eta_c - e1;
      const double n1 = d1.cwiseQuotient(sigma0).norm(), n0 = (e1 - e0).cwiseQuotient(sigma0).norm();
      if (!(n1 > 0)) return false;
      const double q = n0 > 0 ? n1 / n0 : 0.0;
      const double factor = valley_extrapolation_factor(q, kMaxExtrapolation);
      summary.extrapolations += 1;
      for (const double f : {factor, 0.25 * factor}) {
        const Eigen::VectorXd eta_x = eta_c + f * d1;
        Eigen::VectorXd warm_x;
        UtFit fit_x = run_one(eta_x, it, warm_c, warm_starts ? &warm_x : nullptr);
        const double phi_x = objective.phi(fit_x, eta_x);
        log_debug("UT map iteration {}: valley finishing step x{:.3g} (q {:.3g}): Phi {:.6g} -> {:.6g}", it,
                  f, q, phi_c, phi_x);
        if (std::isfinite(phi_x) && phi_x < phi_c) {
          rec.eta_mean = eta_x;
          rec.extrapolated = true;
          eta_c = eta_x;
          fit_c = std::move(fit_x);
          warm_c = std::move(warm_x);
          phi_c = phi_x;
          P_c = lin ? lin->P_post : P_c;
          relinearisations = 0;
          valley_tried = false;
          secant_trust = 0.0;  // a long extrapolation: sample the slope there
          return true;
        }
      }
      return false;
    };
    if (!fit_c.status.ok() || !std::isfinite(phi_c)) {
      summary.actions.push_back({UtAction::Kind::kAbort, 0, 0, 1.0, 0.0, 0.0, {-1}});
      abort_with("the starting point (" + format_theta(summary.names, fit_c.theta) +
                 ") failed: " + (fit_c.status.ok() ? std::string("non-finite misfit") : fit_c.status.message));
      done = true;
    }
    for (int it = 0; it < max_iterations && !done; ++it) {
      current_iteration = it;
      UtIteration rec;
      rec.iteration = it;
      rec.center_fit = fit_c;
      rec.objective = phi_c;
      if (!resampling) phi_history.push_back(phi_c);  // a centre's Phi once, however often sampled
      resampling = false;
      Eigen::MatrixXd H, P_post;
      Eigen::VectorXd g, eta_gn;
      Eigen::MatrixXd A_slope;  // m x p, whitened
      std::optional<Moments> mo;  // of the sigma points, when this iteration sampled them
      bool returned = false;    // back at the last linearised centre: sigma points here failed
      bool use_secant = lin && secant_trust >= kSecantTrust && secant_run < options_.secant_iterations;
      secant_trust = 0.0;
      if (use_secant) {
        // Only over a step of at least sample_scale standard deviations of the covariance the
        // last sigma points sampled (their own scale): over a shorter one the difference of two
        // runs is dominated by the forward model's tolerance (a periodic state to 1e-6), and the
        // corrected slope by that noise over |d|.
        const Eigen::VectorXd d = eta_c - lin->eta_c;
        const double length = std::sqrt(d.dot(Eigen::LLT<Eigen::MatrixXd>(lin->P_c).solve(d)));
        if (length >= options_.sample_scale) {
          const Eigen::VectorXd wd = d.cwiseQuotient(sigma0.cwiseProduct(sigma0));
          A_slope = lin->A + (Lt.solve(fit_c.z - lin->fit_c.z) - lin->A * d) * wd.transpose() / d.dot(wd);
        }
        use_secant = A_slope.size() > 0 && A_slope.allFinite();
        if (!use_secant) A_slope.resize(0, 0);
      }
      if (use_secant) {
        rec.secant = true;
        rec.attempts = 0;
        rec.spread_factor = 0.0;
        rec.eta_center = eta_c;
        rec.P_center = P_c;
        rec.eta_members.resize(0, p);
        rec.theta_members.resize(0, p);
        rec.Z.resize(0, m);
        ++secant_run;
      } else if (sample(it, eta_c, P_c, rec, false, lin.has_value(), &fit_c.z, warm_c)) {
        // z ~ A eta + b over the sigma points of the current posterior approximation.
        mo = moments(rec);
        A_slope = Eigen::LLT<Eigen::MatrixXd>(P_c).solve(mo->Ptz).transpose();
        secant_run = 0;
      }
      if (A_slope.size() > 0) {
        Eigen::MatrixXd A = A_slope;
        Eigen::VectorXd rw = yw - Lt.solve(fit_c.z);  // whitened residual at the centre
        const Eigen::VectorXd rw_stated = rw;
        Eigen::VectorXd sw = Eigen::VectorXd::Ones(m);
        if (options_.noise_scale) {
          // Gauss-Newton on the marginal over the channel scales: the Gaussian step with each
          // channel's rows weighted by w_c = E[1 / s_c^2 | r_c] at the centre (noise_scale.h).
          sw = observation_weights(
              noise_scale_posterior(*options_.noise_scale, objective.groups, rw), objective.groups).cwiseSqrt();
          A = sw.asDiagonal() * A;
          rw = rw.cwiseProduct(sw);
        }
        // The update from the PRIOR (eta0, P0) with this linearisation.
        const Eigen::MatrixXd Sw = A * P0 * A.transpose() + Eigen::MatrixXd::Identity(m, m);
        const Eigen::LDLT<Eigen::MatrixXd> ldlt(Sw);
        const Eigen::MatrixXd Kw = ldlt.solve(A * P0).transpose();  // p x m
        eta_gn = eta0 + Kw * (rw + A * (eta_c - eta0));
        P_post = P0 - Kw * Sw * Kw.transpose();
        P_post = 0.5 * (P_post + P_post.transpose()).eval();
        if (ldlt.info() != Eigen::Success || !eta_gn.allFinite() || !P_post.allFinite()) {
          numerical_failure(it, "the linearised update is not finite");
          break;
        }
        const Eigen::MatrixXd Sc = A * P_c * A.transpose() + Eigen::MatrixXd::Identity(m, m);
        // The moments of the linearised model over P_c (the sigma points' own for a sampled slope,
        // up to their second-order terms in z_bar and P_zz).
        rec.z_bar = fit_c.z;
        rec.innovation = L * rw_stated;
        rec.nis = rw.dot(Sc.ldlt().solve(rw));
        if (mo) {
          rec.z_bar = L * mo->zbar;
          rec.P_zz = L * mo->Pzz * L.transpose();
          rec.P_tz = mo->Ptz * L.transpose();
        } else {
          rec.P_zz = L * A_slope * P_c * A_slope.transpose() * L.transpose();
          rec.P_tz = P_c * A_slope.transpose() * L.transpose();
        }
        rec.gain = Lt.transpose().solve(Kw.transpose()).transpose();
        rec.P = P_post;
        // Levenberg-Marquardt on the linearised Phi: H d = g with H = A^T A + (1 + lambda) P0^-1.
        H = A.transpose() * A + P0inv;
        g = A.transpose() * rw - P0inv * (eta_c - eta0);
        lin = Linearisation{rec, eta_c, fit_c, phi_c, P_c, H, g, eta_gn, P_post, lambda, nu, warm_c, A_slope, sw};
      } else if (!gave_up.empty() && lin) {
        // Sigma points at this centre still fail after the shrink retries: the step that reached
        // it is rejected like a failed candidate (back to the last linearised centre, lambda
        // raised), so a failed member never aborts a run that has a centre to return to.
        UtAction action;
        action.kind = UtAction::Kind::kRevert;
        action.iteration = it;
        action.attempt = rec.attempts - 1;
        action.misfit = phi_c;
        action.previous_misfit = lin->phi_c;
        action.failed_members = gave_up;
        lambda = lin->lambda == 0.0 ? 1.0 : lin->lambda * lin->nu;
        nu = 2.0 * lin->nu;
        lin->lambda = lambda;
        lin->nu = nu;
        action.spread_factor = lambda;
        summary.actions.push_back(action);
        summary.rejected_steps += 1;
        log_debug("UT: {}", action.describe());
        eta_c = lin->eta_c;
        fit_c = lin->fit_c;
        warm_c = lin->warm_c;
        phi_c = lin->phi_c;
        P_c = lin->P_c;
        lin->rec.rejected += 1;
        rec = lin->rec;
        returned = true;
        rec.iteration = it;
        H = lin->H;
        g = lin->g;
        eta_gn = lin->eta_gn;
        P_post = lin->P_post;
      } else {
        break;
      }
      for (int candidate = 0;; ++candidate) {
        const Eigen::VectorXd d = lambda == 0.0 ? Eigen::VectorXd(eta_gn - eta_c)
                                                : Eigen::VectorXd((H + lambda * P0inv).ldlt().solve(g));
        rec.step = d.cwiseAbs().cwiseQuotient(sigma0).maxCoeff();
        rec.lambda = lambda;
        if (!d.allFinite()) {
          numerical_failure(it, "the damped step is not finite");
          done = true;
          break;
        }
        // A step made short by a large lambda after rejected candidates is not a stationary point
        // of Phi: converged only when the undamped Gauss-Newton step promises no decrease above
        // kNegligibleDecrease either (its predicted decrease g.d_gn / 2 on the linearised Phi).
        const double gn_decrease = 0.5 * g.dot(eta_gn - eta_c);
        const auto n_phi = phi_history.size();
        const bool stalled = n_phi > static_cast<size_t>(kStall) &&
                             phi_history[n_phi - 1 - kStall] - phi_c < kNegligibleDecrease &&
                             std::all_of(summary.iterations.end() - kStall, summary.iterations.end(),
                                         [&](const UtIteration& earlier) { return earlier.step < options_.tolerance; });
        // A stop is decided on sigma points: a secant iteration that would stop samples first,
        // unless it is the centre the run returned to because sigma points failed around the
        // centre after it (sampling there again would only return here: the stop stands, said).
        const bool defer_stop = rec.secant && !returned;
        const std::string secant_note =
            rec.secant ? "; on a secant slope (the sigma points after this centre failed)" : "";
        auto resample_here = [&]() {
          rec.eta_mean = eta_c;
          secant_trust = 0.0;
          resampling = true;
        };
        if (rec.step < options_.tolerance && (gn_decrease < kNegligibleDecrease || stalled)) {
          if (defer_stop) {
            resample_here();
            break;
          }
          rec.eta_mean = eta_c;
          summary.termination = UtTermination::kConverged;
          if (gn_decrease >= kNegligibleDecrease) {
            summary.message = "stationary: the last " + std::to_string(kStall) +
                              " iterations lowered Phi by " +
                              format_number(phi_history[n_phi - 1 - kStall] - phi_c) +
                              " with steps below the tolerance, where the linearised Phi promised " +
                              format_number(gn_decrease);
          }
          if (rec.secant) {
            summary.message = (summary.message.empty() ? "converged (last step " + format_number(rec.step) +
                                                             " prior stds)"
                                                       : summary.message) +
                              secant_note;
          }
          done = true;
          break;
        }
        // The objective-based stop: over the last two iterations Phi fell by less than
        // objective_tolerance per observation. Before stopping, one finishing step along the
        // valley the last steps crept down (finish_valley); if it lowers Phi the run goes on.
        if (candidate == 0 && objective_limit > 0 && n_phi >= 3 &&
            phi_history[n_phi - 3] - phi_c < objective_limit) {
          if (!valley_tried && summary.extrapolations < kMaxExtrapolations && summary.iterations.size() >= 2) {
            valley_tried = true;
            if (finish_valley(it, rec)) break;
          }
          if (defer_stop) {
            resample_here();
            break;
          }
          rec.eta_mean = eta_c;
          summary.termination = UtTermination::kConverged;
          summary.message = "objective: Phi fell by " + format_number(phi_history[n_phi - 3] - phi_c) +
                            " over the last 2 iterations (< " + format_number(options_.objective_tolerance) +
                            " per observation = " + format_number(objective_limit) + "), last step " +
                            format_number(rec.step) + " prior stds, the linearised Phi promised " +
                            format_number(gn_decrease) +
                            (summary.extrapolations > 0
                                 ? "; " + std::to_string(summary.extrapolations) + " valley finishing step(s)"
                                 : std::string()) +
                            secant_note;
          done = true;
          break;
        }
        Eigen::VectorXd step = d;
        if (options_.geodesic_acceleration) {
          // Geodesic acceleration (Transtrum & Sethna 2012, arXiv:1201.5885, eqs. 14-16; Transtrum,
          // Machta & Sethna 2011, Phys Rev E 83:036701): the second-order correction of the step
          // along the curved valley of a sloppy model, a = -(H + lambda P0^-1)^-1 A^T h_vv, with the
          // model's second directional derivative along d from one run at eta_c + delta d,
          // h_vv = (2 / delta) ((h(eta_c + delta d) - h(eta_c)) / delta - A d); the prior term is
          // quadratic and adds none. Taken as d + a / 2 while |a| <= kAcceleration x |d| / 2
          // (prior-scaled norms: the truncated expansion holds), else the plain step d.
          constexpr double kDelta = 0.1, kAcceleration = 0.75;
          UtFit fit_v = run_one(eta_c + kDelta * d, it, warm_c);
          if (fit_v.status.ok()) {
            const Eigen::VectorXd hvv =
                (2.0 / kDelta) * (Lt.solve(fit_v.z - fit_c.z) / kDelta - lin->A * d).cwiseProduct(lin->sw);
            const Eigen::VectorXd a =
                -(H + lambda * P0inv).ldlt().solve((lin->sw.asDiagonal() * lin->A).transpose() * hvv);
            const double ratio = 2.0 * a.cwiseQuotient(sigma0).norm() / d.cwiseQuotient(sigma0).norm();
            if (a.allFinite() && ratio <= kAcceleration) step = d + 0.5 * a;
          }
        }
        const Eigen::VectorXd eta_n = eta_c + step;
        current_attempt = candidate;
        Eigen::VectorXd warm_n;
        UtFit fit_n = run_one(eta_n, it, warm_c, warm_starts ? &warm_n : nullptr);
        const double phi_n = objective.phi(fit_n, eta_n);
        if (std::isfinite(phi_n) && phi_n < phi_c) {
          // Gain ratio of the actual to the predicted decrease (Nielsen 1999, eq. 2.3 update).
          const double predicted = g.dot(step) - 0.5 * step.dot(H * step);
          const double rho = predicted > 0 ? (phi_c - phi_n) / predicted : 0.0;
          lin->lambda = lambda;  // the damping of this step, raised if the step is reverted
          lin->nu = nu;
          if (lambda > 0) {
            lambda = damping_after_accepted_step(lambda, rho, 1e-3);
          }
          nu = 2.0;
          secant_trust = rho;
          rec.eta_mean = eta_n;
          eta_c = eta_n;
          fit_c = std::move(fit_n);
          warm_c = std::move(warm_n);
          phi_c = phi_n;
          P_c = P_post;
          relinearisations = 0;
          break;
        }
        UtAction action;
        action.kind = UtAction::Kind::kReject;
        action.iteration = it;
        action.attempt = candidate;
        action.misfit = phi_n;
        action.previous_misfit = phi_c;
        if (!fit_n.status.ok()) action.failed_members = {-1};
        if (rec.secant) {
          // The secant slope, not the damping, is the suspect: sample at this centre, lambda kept.
          action.spread_factor = lambda;
          summary.actions.push_back(action);
          summary.rejected_steps += 1;
          rec.rejected += 1;
          log_debug("UT: {} (secant slope: sampled again)", action.describe());
          resample_here();
          break;
        }
        lambda = lambda == 0.0 ? 1.0 : lambda * nu;
        nu *= 2.0;
        action.spread_factor = lambda;
        summary.actions.push_back(action);
        summary.rejected_steps += 1;
        rec.rejected += 1;
        log_debug("UT: {}", action.describe());
        if (rec.rejected > options_.max_rejections && relinearisations < kMaxRelinearisations) {
          ++relinearisations;
          rec.eta_mean = eta_c;
          P_c = P_c * (kRelinearise * kRelinearise);
          lambda = 0.0;
          nu = 2.0;
          UtAction relin;
          relin.iteration = it;
          relin.spread_factor = kRelinearise;
          summary.actions.push_back(relin);
          log_debug("UT: {}", relin.describe());
          break;
        }
        if (rec.rejected > options_.max_rejections) {
          rec.eta_mean = eta_c;
          summary.termination = UtTermination::kDiverged;
          summary.message = "iteration " + std::to_string(it) + ": no step lowers the MAP objective (" +
                            std::to_string(rec.rejected) + " damped candidates rejected, Phi " +
                            std::to_string(phi_c) + ")" +
                            (options_.global_start.samples == 0
                                 ? "; the slope over the sigma points contradicts Phi here: start "
                                   "elsewhere (calibration.global_start: {samples: 32, keep: 4, width: 2}) "
                                   "or sample more locally (a smaller calibration.sample_scale)"
                                 : std::string());
          done = true;
          break;
        }
      }
      log_debug("UT map iteration {}: step {:.3g} prior stds, Phi {:.6g}, lambda {:.3g}", it,
                rec.step, rec.objective, rec.lambda);
      if (rec.eta_mean.size() == 0) rec.eta_mean = eta_c;
      summary.iterations.push_back(rec);
      eta_last = eta_c;
      P_last = P_post;
      if (!done && it + 1 == max_iterations) summary.termination = UtTermination::kMaxIterations;
    }
    last_center_fit = fit_c;
    eta_last = eta_c;
  } else {
    // ---- one-shot, iterate-keep-spread, iterate-inflate ----
    Eigen::VectorXd eta_c = start.eta;
    Eigen::MatrixXd P_c = P0;
    bool stopped = false;
    // Backtracking of the iterate modes: a re-centred step that raises the data misfit at the new
    // centre is halved back towards the previous centre (up to kMaxBacktracks times, recorded as
    // actions); a step still raising it ends the run (kDiverged), never accepted.
    constexpr int kMaxBacktracks = 4;
    std::optional<UtFit> previous_center_fit;
    Eigen::VectorXd eta_previous = eta_c;

    for (int it = 0; it < max_iterations && !stopped; ++it) {
      current_iteration = it;
      UtIteration rec;
      rec.iteration = it;
      if (it == 0 && start.fit) rec.center_fit = start.fit;
      if (it > 0 && need_center && previous_center_fit && previous_center_fit->status.ok()) {
        bool diverged = false;
        for (int b = 0;; ++b) {
          UtFit fit = run_one(eta_c, it);
          const double misfit = fit.misfit();
          if (std::isfinite(misfit) && misfit <= previous_center_fit->misfit()) {
            rec.center_fit = fit;
            break;
          }
          if (b == kMaxBacktracks) {
            diverged = true;
            summary.termination = UtTermination::kDiverged;
            summary.message = "iteration " + std::to_string(it) + ": the step raised the misfit (" +
                              std::to_string(previous_center_fit->misfit()) + " -> " +
                              std::to_string(misfit) + ") after " + std::to_string(kMaxBacktracks) +
                              " halvings; the previous centre is kept";
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
        if (diverged) {
          eta_last = eta_previous;
          break;
        }
      }
      const bool accepted = sample(it, eta_c, P_c, rec, need_center);
      if (it == 0) first_center_fit = rec.center_fit;
      if (!accepted) break;
      if (summary.innovation == UtInnovation::kCenter && !rec.center_fit->status.ok()) {
        summary.actions.push_back({UtAction::Kind::kAbort, it, rec.attempts - 1, 1.0, 0.0, 0.0, {-1}});
        abort_with("iteration " + std::to_string(it) + ": the centre run (" +
                   format_theta(summary.names, to_theta(eta_c)) + ") failed: " +
                   rec.center_fit->status.message);
        break;
      }

      // The update (Marchesseau et al. 2013; docs/estimation.md s.3) in whitened observations.
      const Moments mo = moments(rec);
      const Eigen::MatrixXd Sw = mo.Pzz + Eigen::MatrixXd::Identity(m, m);
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(Sw);
      if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
          !(ldlt.vectorD().array() > 0).all()) {
        numerical_failure(it, "P_zz + R is not positive definite (a negative centre weight?)");
        break;
      }
      const Eigen::MatrixXd Kw = ldlt.solve(mo.Ptz.transpose()).transpose();  // p x m
      const Eigen::VectorXd zref_w = summary.innovation == UtInnovation::kCenter
                                         ? Eigen::VectorXd(Lt.solve(rec.center_fit->z))
                                         : mo.zbar;
      const Eigen::VectorXd innovation_w = yw - zref_w;
      const Eigen::VectorXd eta_new = eta_c + Kw * innovation_w;
      Eigen::MatrixXd P_new = P_c - Kw * Sw * Kw.transpose();
      P_new = 0.5 * (P_new + P_new.transpose()).eval();
      if (!eta_new.allFinite() || !P_new.allFinite()) {
        numerical_failure(it, "the update is not finite");
        break;
      }
      rec.z_bar = L * mo.zbar;
      rec.innovation = L * innovation_w;
      rec.nis = innovation_w.dot(ldlt.solve(innovation_w));
      rec.P_zz = L * mo.Pzz * L.transpose();
      rec.P_tz = mo.Ptz * L.transpose();
      rec.gain = Lt.transpose().solve(Kw.transpose()).transpose();  // K = Kw L^-1
      rec.eta_mean = eta_new;
      rec.P = P_new;
      rec.step = ((eta_new - eta_c).cwiseAbs().cwiseQuotient(sigma0)).maxCoeff();
      if (rec.center_fit) rec.objective = rec.center_fit->misfit();
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

  if (options_.evaluate_fit || map) {
    // The model at the prior mean (fit_before) and at the estimate (fit_after), run once each.
    const bool started_at_prior = start.eta == eta0;
    if (start.prior_fit) {
      summary.fit_before = start.prior_fit;
    } else if (started_at_prior && first_center_fit) {
      summary.fit_before = first_center_fit;
    } else {
      current_iteration = static_cast<int>(summary.iterations.size());
      summary.fit_before = run_one(eta0, current_iteration);
    }
    if (last_center_fit && last_center_fit->theta == summary.theta_of_eta_mean) {
      summary.fit_after = last_center_fit;
    } else if (summary.iterations.empty() && started_at_prior) {
      summary.fit_after = summary.fit_before;
    } else {
      current_iteration = static_cast<int>(summary.iterations.size());
      current_attempt = 0;
      summary.fit_after = run_one(eta_last, current_iteration);
    }
  }
  auto metrics_of = [&](const std::optional<UtFit>& f) {
    return f && f->z.size() == m ? fit_metrics(y, f->z, objective.r_std) : missing_fit_metrics(m);
  };
  summary.metrics_before = metrics_of(summary.fit_before);
  summary.metrics_after = metrics_of(summary.fit_after);
  if (summary.fit_before) summary.objective_prior = objective.phi(*summary.fit_before, eta0);
  if (summary.fit_after) summary.objective = objective.phi(*summary.fit_after, eta_last);
  if (options_.noise_scale && summary.fit_after && summary.fit_after->z.allFinite()) {
    summary.noise_scale = noise_scale_posterior(*options_.noise_scale, objective.groups,
                                                objective.whitened(*summary.fit_after));
  }
  classify(summary, options_, prior_, m);
  return summary;
}


}  // namespace sigmaheart::estimation
