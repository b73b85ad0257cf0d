#include "estimation/roukf/roukf.h"

#include "estimation/channel_noise_scale.h"
#include "estimation/damping.h"
#include "estimation/enum_names.h"
#include "estimation/fit_metrics.h"
#include "estimation/roukf/steppable_forward_model.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

SIGMAHEART_ENUM_TEXT(RoukfFailurePolicy, parse_roukf_failure_policy,
    {RoukfFailurePolicy::kRetryThenSkip, "retry-then-skip"},
    {RoukfFailurePolicy::kSkipWithInflation, "skip"}, {RoukfFailurePolicy::kAbort, "abort"})

SIGMAHEART_ENUM_TEXT(RoukfPassMode, parse_roukf_pass_mode,
    {RoukfPassMode::kRepeat, "repeat"}, {RoukfPassMode::kSplit, "split"})

constexpr std::array<EnumName<RoukfTermination>, 7> kRoukfTerminationNames{{
    {RoukfTermination::kCompleted, "completed"}, {RoukfTermination::kMemberFailed, "member failed"},
    {RoukfTermination::kCancelled, "cancelled"}, {RoukfTermination::kInvalidInput, "invalid input"},
    {RoukfTermination::kNumericalFailure, "numerical failure"},
    {RoukfTermination::kEstimateOutOfBounds, "estimate out of bounds"},
    {RoukfTermination::kMapNotConverged, "MAP refinement not converged"},
}};
const char* to_string(RoukfTermination t) { return enum_to_string(kRoukfTerminationNames, t); }

std::string RoukfData::validate() const {
  std::ostringstream s;
  if (channels.empty()) return "RoukfData: no observed channels";
  if (times.size() == 0) return "RoukfData: no frame times";
  if (values.rows() != times.size() ||
      values.cols() != static_cast<Eigen::Index>(channels.size())) {
    s << "RoukfData: values is " << values.rows() << " x " << values.cols() << ", expected "
      << times.size() << " frames x " << channels.size() << " channels";
    return s.str();
  }
  for (Eigen::Index k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times(k))) return "RoukfData: non-finite frame time";
    if (k > 0 && !(times(k) > times(k - 1))) {
      s << "RoukfData: frame times must increase strictly (frame " << k << ")";
      return s.str();
    }
  }
  for (Eigen::Index k = 0; k < values.size(); ++k) {
    if (std::isinf(values.data()[k])) return "RoukfData: infinite value (use NaN for missing)";
  }
  return {};
}

std::string RoukfOptions::validate() const {
  std::ostringstream s;
  if (R.rows() != R.cols() || R.rows() == 0) return "roukf: R must be a non-empty square matrix";
  if (!R.allFinite() || (R - R.transpose()).cwiseAbs().maxCoeff() > 1e-12 * R.cwiseAbs().maxCoeff()) {
    return "roukf: R must be finite and symmetric";
  }
  if (Eigen::LLT<Eigen::MatrixXd>(R).info() != Eigen::Success) {
    return "roukf: R must be positive definite";
  }
  if (beats < 1) return "roukf: beats must be >= 1";
  if (beats > 1 && pass_mode == RoukfPassMode::kRepeat && !(period > 0 && std::isfinite(period))) {
    return "roukf: period must be positive when beats > 1";
  }
  if (sigma_rule == SigmaRule::kScaled) {
    return "roukf: the scaled sigma rule has unequal mean and covariance weights; use simplex, "
           "canonical or star";
  }
  if (!(forgetting > 0.0 && forgetting <= 1.0)) return "roukf: forgetting must lie in (0, 1]";
  if (!(sigma_scale > 0.0 && sigma_scale <= 1.0)) return "roukf: sigma_scale must lie in (0, 1]";
  if (!(tempering >= 0.0 && std::isfinite(tempering))) return "roukf: tempering must be >= 0";
  if (max_subupdates < 1) return "roukf: max_subupdates must be >= 1";
  if (!(first_fraction > 0.0 && first_fraction <= 1.0)) return "roukf: first_fraction must lie in (0, 1]";
  if (!(pass_growth > 0.0 && std::isfinite(pass_growth))) return "roukf: pass_growth must be positive";
  if (map_iterations < 0) return "roukf: map_iterations must be >= 0";
  if (noise_scale) {
    if (const std::string e = noise_scale->validate(); !e.empty()) return "roukf: noise scale prior: " + e;
    if (pass_mode != RoukfPassMode::kSplit || map_iterations == 0) {
      return "roukf: an estimated noise scale needs split passes and the MAP refinement (map_iterations > 0)";
    }
  }
  if (!(map_tolerance > 0.0 && std::isfinite(map_tolerance))) return "roukf: map_tolerance must be positive";
  if (!(map_objective_tolerance >= 0.0 && std::isfinite(map_objective_tolerance))) {
    return "roukf: map_objective_tolerance must be >= 0";
  }
  if (max_retries < 0) return "roukf: max_retries must be >= 0";
  if (!(shrink > 0 && shrink < 1)) return "roukf: shrink must lie in (0, 1)";
  if (!(inflation >= 0 && std::isfinite(inflation))) return "roukf: inflation must be >= 0";
  if (const std::string e = ensemble.validate(); !e.empty()) return "roukf: " + e;
  return {};
}

