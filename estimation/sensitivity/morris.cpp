#include "estimation/sensitivity/morris.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <tuple>

namespace sigmaheart::estimation::sensitivity {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint64_t kBootstrapStream = 1ULL << 40;

struct Stats {
  Eigen::MatrixXd mu, mu_star, sigma;
};

Stats statistics(const std::vector<Eigen::MatrixXd>& effects, const std::vector<int>& pick) {
  const Eigen::Index p = effects.front().rows(), m = effects.front().cols();
  const auto r = static_cast<double>(pick.size());
  Stats s{Eigen::MatrixXd::Zero(p, m), Eigen::MatrixXd::Zero(p, m), Eigen::MatrixXd::Zero(p, m)};
  for (int t : pick) {
    s.mu += effects[static_cast<size_t>(t)];
    s.mu_star += effects[static_cast<size_t>(t)].cwiseAbs();
  }
  s.mu /= r;
  s.mu_star /= r;
  if (pick.size() < 2) {
    s.sigma.setConstant(kNaN);
    return s;
  }
  for (int t : pick) s.sigma += (effects[static_cast<size_t>(t)] - s.mu).cwiseAbs2();
  s.sigma = (s.sigma / (r - 1.0)).cwiseSqrt();
  return s;
}

}  // namespace

std::string MorrisOptions::validate() const {
  if (trajectories < 1) return "Morris study: trajectories must be >= 1";
  if (levels < 2 || levels % 2 != 0) {
    return "Morris study: levels must be even and >= 2 (Delta = L / (2 (L - 1)) must lie on the "
           "grid), got " + std::to_string(levels);
  }
  if (bootstrap_samples < 0) return "Morris study: bootstrap_samples must be >= 0";
  if (!(confidence > 0.0 && confidence < 1.0)) return "Morris study: confidence must be in (0, 1)";
  return ensemble.validate();
}

Eigen::MatrixXd morris_design(int p, const MorrisOptions& options) {
  const int L = options.levels;
  const int jump = L / 2;  // Delta in grid steps
  const double step = 1.0 / (L - 1);
  Eigen::MatrixXd U(static_cast<Eigen::Index>(options.trajectories) * (p + 1), p);
  for (int t = 0; t < options.trajectories; ++t) {
    std::mt19937_64 rng = make_stream(options.seed, static_cast<std::uint64_t>(t));
    std::vector<int> dir(static_cast<size_t>(p)), level(static_cast<size_t>(p));
    for (int i = 0; i < p; ++i) {
      const bool up = (rng() >> 63) == 0;
      dir[static_cast<size_t>(i)] = up ? 1 : -1;
      // Up: base in levels 0..L-1-jump; down: base in jump..L-1.
      level[static_cast<size_t>(i)] = uniform_index(rng, L - jump) + (up ? 0 : jump);
    }
    std::vector<int> order(static_cast<size_t>(p));
    std::iota(order.begin(), order.end(), 0);
    for (int i = p - 1; i > 0; --i) {  // Fisher-Yates
      std::swap(order[static_cast<size_t>(i)], order[static_cast<size_t>(uniform_index(rng, i + 1))]);
    }
    const Eigen::Index row0 = static_cast<Eigen::Index>(t) * (p + 1);
    for (int i = 0; i < p; ++i) U(row0, i) = level[static_cast<size_t>(i)] * step;
    for (int s = 0; s < p; ++s) {
      U.row(row0 + s + 1) = U.row(row0 + s);
      const int i = order[static_cast<size_t>(s)];
      level[static_cast<size_t>(i)] += dir[static_cast<size_t>(i)] * jump;
      U(row0 + s + 1, i) = level[static_cast<size_t>(i)] * step;
    }
  }
  return U;
}

DesignLayout morris_layout(int trajectories, int p) {
  DesignLayout l;
  l.description = "r (p + 1) runs, trajectory-major; row = step within the trajectory";
  for (int t = 0; t < trajectories; ++t) {
    for (int s = 0; s <= p; ++s) {
      l.block.push_back("trajectory " + std::to_string(t));
      l.row.push_back(s);
    }
  }
  return l;
}

