#include "estimation/roukf/roukf.h"

#include "estimation/enum_names.h"
#include "estimation/fit_metrics.h"
#include "estimation/roukf/steppable_forward_model.h"

#include <Eigen/Cholesky>

#include <chrono>
#include <cmath>
#include <exception>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

constexpr std::array<EnumName<RoukfFailurePolicy>, 3> kRoukfFailurePolicyNames{{
    {RoukfFailurePolicy::kRetryThenSkip, "retry-then-skip"},
    {RoukfFailurePolicy::kSkipWithInflation, "skip"}, {RoukfFailurePolicy::kAbort, "abort"},
}};
const char* to_string(RoukfFailurePolicy policy) {
  return enum_to_string(kRoukfFailurePolicyNames, policy);
}
std::optional<RoukfFailurePolicy> parse_roukf_failure_policy(const std::string& text) {
  return enum_from_string(kRoukfFailurePolicyNames, text);
}

constexpr std::array<EnumName<RoukfTermination>, 6> kRoukfTerminationNames{{
    {RoukfTermination::kCompleted, "completed"}, {RoukfTermination::kMemberFailed, "member failed"},
    {RoukfTermination::kCancelled, "cancelled"}, {RoukfTermination::kInvalidInput, "invalid input"},
    {RoukfTermination::kNumericalFailure, "numerical failure"},
    {RoukfTermination::kEstimateOutOfBounds, "estimate out of bounds"},
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
  if (beats > 1 && !(period > 0 && std::isfinite(period))) {
    return "roukf: period must be positive when beats > 1";
  }
  if (sigma_rule == SigmaRule::kScaled) {
    return "roukf: the scaled sigma rule has unequal mean and covariance weights; use simplex, "
           "canonical or star";
  }
  if (!(forgetting > 0.0 && forgetting <= 1.0)) return "roukf: forgetting must lie in (0, 1]";
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
    for (const auto& st : summary.steps) {
      if (st.observed == 0) continue;
      ++summary.nis_frames;
      summary.nis_dof += st.observed;
      nis_sum += st.nis;
    }
    if (summary.nis_frames > 0) {
      summary.nis_mean = nis_sum / summary.nis_frames;
      summary.nis_band_lower = chi_square_quantile(summary.nis_dof, 0.025) / summary.nis_frames;
      summary.nis_band_upper = chi_square_quantile(summary.nis_dof, 0.975) / summary.nis_frames;
    }
    if (options.truth && t != RoukfTermination::kInvalidInput) {
      summary.pass_error_percent = pass_errors_percent(summary, *options.truth, options.beats);
      summary.passes_to_within_10_percent = passes_to_within(summary.pass_error_percent, 10.0);
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
  if (options.beats > 1 && !(data.times(data.times.size() - 1) < data.times(0) + options.period)) {
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
  for (int beat = 0; beat < options.beats; ++beat) {
    for (int k = 0; k < frames; ++k, ++step_index) {
      const double t = data.times(k) + beat * options.period;
      RoukfStep rec;
      rec.index = step_index;
      rec.beat = beat;
      rec.frame = k;
      rec.time = t;

      // 1. Sampling: C = chol(U^-1), L <- L C, U = I.
      {
        const Eigen::LLT<Eigen::MatrixXd> Ullt(U);
        const Eigen::MatrixXd Uinv = Ullt.solve(Eigen::MatrixXd::Identity(p, p));
        const Eigen::LLT<Eigen::MatrixXd> Cllt(0.5 * (Uinv + Uinv.transpose()));
        if (Ullt.info() != Eigen::Success || Cllt.info() != Eigen::Success || !Uinv.allFinite()) {
          return numerical_failure("U is not positive definite at t = " + std::to_string(t) + " s");
        }
        L = L * Eigen::MatrixXd(Cllt.matrixL());
        U.setIdentity();
      }

      // 2. Prediction of the r members, with the failure policy.
      double spread = 1.0;
      bool skip_analysis = false;
      int failed = predict(t, spread, true);
      auto first_failure = [&]() -> int {
        for (int i = 0; i < r; ++i) {
          if (!outcomes[static_cast<size_t>(i)].status.ok()) return i;
        }
        return -1;
      };
      for (const auto& o : outcomes) rec.actions.insert(rec.actions.end(), o.actions.begin(), o.actions.end());
      if (failed > 0) {
        const int i = first_failure();
        const model::Status st = outcomes[static_cast<size_t>(i)].status;
        const Eigen::VectorXd xi = x + L * V.col(i);
        const std::string who = "member " + std::to_string(i) + " failed at t = " +
                                std::to_string(t) + " s (" +
                                describe_theta(space, theta_of(xi.tail(p)), estimated) +
                                "): " + st.message;
        if (options.failure_policy == RoukfFailurePolicy::kAbort) {
          rec.actions.push_back({i, "abort", st});
          summary.steps.push_back(std::move(rec));
          return finish(RoukfTermination::kMemberFailed, who);
        }
        spread = options.shrink;
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
      first_prediction = false;
      // L = [x_i] D V^T (M&C 2011 eq. 3.9), rescaled for a shrunk spread, the fading memory and a
      // skip's inflation; HL below gets the same factor so that P and P_zz stay consistent.
      double grow = 1.0 / spread;
      if (options.forgetting < 1.0) grow /= std::sqrt(options.forgetting);
      if (skip_analysis) grow *= std::sqrt(1.0 + options.inflation);
      x = X * alpha;
      L = (X.colwise() - x) * DVt * grow;
      if (skip_analysis) {
        ++summary.skipped_analyses;
        rec.analysis_skipped = true;
        rec.actions.push_back({-1, "skipped the analysis, covariance inflated by " +
                                       std::to_string(options.inflation),
                               {}});
      }
      // U = I after every prediction (U was reset at sampling and nothing has changed it).

      // 3. Correction with the channels present at this frame.
      const Eigen::VectorXd zm = Z * alpha;
      rec.forecast = zm;
      rec.fitted = zm;
      rec.innovation = Eigen::VectorXd::Constant(m_all, std::nan(""));
      std::vector<int> present;
      for (int c = 0; c < m_all; ++c) {
        if (std::isfinite(data.values(k, c))) present.push_back(c);
      }
      const int m = static_cast<int>(present.size());
      if (m > 0) {
        Eigen::VectorXd d(m);
        Eigen::MatrixXd Rk(m, m), HL(m, p);
        const Eigen::MatrixXd HLall = (Z.colwise() - zm) * DVt * grow;
        for (int a = 0; a < m; ++a) {
          d(a) = data.values(k, present[a]) - zm(present[a]);
          HL.row(a) = HLall.row(present[a]);
          for (int b = 0; b < m; ++b) Rk(a, b) = options.R(present[a], present[b]);
        }
        const Eigen::LLT<Eigen::MatrixXd> Rllt(Rk);
        const Eigen::MatrixXd RinvHL = Rllt.solve(HL);
        const Eigen::VectorXd Rinvd = Rllt.solve(d);
        const Eigen::MatrixXd Unew = Eigen::MatrixXd::Identity(p, p) + HL.transpose() * RinvHL;
        const Eigen::LLT<Eigen::MatrixXd> Ullt(Unew);
        const Eigen::VectorXd coeff = Ullt.solve(HL.transpose() * Rinvd);
        if (Ullt.info() != Eigen::Success || !coeff.allFinite()) {
          return numerical_failure("the analysis at t = " + std::to_string(t) +
                                   " s is not finite (U = I + HL^T R^-1 HL not positive definite)");
        }
        // S^-1 d = R^-1 d - R^-1 HL U^-1 HL^T R^-1 d (Woodbury), log det S = log det R + log det U.
        const Eigen::VectorXd Sinvd = Rinvd - RinvHL * coeff;
        rec.nis = d.dot(Sinvd);
        rec.log_likelihood =
            -0.5 * (m * std::log(2.0 * std::numbers::pi) + log_det(Rllt) + log_det(Ullt) + rec.nis);
        for (int a = 0; a < m; ++a) rec.innovation(present[a]) = d(a);
        if (!skip_analysis) {
          rec.observed = m;
          x += L * coeff;
          U = Unew;
          const Eigen::VectorXd dz = HLall * coeff;
          rec.fitted = zm + dz;
        }
      }

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
  }
  summary.state = model::State{t_prev, x.head(ny)};
  summary.L = L;
  summary.U = U;
  return finish(RoukfTermination::kCompleted, "all frames assimilated");
}

double chi_square_quantile(int dof, double prob) {
  double z = 0.0;  // standard normal quantile
  if (prob == 0.025) {
    z = -1.959963984540054;
  } else if (prob == 0.975) {
    z = 1.959963984540054;
  } else {
    throw std::invalid_argument("chi_square_quantile: only the 2.5 % and 97.5 % quantiles");
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
    << std::fixed << std::setprecision(2) << wall_seconds << " s";
  if (nis_frames > 0) {
    s << ", mean NIS " << nis_mean << " (95 % band " << nis_band_lower << "-" << nis_band_upper
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