namespace {

struct MemberOutcome {
  model::Status status;
  std::vector<RoukfAction> actions;
  int retries = 0;
};

std::string describe_theta(const model::ParameterSpace& space, const Eigen::VectorXd& theta,
                           const std::vector<int>& estimated) {
  std::ostringstream s;
  s << std::setprecision(6);
  for (size_t j = 0; j < estimated.size(); ++j) {
    const auto& q = space[estimated[j]];
    s << (j ? ", " : "") << q.name << " = " << theta(estimated[j]) << " " << q.unit;
  }
  return s.str();
}

// "name = value unit outside [lower, upper]" for every estimated parameter outside its simulator
// bounds; empty when all are inside.
std::string out_of_bounds(const model::ParameterSpace& space, const Eigen::VectorXd& theta,
                          const std::vector<int>& estimated) {
  std::ostringstream s;
  s << std::setprecision(6);
  for (int i : estimated) {
    const auto& q = space[i];
    if (theta(i) >= q.lower && theta(i) <= q.upper) continue;
    s << (s.tellp() > 0 ? "; " : "") << q.name << " = " << theta(i) << " " << q.unit
      << " outside [" << q.lower << ", " << q.upper << "]";
  }
  return s.str();
}

// Log-determinant of an SPD matrix from its Cholesky factor.
double log_det(const Eigen::LLT<Eigen::MatrixXd>& llt) {
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

// RoukfSummary::truth_z, truth_d2 and truth_d2_limit for a run that has an estimate.
void truth_consistency(RoukfSummary& summary, const Prior& prior, const Eigen::VectorXd& truth) {
  const Eigen::Index p = truth.size();
  if (!summary.has_estimate() || summary.eta.size() != p || summary.eta_covariance.rows() != p) return;
  Eigen::VectorXd e(p);
  for (Eigen::Index i = 0; i < p; ++i) {
    e(i) = summary.eta(i) - prior.parameters[static_cast<size_t>(i)].to_eta(truth(i));
  }
  summary.truth_z = e.cwiseQuotient(summary.eta_covariance.diagonal().cwiseSqrt());
  const Eigen::LLT<Eigen::MatrixXd> llt(summary.eta_covariance);
  if (llt.info() == Eigen::Success && e.allFinite()) {
    summary.truth_d2 = e.dot(llt.solve(e));
    summary.truth_d2_limit = chi_square_quantile(static_cast<int>(p), 0.95);
  }
}

}  // namespace

RoukfSummary run_roukf(const model::SteppableSimulator& simulator, const Prior& prior,
                       const RoukfData& data, const RoukfOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  RoukfSummary summary;
  auto finish = [&](RoukfTermination t, std::string message) -> RoukfSummary& {
    summary.termination = t;
    summary.message = std::move(message);
    summary.nis_frames = 0;
    summary.nis_dof = 0;
    double nis_sum = 0.0;
    if (options.pass_mode == RoukfPassMode::kSplit) {
      // Per-step NIS of a split pass use R / phi_b: the check is the whole-data statistic.
      summary.nis_source = "whole data at the estimate (2 x MAP objective)";
      if (summary.map_frames > 0) {
        summary.nis_frames = summary.map_frames;
        summary.nis_dof = summary.map_dof;
        nis_sum = summary.map_statistic;
      }
    } else {
      summary.nis_source = "sequential innovations";
      for (const auto& st : summary.steps) {
        if (st.observed == 0) continue;
        ++summary.nis_frames;
        summary.nis_dof += st.observed;
        nis_sum += st.nis;
      }
    }
    if (summary.nis_frames > 0) {
      summary.nis_mean = nis_sum / summary.nis_frames;
      summary.nis_band_lower = chi_square_quantile(summary.nis_dof, 0.025) / summary.nis_frames;
      summary.nis_band_upper = chi_square_quantile(summary.nis_dof, 0.975) / summary.nis_frames;
    }
    if (summary.has_estimate() && summary.eta_covariance.rows() == prior.size()) {
      summary.std_ratio = summary.eta_covariance.diagonal().cwiseMax(0.0).cwiseSqrt().cwiseQuotient(prior.std_eta());
    }
    if (options.truth && t != RoukfTermination::kInvalidInput) {
      const int passes = summary.pass_fractions.empty() ? options.beats
                                                        : static_cast<int>(summary.pass_fractions.size());
      summary.pass_error_percent = pass_errors_percent(summary, *options.truth, passes);
      summary.passes_to_within_10_percent = passes_to_within(summary.pass_error_percent, 10.0);
      if (summary.has_estimate()) summary.error_percent = relative_errors_percent(summary.theta, *options.truth);
      truth_consistency(summary, prior, *options.truth);
    }
    summary.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    return summary;
  };

  // ---- Up-front checks (tier 2: bad input reported before any work).
  if (std::string e = prior.validate(); !e.empty()) return finish(RoukfTermination::kInvalidInput, "roukf: " + e);
  for (const auto& q : prior.parameters) {
    if (q.kind != PriorKind::kGaussian) {
      return finish(RoukfTermination::kInvalidInput, "roukf: parameter " + q.name + " needs a Gaussian prior");
    }
  }
  if (std::string e = options.validate(); !e.empty()) return finish(RoukfTermination::kInvalidInput, e);
  if (options.truth && options.truth->size() != prior.size()) {
    return finish(RoukfTermination::kInvalidInput, "roukf: the truth has the wrong size");
  }
  if (std::string e = data.validate(); !e.empty()) return finish(RoukfTermination::kInvalidInput, e);
  if (options.R.rows() != static_cast<Eigen::Index>(data.channels.size())) {
    return finish(RoukfTermination::kInvalidInput,
                  "roukf: R is " + std::to_string(options.R.rows()) + " x " +
                      std::to_string(options.R.cols()) + " but " +
                      std::to_string(data.channels.size()) + " channels are observed");
  }
  if (options.beats > 1 && options.pass_mode == RoukfPassMode::kRepeat &&
      !(data.times(data.times.size() - 1) < data.times(0) + options.period)) {
    return finish(RoukfTermination::kInvalidInput,
                  "roukf: the frames span more than one period; repeated passes would overlap");
  }
  const model::ParameterSpace& space = simulator.parameters();
  const int p = prior.size();
  std::vector<int> estimated;
  for (const auto& q : prior.parameters) {
    const auto idx = space.index(q.name);
    if (!idx) {
      const std::string near = model::closest_match(q.name, space.names());
      return finish(RoukfTermination::kInvalidInput,
                    "roukf: unknown parameter '" + q.name + "'" +
                        (near.empty() ? "" : " (did you mean '" + near + "'?)"));
    }
    estimated.push_back(*idx);
    summary.parameter_names.push_back(q.name);
  }
  std::vector<int> observed_channels;
  {
    const auto all = simulator.channels();
    std::vector<std::string> names;
    for (const auto& c : all) names.push_back(c.name);
    for (const auto& c : data.channels) {
      int found = -1;
      for (size_t i = 0; i < names.size(); ++i) {
        if (names[i] == c) found = static_cast<int>(i);
      }
      if (found < 0) {
        const std::string near = model::closest_match(c, names);
        return finish(RoukfTermination::kInvalidInput,
                      "roukf: the simulator has no channel '" + c + "'" +
                          (near.empty() ? "" : " (did you mean '" + near + "'?)"));
      }
      observed_channels.push_back(found);
    }
  }
  Eigen::VectorXd base = options.base_theta.size() ? options.base_theta : space.nominal();
  if (base.size() != space.size()) {
    return finish(RoukfTermination::kInvalidInput, "roukf: base_theta has the wrong size");
  }
  const SigmaPoints sp = make_sigma_points(p, SigmaOptions{options.sigma_rule, options.star_kappa});
  if ((sp.wm - sp.wc).cwiseAbs().maxCoeff() > 1e-14) {
    return finish(RoukfTermination::kInvalidInput,
                  "roukf: the sigma rule must have equal mean and covariance weights");
  }
  const Eigen::MatrixXd& V = sp.unit;  // p x r
  const Eigen::VectorXd& alpha = sp.wm;
  const int r = sp.count();
  const Eigen::MatrixXd DVt = alpha.asDiagonal() * V.transpose();  // r x p
  summary.members = r;

  auto theta_of = [&](const Eigen::Ref<const Eigen::VectorXd>& eta) {
    Eigen::VectorXd theta = base;
    for (int j = 0; j < p; ++j) theta(estimated[j]) = prior[j].to_theta(eta(j));
    return theta;
  };

  // ---- Initialisation (step 0): x = (y0, eta0), L = [0; S0], U = I.
  const Eigen::VectorXd eta0 = prior.mean_eta();
  summary.theta_prior = prior.nominal_theta();
  summary.theta_prior_std = prior.prior_theta_std();
  std::unique_ptr<model::SteppableSimulator> local;
  try {
    local = SteppableForwardModel::clone_steppable(simulator);
  } catch (const std::exception& e) {
    return finish(RoukfTermination::kInvalidInput, e.what());
  }
  model::State init = options.initial_state ? *options.initial_state
                                            : local->initial_state(theta_of(eta0));
  const int ny = static_cast<int>(init.x.size());
  const int n = ny + p;
  if (data.times(0) < init.time) {
    return finish(RoukfTermination::kInvalidInput, "roukf: the first frame is before the initial state's time");
  }
  Eigen::VectorXd x(n);
  x << init.x, eta0;
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, p);
  L.bottomRows(p) = prior.sqrt_covariance_eta();
  Eigen::MatrixXd U = Eigen::MatrixXd::Identity(p, p);
  double t_prev = init.time;

  const int m_all = static_cast<int>(observed_channels.size());
  SteppableForwardModel prototype(std::move(local), observed_channels, 0.0);
  Ensemble ensemble(prototype, options.ensemble);