MorrisSummary run_morris(const ForwardModel& model, const Prior& prior, const MorrisOptions& options) {
  check_study_inputs("Morris study", prior, model, options.validate());
  const int p = prior.size();
  const int r = options.trajectories;

  MorrisSummary res;
  res.parameters = prior.names();
  res.outputs = output_names(model);
  const int m = static_cast<int>(res.outputs.size());
  res.trajectories_requested = r;
  res.unit_design = morris_design(p, options);
  res.thetas = prior.unit_to_theta(res.unit_design);
  res.layout = morris_layout(r, p);
  const std::vector<bool> ok_run = evaluate_design(model, options.ensemble, res);

  for (int t = 0; t < r; ++t) {
    bool ok = true;
    for (int s = 0; s <= p; ++s) ok = ok && ok_run[static_cast<size_t>(t * (p + 1) + s)];
    if (!ok) {
      res.dropped_trajectories.push_back(t);
      continue;
    }
    res.used_trajectories.push_back(t);
    Eigen::MatrixXd ee(p, m);
    for (int s = 0; s < p; ++s) {
      const int run = t * (p + 1) + s;
      const Eigen::RowVectorXd du = res.unit_design.row(run + 1) - res.unit_design.row(run);
      Eigen::Index i = 0;
      du.cwiseAbs().maxCoeff(&i);
      ee.row(i) = (res.Z.row(run + 1) - res.Z.row(run)) / du(i);
    }
    res.effects.push_back(std::move(ee));
  }

  if (!res.dropped_trajectories.empty()) {
    res.message = std::to_string(res.dropped_trajectories.size()) + " of " + std::to_string(r) +
                  " trajectories dropped for failed runs";
  }
  const int used = static_cast<int>(res.effects.size());
  const Eigen::MatrixXd nan = Eigen::MatrixXd::Constant(p, m, kNaN);
  res.mu_low = res.mu_high = res.mu_star_low = res.mu_star_high = res.sigma_low = res.sigma_high = nan;
  if (used == 0) {
    res.status = StudyStatus::kFailedRuns;
    res.message += res.message.empty() ? "no trajectory" : "; no trajectory left";
    res.mu = res.mu_star = res.sigma = nan;
    return res;
  }
  std::vector<int> all(static_cast<size_t>(used));
  std::iota(all.begin(), all.end(), 0);
  const Stats s = statistics(res.effects, all);
  res.mu = s.mu;
  res.mu_star = s.mu_star;
  res.sigma = s.sigma;

  const int B = options.bootstrap_samples;
  if (B == 0) return res;
  std::vector<Stats> reps(static_cast<size_t>(B));
  const std::uint64_t sb = stream_seed(options.seed, kBootstrapStream);
#pragma omp parallel for schedule(static)
  for (int b = 0; b < B; ++b) {
    std::mt19937_64 rng = make_stream(sb, static_cast<std::uint64_t>(b));
    std::vector<int> pick(static_cast<size_t>(used));
    for (auto& t : pick) t = uniform_index(rng, used);
    reps[static_cast<size_t>(b)] = statistics(res.effects, pick);
  }
  std::vector<double> v(static_cast<size_t>(B));
  auto interval = [&](auto member, Eigen::MatrixXd& lo, Eigen::MatrixXd& hi) {
    for (int i = 0; i < p; ++i) {
      for (int k = 0; k < m; ++k) {
        for (int b = 0; b < B; ++b) v[static_cast<size_t>(b)] = (reps[static_cast<size_t>(b)].*member)(i, k);
        std::tie(lo(i, k), hi(i, k)) = percentile_interval(v, options.confidence);
      }
    }
  };
  interval(&Stats::mu, res.mu_low, res.mu_high);
  interval(&Stats::mu_star, res.mu_star_low, res.mu_star_high);
  interval(&Stats::sigma, res.sigma_low, res.sigma_high);
  return res;
}

std::string MorrisSummary::report() const {
  std::ostringstream s;
  s << "Morris elementary effects: " << parameters.size() << " parameters, " << outputs.size()
    << " outputs, " << used_trajectories.size() << " of " << trajectories_requested
    << " trajectories used, " << thetas.rows() << " runs\n";
  if (!message.empty()) s << message << "\n";
  for (int t : dropped_trajectories) s << "  dropped trajectory " << t << "\n";
  for (const FailedRun& f : failed_runs) {
    s << "  failed: " << f.block << " step " << f.design_row << ": "
      << model::to_string(f.status.code) << " " << f.status.message << "\n";
  }
  if (!ok()) return s.str() + "INVALID: no statistics\n";
  s << std::setprecision(4);
  for (int k = 0; k < static_cast<int>(outputs.size()); ++k) {
    s << "output '" << outputs[static_cast<size_t>(k)] << "'\n";
    for (int i : ranking(k)) {
      s << "  " << std::setw(14) << std::left << parameters[static_cast<size_t>(i)] << std::right
        << " mu* " << std::setw(10) << mu_star(i, k) << " [" << mu_star_low(i, k) << ", "
        << mu_star_high(i, k) << "]  mu " << std::setw(10) << mu(i, k) << "  sigma "
        << std::setw(10) << sigma(i, k) << "\n";
    }
  }
  return s.str();
}

}  // namespace sigmaheart::estimation::sensitivity