  Eigen::MatrixXd X(n, r), Z(m_all, r);
  // Ends the run on a numerical failure, keeping the steps done and the last good factors.
  auto numerical_failure = [&](const std::string& why) -> RoukfSummary& {
    summary.state = model::State{t_prev, x.head(ny)};
    summary.L = L;
    summary.U = U;
    return finish(RoukfTermination::kNumericalFailure, "roukf: " + why);
  };
  std::vector<MemberOutcome> outcomes(static_cast<size_t>(r));

  // Advances members x + spread * L V_i from t_prev to t; fills X, Z and outcomes. Each member's
  // row is (model state, observed channels, refined retries used); map_rows spreads the members
  // over threads (and MPI ranks) and gathers the rows.
  const bool may_retry = options.refine && options.failure_policy == RoukfFailurePolicy::kRetryThenSkip;
  bool first_prediction = true;
  auto predict = [&](double t, double spread, bool allow_retry) {
    const int width = ny + m_all + 1;
    const EnsembleResult res = ensemble.map_rows(
        r, width, [&](int i, int worker, Eigen::Ref<Eigen::VectorXd> row) -> model::Status {
          auto& sim =
              static_cast<SteppableForwardModel&>(ensemble.worker_model(worker)).simulator();
          const Eigen::VectorXd xi = x + spread * (L * V.col(i));
          const Eigen::VectorXd theta = theta_of(xi.tail(p));
          const bool own_start =
              first_prediction && options.initial_state_per_member && !options.initial_state;
          auto attempt = [&](model::SteppableSimulator& s) -> model::Status {
            model::State st{t_prev, xi.head(ny)};
            if (own_start) {
              st = s.initial_state(theta);
              if (st.x.size() != ny || st.time != t_prev) {
                return model::Status::Error(model::StatusCode::kInvalidArgument,
                                            "initial_state(theta_i) differs in size or time");
              }
            }
            model::Status status = s.advance(st, theta, t);
            if (!status.ok()) return status;
            if (!st.x.allFinite()) {
              return model::Status::Error(model::StatusCode::kNonFinite, "non-finite model state");
            }
            const Eigen::VectorXd z = s.sample(st, theta);
            row.head(ny) = st.x;
            for (int c = 0; c < m_all; ++c) row(ny + c) = z(observed_channels[static_cast<size_t>(c)]);
            if (!row.segment(ny, m_all).allFinite()) {
              return model::Status::Error(model::StatusCode::kNonFinite, "non-finite observation");
            }
            return model::Status::Ok();
          };
          model::Status status = attempt(sim);
          int level = 0;
          if (!status.ok() && allow_retry && may_retry) {
            while (!status.ok() && level < options.max_retries) {
              std::unique_ptr<model::SteppableSimulator> refined = options.refine(sim, level + 1);
              if (!refined) break;
              ++level;
              status = attempt(*refined);
            }
          }
          row(width - 1) = level;
          return status;
        });
    int failed = 0;
    for (int i = 0; i < r; ++i) {
      MemberOutcome& out = outcomes[static_cast<size_t>(i)];
      out = MemberOutcome{};
      out.status = res.status[static_cast<size_t>(i)];
      if (out.status.ok()) {
        X.col(i) << res.Z.row(i).head(ny).transpose(), (x + spread * (L * V.col(i))).tail(p);
        Z.col(i) = res.Z.row(i).segment(ny, m_all).transpose();
        out.retries = static_cast<int>(res.Z(i, width - 1));
        if (out.retries > 0) {
          out.actions.push_back({i, "recovered with the time step divided by " +
                                        std::to_string(1 << out.retries), {}});
        }
      } else {
        ++failed;
        if (allow_retry && may_retry) {
          out.actions.push_back({i, "failed, also with refined time steps (up to " +
                                        std::to_string(options.max_retries) + " halvings)",
                                 out.status});
        }
      }
      summary.retries += out.retries;
    }
    summary.member_runs += r;
    return failed;
  };

  const int frames = static_cast<int>(data.times.size());
  int step_index = 0;
  // Gauss-Newton on the whole-data MAP objective after the split passes (RoukfOptions::
  // map_iterations; docs/estimation.md s.4.7). With whitened residuals w(eta) = R_k^-1/2 (y_k -
  // h_k(eta)) stacked over the present entries, W = R_k^-1/2 dh/deta (central differences) and
  // the prior's b = S0^-1 (eta - eta0) (P0 = S0 S0^T):
  //   A = W^T W + P0^-1,  d = A^-1 (W^T w - P0^-1 (eta - eta0)),  Phi = |w|^2 + |b|^2
  // (the quasi-Newton iteration of Tarantola 2005, Inverse Problem Theory, s.3.2, with the
  // Gauss-Newton Hessian; the Laplace covariance A^-1 at the end).
  struct Entry { int frame, channel; };
  std::vector<Entry> entries;
  std::vector<std::pair<int, Eigen::MatrixXd>> whiten;  // first entry of a frame, R_k^-1/2 (lower solve)
  for (int k = 0; k < frames; ++k) {
    const int first = static_cast<int>(entries.size());
    for (int c = 0; c < m_all; ++c) {
      if (std::isfinite(data.values(k, c))) entries.push_back({k, c});
    }
    const int m = static_cast<int>(entries.size()) - first;
    if (m == 0) continue;
    Eigen::MatrixXd Rk(m, m);
    for (int a = 0; a < m; ++a) {
      for (int b = 0; b < m; ++b) Rk(a, b) = options.R(entries[first + a].channel, entries[first + b].channel);
    }
    whiten.emplace_back(first, Eigen::MatrixXd(Eigen::LLT<Eigen::MatrixXd>(Rk).matrixL()));
  }
  const int n_obs = static_cast<int>(entries.size());
  // Whitens a stacked vector (or the columns of a matrix) of residuals frame by frame.
  auto whitened = [&](Eigen::MatrixXd v) {
    for (const auto& [first, Lk] : whiten) {
      const auto m = Lk.rows();
      v.middleRows(first, m) = Lk.triangularView<Eigen::Lower>().solve(v.middleRows(first, m));
    }
    return v;
  };
  Eigen::VectorXd y_obs(n_obs);
  for (int e = 0; e < n_obs; ++e) y_obs(e) = data.values(entries[e].frame, entries[e].channel);
  // Runs every column of etas over the whole data from the initial state; row i holds the
  // observations at the present entries, then the final model state.
  auto whole_data_runs = [&](const Eigen::MatrixXd& etas) {
    const int width = n_obs + ny;
    return ensemble.map_rows(
        static_cast<int>(etas.cols()), width,
        [&](int i, int worker, Eigen::Ref<Eigen::VectorXd> row) -> model::Status {
          auto& sim = static_cast<SteppableForwardModel&>(ensemble.worker_model(worker)).simulator();
          const Eigen::VectorXd theta = theta_of(etas.col(i));
          model::State st = init;
          if (!options.initial_state && options.initial_state_per_member) st = sim.initial_state(theta);
          int e = 0;
          for (int k = 0; k < frames; ++k) {  // to the last frame, where the filter's state is
            if (model::Status status = sim.advance(st, theta, data.times(k)); !status.ok()) return status;
            if (e == n_obs || entries[e].frame != k) continue;
            const Eigen::VectorXd z = sim.sample(st, theta);
            for (; e < n_obs && entries[e].frame == k; ++e) {
              row(e) = z(observed_channels[static_cast<size_t>(entries[e].channel)]);
            }
          }
          if (st.x.size() != ny) {
            return model::Status::Error(model::StatusCode::kInvalidArgument, "the model state changed size");
          }
          row.tail(ny) = st.x;
          return model::Status::Ok();
        });
  };
  const Eigen::MatrixXd S0 = prior.sqrt_covariance_eta();
  const Eigen::MatrixXd P0inv = Eigen::LLT<Eigen::MatrixXd>(prior.covariance_eta()).solve(Eigen::MatrixXd::Identity(p, p));
  // Per entry, its channel (the per-channel chi-square and noise scales group by it).
  std::vector<int> channel_of(static_cast<size_t>(n_obs));
  for (int e = 0; e < n_obs; ++e) channel_of[static_cast<size_t>(e)] = entries[static_cast<size_t>(e)].channel;
  // The data term of Phi: |w|^2, or with RoukfOptions::noise_scale the marginal over every
  // channel's noise scale (estimation/channel_noise_scale.h).
  auto data_term = [&](const Eigen::VectorXd& w) {
    return options.noise_scale ? channel_marginal_misfit(*options.noise_scale, channel_of, m_all, w)
                               : w.squaredNorm();
  };
  // Phi(eta) = data term + |b|^2 from the observations h(eta) at the present entries.
  auto objective = [&](const Eigen::VectorXd& eta, const Eigen::VectorXd& h) {
    return data_term(whitened(y_obs - h)) + S0.triangularView<Eigen::Lower>().solve(eta - eta0).squaredNorm();
  };
  // Fills summary.map_* from one whole-data run at the estimate theta(eta) (not counted in
  // member_runs); returns a message when that run fails.
  auto whole_data_statistic = [&]() -> std::string {
    const Eigen::VectorXd eta = x.tail(p);
    const EnsembleResult res = whole_data_runs(eta);
    if (!res.status[0].ok()) return "the run at the estimate failed: " + res.status[0].message;
    const Eigen::VectorXd h = res.Z.row(0).head(n_obs).transpose();
    const Eigen::VectorXd w = whitened(y_obs - h);
    // The consistency statistic uses the stated noise, also when the scales are estimated.
    const double phi = w.squaredNorm() + S0.triangularView<Eigen::Lower>().solve(eta - eta0).squaredNorm();
    if (!std::isfinite(phi)) return "the misfit at the estimate is not finite";
    summary.channel_chi2 = Eigen::VectorXd::Zero(m_all);
    summary.channel_frames = Eigen::VectorXi::Zero(m_all);
    for (int e = 0; e < n_obs; ++e) {
      summary.channel_chi2(channel_of[static_cast<size_t>(e)]) += w(e) * w(e);
      summary.channel_frames(channel_of[static_cast<size_t>(e)]) += 1;
    }
    if (options.noise_scale) {
      summary.noise_scale_mode = channel_noise_posterior(*options.noise_scale, channel_of, m_all, w).mode();
    }
    summary.map_statistic = phi;
    summary.map_dof = n_obs;
    summary.map_frames = static_cast<int>(whiten.size());
    return {};
  };
  auto refine_map = [&]() {
    summary.eta_filter = x.tail(p);
    summary.eta_covariance_filter = summary.eta_covariance;
    const Eigen::LLT<Eigen::MatrixXd> filter_llt(summary.eta_covariance);
    if (filter_llt.info() != Eigen::Success) {
      summary.map_note = "not refined: the filter's covariance is not positive definite";
      return;
    }
    const Eigen::VectorXd h = (0.1 * summary.eta_covariance.diagonal().cwiseSqrt()).cwiseMax(1e-8);
    // The point eta, its objective and Gauss-Newton system from one batch of 2p + 1 members.
    struct Point {
      Eigen::VectorXd eta, state;
      double phi = 0.0;
      Eigen::MatrixXd A;
      Eigen::VectorXd gradient;  // W^T w - P0^-1 (eta - eta0) = -grad Phi / 2: A d = gradient
    };
    // One whole-data run at eta (a candidate): its row (observations at the entries, final state).
    auto probe = [&](const Eigen::VectorXd& eta, Eigen::VectorXd& row) -> std::string {
      const EnsembleResult res = whole_data_runs(eta);
      summary.map_runs += 1;
      summary.member_runs += 1;
      if (!res.status[0].ok()) {
        return "a whole-data member failed (" + describe_theta(space, theta_of(eta), estimated) +
               "): " + res.status[0].message;
      }
      row = res.Z.row(0).transpose();
      return {};
    };
    // centre: the probe() row at eta when it was run already (then 2p members, else 2p + 1).
    auto evaluate = [&](const Eigen::VectorXd& eta, Point& out, const Eigen::VectorXd* centre = nullptr) -> std::string {
      const int c0 = centre ? 0 : 1;  // columns: [centre,] +h_j e_j, -h_j e_j
      Eigen::MatrixXd etas = eta.replicate(1, 2 * p + c0);
      for (int j = 0; j < p; ++j) {
        etas(j, c0 + 2 * j) += h(j);
        etas(j, c0 + 1 + 2 * j) -= h(j);
      }
      const EnsembleResult res = whole_data_runs(etas);
      summary.map_runs += 2 * p + c0;
      summary.member_runs += 2 * p + c0;
      for (int i = 0; i < 2 * p + c0; ++i) {
        if (!res.status[static_cast<size_t>(i)].ok()) {
          return "a whole-data member failed (" +
                 describe_theta(space, theta_of(etas.col(i)), estimated) + "): " +
                 res.status[static_cast<size_t>(i)].message;
        }
      }
      const Eigen::MatrixXd obs = res.Z.leftCols(n_obs).transpose();  // n_obs x (2p [+ 1])
      const Eigen::VectorXd h0 = centre ? Eigen::VectorXd(centre->head(n_obs)) : Eigen::VectorXd(obs.col(0));
      const Eigen::VectorXd w = whitened(y_obs - h0);
      Eigen::MatrixXd H(n_obs, p);  // d h / d eta
      for (int j = 0; j < p; ++j) H.col(j) = (obs.col(c0 + 2 * j) - obs.col(c0 + 1 + 2 * j)) / (2.0 * h(j));
      const Eigen::MatrixXd W = whitened(H);  // = -dw/deta
      out.eta = eta;
      out.state = centre ? Eigen::VectorXd(centre->tail(ny)) : Eigen::VectorXd(res.Z.row(0).tail(ny).transpose());
      out.phi = objective(eta, h0);
      // With noise scales: each entry weighted by E[1 / s_c^2] of its channel at this point
      // (iteratively reweighted least squares on the marginal, channel_noise_scale.h).
      Eigen::VectorXd weight = Eigen::VectorXd::Ones(n_obs);
      if (options.noise_scale) {
        const Eigen::VectorXd wc = channel_noise_posterior(*options.noise_scale, channel_of, m_all, w).weight();
        for (int e = 0; e < n_obs; ++e) weight(e) = wc(channel_of[static_cast<size_t>(e)]);
      }
      out.A = W.transpose() * weight.asDiagonal() * W + P0inv;
      out.gradient = W.transpose() * weight.cwiseProduct(w) - P0inv * (eta - eta0);
      if (!std::isfinite(out.phi) || !out.A.allFinite()) return "the misfit or its Jacobian is not finite";
      return {};
    };
    Point at;
    if (std::string why = evaluate(x.tail(p), at); !why.empty()) {
      summary.map_note = "not refined: " + why;
      return;
    }
    summary.map_statistic_filter = at.phi;
    std::ostringstream note;
    // Damped Gauss-Newton on Phi (docs/estimation.md s.4.7): the step s = d / (1 + lambda) solves
    // (1 + lambda) A s = gradient (Levenberg-Marquardt with A as the damping matrix: the
    // Gauss-Newton direction, shortened), lambda from the gain ratio; a candidate costs one
    // whole-data run, the slopes at an accepted point 2p more. Stops on the step or on Phi.
    const int max_rejections = 8;
    double lambda = 0.0, nu = 2.0;
    std::vector<double> objectives{at.phi};  // at every accepted point
    std::vector<double> lengths;             // of every accepted step [posterior std]
    Eigen::VectorXd previous_step;
    int extrapolations = 0;
    const double objective_drop = options.map_objective_tolerance * n_obs;
    auto fell_over_two = [&]() {
      return objectives.size() >= 3 ? objectives[objectives.size() - 3] - objectives.back()
                                    : std::numeric_limits<double>::infinity();
    };
    // The objective stop: Phi fell by less than objective_drop over the last two accepted steps.
    auto converged_on_objective = [&](const char* how, double next_step_std) {
      summary.map_last_step_std = next_step_std;
      summary.map_converged = true;
      note << "converged after " << summary.map_steps << " step(s)" << how << ": Phi fell by "
           << std::setprecision(3) << fell_over_two() << " over the last 2 steps (< "
           << options.map_objective_tolerance << " per observation = " << objective_drop
           << "), the next Gauss-Newton step " << next_step_std << " posterior std";
    };
    // Moves `at` to eta (whose probe() row is `row`) with a new linearisation; a failed member
    // keeps `at` and returns why.
    auto move_to = [&](const Eigen::VectorXd& eta, const Eigen::VectorXd& row, RoukfMapStep& rec,
                       const Eigen::VectorXd& step) -> std::string {
      Point next;
      if (std::string why = evaluate(eta, next, &row); !why.empty()) return why;
      rec.accepted = true;
      rec.objective = next.phi;
      lengths.push_back(std::sqrt(std::max(0.0, step.dot(at.A * step))));
      if (previous_step.size() == p) {
        const double norm = std::sqrt(previous_step.dot(at.A * previous_step));
        if (norm > 0 && lengths.back() > 0) rec.cos_previous = step.dot(at.A * previous_step) / (lengths.back() * norm);
      }
      previous_step = step;
      at = std::move(next);
      objectives.push_back(at.phi);
      ++summary.map_steps;
      x.tail(p) = at.eta;
      x.head(ny) = at.state;
      return {};
    };
    for (int it = 0;; ++it) {
      const Eigen::LDLT<Eigen::MatrixXd> A_ldlt(at.A);
      const Eigen::VectorXd d = A_ldlt.solve(at.gradient);
      const double length = std::sqrt(std::max(0.0, d.dot(at.A * d)));
      if (A_ldlt.info() != Eigen::Success || !d.allFinite()) {
        note << "stopped: the Gauss-Newton system is singular";
        break;
      }
      summary.map_last_step_std = length;
      if (length < options.map_tolerance && out_of_bounds(space, theta_of(at.eta + d), estimated).empty()) {
        // Converged: the last (short) step is taken without another batch; the Laplace
        // covariance is that of the point just evaluated.
        x.tail(p) = at.eta + d;
        x.head(ny) = at.state;
        summary.map_converged = true;
        note << "converged after " << summary.map_steps << " step(s): the next step is "
             << std::setprecision(3) << length << " posterior std";
        break;
      }
      if (it == options.map_iterations && options.map_objective_tolerance > 0 && fell_over_two() < objective_drop) {
        // The limit reached right after a finishing step that lowered Phi by less than the
        // tolerance: the objective stop holds there (the limit is not why it ends).
        converged_on_objective(" (objective, at map_iterations)", length);
        break;
      }
      if (it == options.map_iterations) {
        note << "stopped after " << summary.map_steps << " step(s) with a step of " << std::setprecision(3)
             << length << " posterior std left";
        if (std::isfinite(fell_over_two())) note << " and Phi still falling by " << fell_over_two() << " over the last 2 steps";
        note << " (map_iterations)";
        break;
      }
      RoukfMapStep rec;
      rec.objective = at.phi;
      rec.gauss_newton_std = length;
      rec.actual = std::numeric_limits<double>::quiet_NaN();
      std::string failed;
      Eigen::VectorXd s, row;
      for (int attempt = 0; attempt <= max_rejections; ++attempt) {
        s = d / (1.0 + lambda);
        rec.damping = lambda;
        rec.step_std = std::sqrt(std::max(0.0, s.dot(at.A * s)));
        rec.predicted = 2.0 * at.gradient.dot(s) - s.dot(at.A * s);
        bool lower = false;
        // A point outside the simulator's bounds (possible where a transform does not bound
        // them) or whose run fails counts as a step that does not lower the objective.
        if (!out_of_bounds(space, theta_of(at.eta + s), estimated).empty()) {
          ++rec.out_of_bounds;
        } else if (failed = probe(at.eta + s, row); failed.empty()) {
          const double phi = objective(at.eta + s, row.head(n_obs));
          rec.actual = at.phi - phi;
          rec.gain = rec.actual / rec.predicted;
          lower = phi < at.phi;
        }
        if (lower) {
          lambda = damping_after_accepted_step(lambda, rec.gain, 1e-6);  // Nielsen 1999
          nu = 2.0;
          break;
        }
        ++rec.rejected;
        lambda = lambda == 0.0 ? 1.0 : lambda * nu;
        nu *= 2.0;
      }
      if (rec.rejected > max_rejections) {
        summary.map_history.push_back(rec);
        note << "stopped after " << summary.map_steps << " step(s): " << max_rejections + 1
             << " damped steps did not lower the objective (the last " << std::setprecision(3) << rec.step_std
             << " posterior std, damping " << rec.damping << ")" << (failed.empty() ? "" : "; " + failed);
        break;
      }
      if (std::string why = move_to(at.eta + s, row, rec, s); !why.empty()) {
        summary.map_history.push_back(rec);
        note << "stopped after " << summary.map_steps << " step(s): " << why;
        break;
      }
      summary.map_history.push_back(rec);
      // Objective-based stop, with a finishing step along the valley first (Aitken's
      // extrapolation of a linearly converging sequence; Brezinski & Redivo Zaglia 1991, s.1.3).
      if (!(options.map_objective_tolerance > 0) || !(fell_over_two() < objective_drop)) continue;
      bool finished_moving = false;
      if (extrapolations < 5 && lengths.size() >= 2) {
        const double q = lengths.back() / lengths[lengths.size() - 2];
        const double factor = valley_extrapolation_factor(q, 50.0);
        const Eigen::VectorXd last = previous_step;
        for (const double f : {factor, 0.25 * factor}) {
          const Eigen::VectorXd cand = at.eta + f * last;
          RoukfMapStep ext;
          ext.objective = at.phi;
          ext.extrapolated = true;
          ext.gauss_newton_std = length;
          ext.step_std = f * lengths.back();
          ext.actual = ext.predicted = ext.gain = std::numeric_limits<double>::quiet_NaN();
          if (!out_of_bounds(space, theta_of(cand), estimated).empty()) {
            ext.out_of_bounds = 1;
            summary.map_history.push_back(ext);
            continue;
          }
          if (!probe(cand, row).empty()) continue;
          const double phi = objective(cand, row.head(n_obs));
          ext.actual = at.phi - phi;
          if (phi < at.phi && move_to(cand, row, ext, f * last).empty()) {
            ++extrapolations;
            summary.map_history.push_back(ext);
            finished_moving = true;
            break;
          }
          ext.rejected = 1;
          summary.map_history.push_back(ext);
        }
      }
      if (finished_moving) continue;
      const Eigen::VectorXd d_next = at.A.ldlt().solve(at.gradient);
      converged_on_objective(" (objective)", std::sqrt(std::max(0.0, d_next.dot(at.A * d_next))));
      break;
    }
    summary.map_note = note.str();
    summary.map_objective = at.phi;
    if (summary.map_steps == 0 && !summary.map_converged) return;  // the filter's estimate stays
    const Eigen::MatrixXd P = at.A.llt().solve(Eigen::MatrixXd::Identity(p, p));
    const Eigen::VectorXd eta = x.tail(p);
    const Eigen::VectorXd shift = eta - summary.eta_filter;
    summary.map_shift_std = std::sqrt(shift.dot(filter_llt.solve(shift)));
    summary.eta = eta;
    summary.eta_covariance = 0.5 * (P + P.transpose());
    const Eigen::VectorXd std_eta = summary.eta_covariance.diagonal().cwiseSqrt();
    for (int j = 0; j < p; ++j) {
      const Transform& tr = prior[j].transform;
      const double a = tr.to_theta(eta(j) - 2 * std_eta(j));
      const double b = tr.to_theta(eta(j) + 2 * std_eta(j));
      summary.theta(j) = tr.to_theta(eta(j));
      summary.theta_lower(j) = std::min(a, b);
      summary.theta_upper(j) = std::max(a, b);
    }
    summary.theta_std = prior.theta_std(eta, std_eta);
  };
  // Passes: kRepeat continues in time over `beats` copies of the beat; kSplit (multiple data
  // assimilation, Emerick & Reynolds 2013, Comput Geosci 55:3, Algorithm 1) restarts every pass
  // from the initial state and assimilates the frames with R / phi_b, sum phi_b = 1.
  const bool split = options.pass_mode == RoukfPassMode::kSplit;
  double fraction = split ? std::min(1.0, options.first_fraction) : 1.0;
  double assimilated = 0.0;
  auto eta_covariance = [&]() -> Eigen::MatrixXd {
    const Eigen::MatrixXd Leta = L.bottomRows(p);
    return Leta * Eigen::LLT<Eigen::MatrixXd>(U).solve(Leta.transpose());
  };
  for (int beat = 0; beat < options.beats; ++beat) {
    Eigen::MatrixXd P_pass_start;
    if (split) {
      if (beat == options.beats - 1) fraction = 1.0 - assimilated;
      if (beat > 0) {
        // The model state is a function of the parameters (no model noise): every member starts
        // again from the initial state (its own with initial_state_per_member), so the state-
        // parameter relation is simulated afresh about the narrower, moved spread.
        t_prev = init.time;
        x.head(ny) = init.x;
        L.topRows(ny).setZero();
        first_prediction = true;
      }
      P_pass_start = eta_covariance();
      summary.pass_fractions.push_back(fraction);
    }
    for (int k = 0; k < frames; ++k, ++step_index) {
      const double t = data.times(k) + (split ? 0.0 : beat * options.period);
      RoukfStep rec;
      rec.index = step_index;
      rec.beat = beat;
      rec.frame = k;
      rec.time = t;

      // 1. Sampling: C = chol(U^-1), L <- L C, U = I (at t_prev; again before every re-linearised
      //    sub-update of step 3).
      auto resample = [&]() -> bool {
        const Eigen::LLT<Eigen::MatrixXd> Ullt(U);
        const Eigen::MatrixXd Uinv = Ullt.solve(Eigen::MatrixXd::Identity(p, p));
        const Eigen::LLT<Eigen::MatrixXd> Cllt(0.5 * (Uinv + Uinv.transpose()));
        if (Ullt.info() != Eigen::Success || Cllt.info() != Eigen::Success || !Uinv.allFinite()) {
          return false;
        }
        L = L * Eigen::MatrixXd(Cllt.matrixL());
        U.setIdentity();
        return true;
      };
      if (!resample()) {
        return numerical_failure("U is not positive definite at t = " + std::to_string(t) + " s");
      }

      // 2. Prediction of the r members, with the failure policy.
      double spread = options.sigma_scale;
      bool skip_analysis = false;
      int failed = predict(t, spread, true);
      auto first_failure = [&]() -> int {
        for (int i = 0; i < r; ++i) {
          if (!outcomes[static_cast<size_t>(i)].status.ok()) return i;
        }
        return -1;
      };
      auto collect_actions = [&]() {
        for (const auto& o : outcomes) rec.actions.insert(rec.actions.end(), o.actions.begin(), o.actions.end());
      };
      collect_actions();
      if (failed > 0) {
        const int i = first_failure();
        const model::Status st = outcomes[static_cast<size_t>(i)].status;
        const Eigen::VectorXd xi = x + spread * (L * V.col(i));
        const std::string who = "member " + std::to_string(i) + " failed at t = " +
                                std::to_string(t) + " s (" +
                                describe_theta(space, theta_of(xi.tail(p)), estimated) +
                                "): " + st.message;
        if (options.failure_policy == RoukfFailurePolicy::kAbort) {
          rec.actions.push_back({i, "abort", st});
          summary.steps.push_back(std::move(rec));
          return finish(RoukfTermination::kMemberFailed, who);
        }
        spread *= options.shrink;
        rec.actions.push_back({-1, "re-ran the step with the sigma spread shrunk by " +
                                       std::to_string(options.shrink) + " (" +
                                       std::to_string(failed) + " member(s) failed)",
                               st});
        failed = predict(t, spread, false);
        if (failed > 0) {
          const int j = first_failure();
          summary.steps.push_back(std::move(rec));
          return finish(RoukfTermination::kMemberFailed,
                        who + "; after shrinking the spread member " + std::to_string(j) +
                            " still fails: " + outcomes[static_cast<size_t>(j)].status.message);
        }
        skip_analysis = true;
      }
      // L = [x_i] D V^T (M&C 2011 eq. 3.9), divided by the spread of the points (scaled set,
      // Julier 2002) and rescaled for the fading memory and a skip's inflation; HL below gets the
      // same factor so that P and P_zz stay consistent. `memory` is also applied to the factor at
      // t_prev when a sub-update re-linearises (step 3).
      double memory = 1.0;
      if (options.forgetting < 1.0) memory /= std::sqrt(options.forgetting);
      if (skip_analysis) memory *= std::sqrt(1.0 + options.inflation);
      // The regression of the ensemble just predicted: mean x0 and z0 at t, factors Lt and HLall.
      Eigen::VectorXd x0, zm;
      Eigen::MatrixXd Lt, HLall;
      auto regress = [&](double grow) {
        x0 = X * alpha;
        zm = Z * alpha;
        Lt = (X.colwise() - x0) * DVt * grow;
        HLall = (Z.colwise() - zm) * DVt * grow;
      };
      regress(memory / spread);
      if (skip_analysis) {
        ++summary.skipped_analyses;
        rec.analysis_skipped = true;
        rec.actions.push_back({-1, "skipped the analysis, covariance inflated by " +
                                       std::to_string(options.inflation),
                               {}});
      }
      Eigen::VectorXd xt = x0;  // analysed mean at t
      // U = I after every prediction (U was reset at sampling and nothing has changed it).

      // 3. Correction with the channels present at this frame.
      rec.forecast = zm;
      rec.fitted = zm;
      rec.innovation = Eigen::VectorXd::Constant(m_all, std::nan(""));
      std::vector<int> present;
      for (int c = 0; c < m_all; ++c) {
        if (std::isfinite(data.values(k, c))) present.push_back(c);
      }
      const int m = static_cast<int>(present.size());
      Eigen::MatrixXd Rk(m, m);
      for (int a = 0; a < m; ++a) {
        for (int b = 0; b < m; ++b) Rk(a, b) = options.R(present[a], present[b]) / fraction;
      }
      const Eigen::LLT<Eigen::MatrixXd> Rllt(Rk);
      // The analysis of a fraction phi of the frame's information (the likelihood raised to phi,
      // i.e. R / phi) with the current regression: U = I + phi HL^T R^-1 HL,
      // coeff = U^-1 phi HL^T R^-1 (y - z0).
      struct Analysis {
        Eigen::VectorXd d, Rinvd, coeff;
        Eigen::MatrixXd HL, RinvHL, U;
        Eigen::LLT<Eigen::MatrixXd> Ullt;
        bool ok = false;
      };
      auto analyse = [&](double phi) {
        Analysis an;
        an.d.resize(m);
        an.HL.resize(m, p);
        for (int a = 0; a < m; ++a) {
          an.d(a) = data.values(k, present[a]) - zm(present[a]);
          an.HL.row(a) = HLall.row(present[a]);
        }
        an.RinvHL = Rllt.solve(an.HL);
        an.Rinvd = Rllt.solve(an.d);
        an.U = Eigen::MatrixXd::Identity(p, p) + phi * an.HL.transpose() * an.RinvHL;
        an.Ullt.compute(an.U);
        an.coeff = an.Ullt.solve(phi * an.HL.transpose() * an.Rinvd);
        an.ok = an.Ullt.info() == Eigen::Success && an.coeff.allFinite();
        return an;
      };
      if (m > 0) {
        const Analysis full = analyse(1.0);
        if (!full.ok) {
          return numerical_failure("the analysis at t = " + std::to_string(t) +
                                   " s is not finite (U = I + HL^T R^-1 HL not positive definite)");
        }
        // Consistency of the forecast (the first regression, all of the frame's information):
        // S^-1 d = R^-1 d - R^-1 HL U^-1 HL^T R^-1 d (Woodbury), log det S = log det R + log det U.
        const Eigen::VectorXd Sinvd = full.Rinvd - full.RinvHL * full.coeff;
        rec.nis = full.d.dot(Sinvd);
        rec.log_likelihood = -0.5 * (m * std::log(2.0 * std::numbers::pi) + log_det(Rllt) +
                                     log_det(full.Ullt) + rec.nis);
        for (int a = 0; a < m; ++a) rec.innovation(present[a]) = full.d(a);
        if (!skip_analysis) {
          // Tempered (progressive) analysis, the recursive update of Zanetti 2012 (IEEE TAC
          // 57:1481) with the sigma points re-drawn between sub-updates: the frame's
          // information is split into fractions phi_1 + ... + phi_K = 1, each at most
          // options.tempering / lambda_max(HL^T R^-1 HL) of the current regression (so no
          // sub-update shrinks the spread by more than sqrt(1 + tempering) in any direction).
          // After each sub-update the mean and factor at t_prev get the same coefficients (the
          // sigma points at t_prev regress on V with D V^T: the one-step smoother without model
          // noise), new points are drawn there and advanced again, so the next regression is
          // taken over the narrower, moved spread. Linear-Gaussian: every sub-update is exact and
          // the K likelihoods raised to phi_k multiply to the one likelihood, so the result is the
          // Kalman filter's whatever the split.
          double done = 0.0;  // fraction assimilated before the current regression
          Analysis an;
          for (;;) {
            const double remaining = 1.0 - done;
            double phi = remaining;
            const bool last_allowed = rec.subupdates + 1 >= options.max_subupdates;
            if (options.tempering > 0.0 && !last_allowed) {
              const Analysis probe = analyse(0.0);
              const double lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(
                                        probe.HL.transpose() * probe.RinvHL, Eigen::EigenvaluesOnly)
                                        .eigenvalues()
                                        .maxCoeff();
              if (lambda * remaining > options.tempering) phi = options.tempering / lambda;
            }
            an = analyse(phi);
            ++rec.subupdates;
            if (!an.ok) {
              return numerical_failure("the analysis at t = " + std::to_string(t) +
                                       " s is not finite (U = I + phi HL^T R^-1 HL not positive "
                                       "definite)");
            }
            xt = x0 + Lt * an.coeff;
            if (phi >= remaining) break;
            // Smoother update at t_prev with the same coefficients, then new points there.
            L *= memory;
            x += L * an.coeff;
            U = an.U;
            memory = 1.0;
            if (!resample()) {
              return numerical_failure("U is not positive definite at a sub-update at t = " +
                                       std::to_string(t) + " s");
            }
            const Eigen::VectorXd x0_kept = x0, zm_kept = zm;
            const Eigen::MatrixXd Lt_kept = Lt, HL_kept = HLall;
            failed = predict(t, spread, true);
            collect_actions();
            if (failed > 0) {
              // Keep the last good regression and assimilate the rest of the frame with it (two
              // updates with one regression equal one update with the summed fraction).
              const int i = first_failure();
              rec.actions.push_back({i, "tempering stopped after " + std::to_string(rec.subupdates) +
                                            " sub-update(s): the rest of the frame assimilated "
                                            "with the last regression",
                                     outcomes[static_cast<size_t>(i)].status});
              x0 = x0_kept;
              zm = zm_kept;
              Lt = Lt_kept;
              HLall = HL_kept;
              an = analyse(remaining);
              ++rec.subupdates;
              if (!an.ok) {
                return numerical_failure("the analysis at t = " + std::to_string(t) +
                                         " s is not finite after a failed sub-update");
              }
              xt = x0 + Lt * an.coeff;
              break;
            }
            done += phi;
            regress(1.0 / spread);
          }
          summary.subupdates += rec.subupdates;
          rec.observed = m;
          U = an.U;
          rec.fitted = zm + HLall * an.coeff;
        }
      }
      first_prediction = false;
      x = xt;
      L = Lt;
      // 4. Record.
      const Eigen::MatrixXd Leta = L.bottomRows(p);
      const Eigen::MatrixXd Peta = Leta * Eigen::LLT<Eigen::MatrixXd>(U).solve(Leta.transpose());
      if (!x.allFinite() || !Peta.allFinite()) {
        return numerical_failure("non-finite state or covariance at t = " + std::to_string(t) + " s");
      }
      rec.eta = x.tail(p);
      rec.eta_std = Peta.diagonal().cwiseMax(0.0).cwiseSqrt();
      rec.theta.resize(p);
      rec.theta_lower.resize(p);
      rec.theta_upper.resize(p);
      for (int j = 0; j < p; ++j) {
        const Transform& tr = prior[j].transform;
        const double a = tr.to_theta(rec.eta(j) - 2 * rec.eta_std(j));
        const double b = tr.to_theta(rec.eta(j) + 2 * rec.eta_std(j));
        rec.theta(j) = tr.to_theta(rec.eta(j));
        rec.theta_lower(j) = std::min(a, b);
        rec.theta_upper(j) = std::max(a, b);
      }
      if (options.record_factors) {
        rec.x = x;
        rec.L = L;
        rec.U = U;
      }
      summary.eta = rec.eta;
      summary.theta = rec.theta;
      summary.theta_lower = rec.theta_lower;
      summary.theta_upper = rec.theta_upper;
      summary.eta_covariance = Peta;
      summary.theta_std = prior.theta_std(rec.eta, rec.eta_std);
      t_prev = t;
      summary.steps.push_back(std::move(rec));
      if (const std::string outside = out_of_bounds(space, theta_of(x.tail(p)), estimated);
          !outside.empty()) {
        summary.state = model::State{t_prev, x.head(ny)};
        summary.L = L;
        summary.U = U;
        return finish(RoukfTermination::kEstimateOutOfBounds,
                      "roukf: the estimate left the parameter bounds at t = " + std::to_string(t) +
                          " s: " + outside);
      }
      if (options.on_step && !options.on_step(summary.steps.back())) {
        summary.state = model::State{t_prev, x.head(ny)};
        summary.L = L;
        summary.U = U;
        return finish(RoukfTermination::kCancelled, "cancelled by the progress callback");
      }
    }
    if (split) {
      // Next fraction: the information of this pass, relative to the spread it ended with, is
      // lambda = lambda_max(I - P_end P_start^-1) for the fraction phi_b; the next pass may add
      // pass_growth times the current spread's information (phi_{b+1} = pass_growth phi_b /
      // lambda), so no pass shrinks the spread by more than sqrt(1 + pass_growth) in any direction
      // when the model is linear.
      assimilated += fraction;
      if (assimilated >= 1.0 - 1e-12) break;
      const Eigen::MatrixXd P_end = eta_covariance();
      const Eigen::LLT<Eigen::MatrixXd> start_llt(P_pass_start);
      const Eigen::MatrixXd Ls = start_llt.matrixL();
      const Eigen::MatrixXd W = Ls.triangularView<Eigen::Lower>().solve(
          Ls.triangularView<Eigen::Lower>().solve(P_end).transpose());
      const double mu_min =
          Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (W + W.transpose()), Eigen::EigenvaluesOnly)
              .eigenvalues()
              .minCoeff();
      const double lambda = 1.0 - mu_min;
      const double next = lambda > 1e-12 ? options.pass_growth * fraction / lambda : 1.0;
      fraction = std::min(next, 1.0 - assimilated);
    }
  }
  if (split) {
    if (assimilated < 1.0 - 1e-12) assimilated += fraction;  // the last pass took the rest
    if (options.map_iterations > 0) refine_map();
    // Consistency with the whole data set: 2 x the MAP objective at the estimate,
    // sum_k r_k^T R^-1 r_k + (eta - eta0)^T P0^-1 (eta - eta0), r_k = y_k - h_k(eta). On a
    // linear-Gaussian model at the exact posterior mean this equals
    // (y - H eta0)^T (H P0 H^T + R)^-1 (y - H eta0) (completing the square in the misfit of
    // Tarantola 2005, s.3.2), which is the sum of the NIS of one exact pass (the innovations
    // decomposition of the Gaussian likelihood, Schweppe 1965, IEEE Trans Inf Theory 11:61),
    // chi-square with sum_k m_k degrees of freedom; summary.nis_mean is it divided by the frames.
    const std::string why = whole_data_statistic();
    if (!why.empty()) {
      summary.state = model::State{t_prev, x.head(ny)};
      summary.L = L;
      summary.U = U;
      return finish(RoukfTermination::kNumericalFailure, "roukf: " + why);
    }
  }
  summary.state = model::State{t_prev, x.head(ny)};
  summary.L = L;
  summary.U = U;
  if (split && options.map_iterations > 0 && !summary.map_converged) {
    return finish(RoukfTermination::kMapNotConverged,
                  "roukf: all frames assimilated; MAP refinement: " + summary.map_note +
                      "; the estimate is the last accepted point, not the MAP");
  }
  return finish(RoukfTermination::kCompleted, "all frames assimilated");
}

double chi_square_quantile(int dof, double prob) {
  double z = 0.0;  // standard normal quantile
  if (prob == 0.025) {
    z = -1.959963984540054;
  } else if (prob == 0.95) {
    z = 1.6448536269514722;
  } else if (prob == 0.975) {
    z = 1.959963984540054;
  } else {
    throw std::invalid_argument("chi_square_quantile: only the 2.5 %, 95 % and 97.5 % quantiles");
  }
  if (dof < 1) throw std::invalid_argument("chi_square_quantile: dof must be >= 1");
  const double k = dof;
  const double c = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - c + z * std::sqrt(c), 3);
}

std::unique_ptr<model::SteppableSimulator> refine_by_time_step(const model::SteppableSimulator& s,
                                                               int level) {
  return s.with_time_step_factor(std::ldexp(1.0, -level));
}

Eigen::MatrixXd pass_errors_percent(const RoukfSummary& summary, const Eigen::VectorXd& truth,
                                    int passes) {
  Eigen::MatrixXd err = Eigen::MatrixXd::Constant(passes, truth.size(), std::nan(""));
  for (const auto& s : summary.steps) {
    if (s.theta.size() != truth.size() || s.beat >= passes) continue;
    err.row(s.beat) = relative_errors_percent(s.theta, truth).transpose();
  }
  return err;
}

int passes_to_within(const Eigen::MatrixXd& pass_error_percent, double percent) {
  for (Eigen::Index b = 0; b < pass_error_percent.rows(); ++b) {
    const auto row = pass_error_percent.row(b);
    if (row.allFinite() && row.maxCoeff() <= percent) return static_cast<int>(b) + 1;
  }
  return -1;
}

std::string RoukfSummary::brief_report() const {
  std::ostringstream s;
  s << "ROUKF: " << to_string(termination) << ", " << steps.size() << " steps, p = "
    << parameter_names.size() << ", " << members << " members, " << member_runs
    << " member runs, " << retries << " retries, " << skipped_analyses << " skipped analyses, "
    << subupdates << " analysis sub-updates, "
    << std::fixed << std::setprecision(2) << wall_seconds << " s";
  if (!pass_fractions.empty()) {
    s << ", " << pass_fractions.size() << " split passes (first fraction " << std::setprecision(3)
      << pass_fractions.front() << std::fixed << std::setprecision(2) << ")";
  }
  if (map_runs > 0) {
    s << ", MAP refinement: " << map_note;
    if (std::isfinite(map_shift_std)) {
      s << ", moved " << std::setprecision(3) << map_shift_std << std::fixed << std::setprecision(2)
        << " filter std";
    }
  }
  if (nis_frames > 0) {
    s << ", mean NIS (" << nis_source << ") " << nis_mean << " (95 % band " << nis_band_lower << "-" << nis_band_upper
      << " over " << nis_frames << " frames)";
  }
  if (termination != RoukfTermination::kCompleted) s << " (" << message << ")";
  return s.str();
}

std::string RoukfSummary::full_report() const {
  std::ostringstream s;
  s << brief_report() << "\n";
  s << std::setprecision(5);
  for (size_t j = 0; j < parameter_names.size() && static_cast<Eigen::Index>(j) < theta.size(); ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    s << "  " << std::left << std::setw(14) << parameter_names[j] << std::right << " theta "
      << std::setw(12) << theta(jj) << "  [" << theta_lower(jj) << ", " << theta_upper(jj)
      << "]  eta " << eta(jj) << " +- " << std::sqrt(std::max(0.0, eta_covariance(jj, jj)))
      << "\n";
  }
  return s.str();
}

}  // namespace sigmaheart::estimation
