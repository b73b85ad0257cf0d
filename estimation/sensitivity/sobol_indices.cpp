#include "estimation/sensitivity/sobol_indices.h"

#include "estimation/enum_names.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace sigmaheart::estimation::sensitivity {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Bootstrap streams live above the scramble streams (0..2p-1) of the same seed.
constexpr std::uint64_t kBootstrapStream = 1ULL << 40;

struct Indices {
  Eigen::MatrixXd S1, ST;          // p x m
  std::vector<Eigen::MatrixXd> S2;  // m of p x p (empty without second order)
  Eigen::VectorXd V;               // m
};

// The estimators on the rows `idx` (indices into 0..N-1) of every block.
Indices estimate_on(const Eigen::MatrixXd& Z, int p, int N, const std::vector<int>& idx,
                    bool second_order) {
  const int m = static_cast<int>(Z.cols());
  const auto n = static_cast<double>(idx.size());
  Indices out{Eigen::MatrixXd(p, m), Eigen::MatrixXd(p, m), {}, Eigen::VectorXd(m)};
  auto ab = [&](int i) { return static_cast<Eigen::Index>(2 + i) * N; };      // AB_i block
  auto ba = [&](int i) { return static_cast<Eigen::Index>(2 + p + i) * N; };  // BA_i block
  for (int k = 0; k < m; ++k) {
    double sum = 0.0;
    for (int j : idx) sum += Z(j, k) + Z(N + j, k);
    const double mean = sum / (2.0 * n);
    double ss = 0.0;
    for (int j : idx) {
      const double a = Z(j, k) - mean, b = Z(N + j, k) - mean;
      ss += a * a + b * b;
    }
    const double V = ss / (2.0 * n - 1.0);
    out.V(k) = V;
    for (int i = 0; i < p; ++i) {
      const Eigen::Index off = ab(i);
      double s1 = 0.0, st = 0.0;
      for (int j : idx) {
        const double fA = Z(j, k), fB = Z(N + j, k), fAB = Z(off + j, k);
        s1 += (fB - mean) * (fAB - fA);  // centred: see the header
        st += (fA - fAB) * (fA - fAB);
      }
      out.S1(i, k) = V > 0 ? s1 / n / V : kNaN;
      out.ST(i, k) = V > 0 ? st / (2.0 * n) / V : kNaN;
    }
    if (!second_order) continue;
    Eigen::MatrixXd S2 = Eigen::MatrixXd::Constant(p, p, kNaN);
    double ab_product = 0.0;  // sum of (f_A - mean)(f_B - mean)
    for (int j : idx) ab_product += (Z(j, k) - mean) * (Z(N + j, k) - mean);
    for (int i = 0; i < p; ++i) {
      for (int l = i + 1; l < p; ++l) {
        const Eigen::Index bai = ba(i), abl = ab(l);
        double cross = 0.0;
        for (int j : idx) cross += (Z(bai + j, k) - mean) * (Z(abl + j, k) - mean);
        S2(i, l) = V > 0 ? (cross - ab_product) / n / V - out.S1(i, k) - out.S1(l, k) : kNaN;
      }
    }
    out.S2.push_back(std::move(S2));
  }
  return out;
}

}  // namespace

SIGMAHEART_ENUM_TEXT(SobolFailurePolicy, parse_sobol_failure_policy,
    {SobolFailurePolicy::kStop, "stop"}, {SobolFailurePolicy::kImputeMean, "impute-mean"},
    {SobolFailurePolicy::kImputeMean, "impute_mean"})

std::int64_t sobol_runs(int p, std::int64_t N, bool second_order) {
  return N * (second_order ? 2 * static_cast<std::int64_t>(p) + 2 : static_cast<std::int64_t>(p) + 2);
}

std::string SobolOptions::validate(int p) const {
  std::ostringstream s;
  if (p < 1 || 2 * p > kMaxSobolDimension) {
    s << "Sobol' study: " << p << " parameters; supported are 1.." << kMaxSobolDimension / 2
      << " (the design needs a Sobol' sequence of dimension 2p)";
    return s.str();
  }
  if (base_samples < 16 || !is_power_of_two(static_cast<std::uint64_t>(base_samples))) {
    s << "Sobol' study: base_samples must be a power of two >= 16, got " << base_samples;
    return s.str();
  }
  if (second_order && p < 2) return "Sobol' study: second_order needs at least 2 parameters";
  if (bootstrap_samples < 0) return "Sobol' study: bootstrap_samples must be >= 0";
  if (!(confidence > 0.0 && confidence < 1.0)) return "Sobol' study: confidence must be in (0, 1)";
  if (convergence_levels < 1) return "Sobol' study: convergence_levels must be >= 1";
  return ensemble.validate();
}

Eigen::MatrixXd saltelli_design(int p, int N, Scrambling scrambling, std::uint64_t seed,
                                bool second_order) {
  SobolSequenceOptions so;
  so.dimension = 2 * p;
  so.scrambling = scrambling;
  so.seed = seed;
  const SobolSequence seq(so);
  const Eigen::MatrixXd P = seq.points(0, static_cast<std::uint64_t>(N));
  Eigen::MatrixXd U(static_cast<Eigen::Index>(sobol_runs(p, N, second_order)), p);
  const Eigen::MatrixXd A = P.leftCols(p);
  const Eigen::MatrixXd B = P.rightCols(p);
  U.topRows(N) = A;
  U.middleRows(N, N) = B;
  for (int i = 0; i < p; ++i) {
    auto ABi = U.middleRows(static_cast<Eigen::Index>(2 + i) * N, N);
    ABi = A;
    ABi.col(i) = B.col(i);
  }
  if (!second_order) return U;
  for (int i = 0; i < p; ++i) {
    auto BAi = U.middleRows(static_cast<Eigen::Index>(2 + p + i) * N, N);
    BAi = B;
    BAi.col(i) = A.col(i);
  }
  return U;
}

SobolEstimate sobol_estimate(const Eigen::MatrixXd& Z, int p, int N, int n_used,
                             const SobolOptions& options) {
  const bool second = options.second_order;
  if (Z.rows() != sobol_runs(p, N, second) || n_used < 2 || n_used > N) {
    throw std::invalid_argument(std::string("sobol_estimate: outputs do not match an ") +
                                (second ? "N (2p + 2)" : "N (p + 2)") + " design");
  }
  const int m = static_cast<int>(Z.cols());
  std::vector<int> rows(static_cast<size_t>(n_used));
  for (int j = 0; j < n_used; ++j) rows[static_cast<size_t>(j)] = j;
  Indices point = estimate_on(Z, p, N, rows, second);

  SobolEstimate e;
  e.n = n_used;
  e.S1 = point.S1;
  e.ST = point.ST;
  e.S2 = std::move(point.S2);
  e.variance = point.V;
  e.output_std = point.V.cwiseMax(0.0).cwiseSqrt();
  e.S1_low = e.S1_high = e.ST_low = e.ST_high = Eigen::MatrixXd::Constant(p, m, kNaN);
  e.S1_conf = e.ST_conf = Eigen::MatrixXd::Constant(p, m, kNaN);
  if (second) e.S2_conf.assign(static_cast<size_t>(m), Eigen::MatrixXd::Constant(p, p, kNaN));
  const int B = options.bootstrap_samples;
  if (B == 0) return e;

  // Replicate b resamples n_used rows with replacement from make_stream(s_n, b), s_n depending
  // on the seed and the prefix size only: identical for any thread count. Replicates are
  // computed in parallel chunks and reduced in replicate order (the same bits for any thread
  // count), so memory stays at one chunk of second-order tables.
  const std::uint64_t s_n = stream_seed(options.seed, kBootstrapStream + static_cast<std::uint64_t>(n_used));
  const auto pm = static_cast<size_t>(p) * static_cast<size_t>(m);
  std::vector<double> s1(pm * static_cast<size_t>(B)), st(pm * static_cast<size_t>(B));
  auto at = [&](int i, int k, int b) {
    return (static_cast<size_t>(k) * static_cast<size_t>(p) + static_cast<size_t>(i)) * static_cast<size_t>(B) +
           static_cast<size_t>(b);
  };
  // Second order: running mean and sum of squared deviations (Welford) per entry.
  std::vector<Eigen::MatrixXd> s2_mean, s2_m2;
  std::vector<Eigen::MatrixXi> s2_count;
  if (second) {
    s2_mean.assign(static_cast<size_t>(m), Eigen::MatrixXd::Zero(p, p));
    s2_m2 = s2_mean;
    s2_count.assign(static_cast<size_t>(m), Eigen::MatrixXi::Zero(p, p));
  }
  constexpr int kChunk = 64;
  std::vector<Indices> reps(static_cast<size_t>(std::min(B, kChunk)));
  for (int first = 0; first < B; first += kChunk) {
    const int count = std::min(kChunk, B - first);
#pragma omp parallel for schedule(static)
    for (int c = 0; c < count; ++c) {
      std::mt19937_64 rng = make_stream(s_n, static_cast<std::uint64_t>(first + c));
      std::vector<int> idx(static_cast<size_t>(n_used));
      for (auto& j : idx) j = uniform_index(rng, n_used);
      reps[static_cast<size_t>(c)] = estimate_on(Z, p, N, idx, second);
    }
    for (int c = 0; c < count; ++c) {
      const Indices& r = reps[static_cast<size_t>(c)];
      for (int k = 0; k < m; ++k) {
        for (int i = 0; i < p; ++i) {
          s1[at(i, k, first + c)] = r.S1(i, k);
          st[at(i, k, first + c)] = r.ST(i, k);
        }
        if (!second) continue;
        const auto kk = static_cast<size_t>(k);
        for (int i = 0; i < p; ++i) {
          for (int l = i + 1; l < p; ++l) {
            const double v = r.S2[kk](i, l);
            if (!std::isfinite(v)) continue;
            const int nn = ++s2_count[kk](i, l);
            const double d = v - s2_mean[kk](i, l);
            s2_mean[kk](i, l) += d / nn;
            s2_m2[kk](i, l) += d * (v - s2_mean[kk](i, l));
          }
        }
      }
    }
  }
  const double z = normal_quantile(0.5 + options.confidence / 2.0);
  for (int k = 0; k < m; ++k) {
    for (int i = 0; i < p; ++i) {
      const auto b0 = s1.begin() + static_cast<std::ptrdiff_t>(at(i, k, 0));
      const std::vector<double> s1_b(b0, b0 + B);
      const auto t0 = st.begin() + static_cast<std::ptrdiff_t>(at(i, k, 0));
      const std::vector<double> st_b(t0, t0 + B);
      std::tie(e.S1_low(i, k), e.S1_high(i, k)) = percentile_interval(s1_b, options.confidence);
      std::tie(e.ST_low(i, k), e.ST_high(i, k)) = percentile_interval(st_b, options.confidence);
      e.S1_conf(i, k) = z * finite_std(s1_b);
      e.ST_conf(i, k) = z * finite_std(st_b);
    }
    if (!second) continue;
    const auto kk = static_cast<size_t>(k);
    for (int i = 0; i < p; ++i) {
      for (int l = i + 1; l < p; ++l) {
        const int nn = s2_count[kk](i, l);
        if (nn >= 2) e.S2_conf[kk](i, l) = z * std::sqrt(s2_m2[kk](i, l) / (nn - 1));
      }
    }
  }
  return e;
}

DesignLayout sobol_layout(int N, const std::vector<std::string>& names, bool second_order) {
  DesignLayout l;
  l.description = second_order
                      ? "N (2p + 2) runs in blocks A, B, AB_1..AB_p, BA_1..BA_p (AB_i: A with column i "
                        "from B; BA_i: B with column i from A); row = design row j in 0..N-1"
                      : "N (p + 2) runs in blocks A, B, AB_1..AB_p (AB_i: A with column i from B); "
                        "row = design row j in 0..N-1";
  auto add = [&](const std::string& b) {
    for (int j = 0; j < N; ++j) {
      l.block.push_back(b);
      l.row.push_back(j);
    }
  };
  add("A");
  add("B");
  for (size_t i = 0; i < names.size(); ++i) add("AB_" + std::to_string(i + 1) + " (" + names[i] + ")");
  if (second_order) {
    for (size_t i = 0; i < names.size(); ++i) add("BA_" + std::to_string(i + 1) + " (" + names[i] + ")");
  }
  return l;
}

SobolSummary run_sobol(const ForwardModel& model, const Prior& prior, const SobolOptions& options) {
  if (const std::string m = validate_prior(prior, model); !m.empty()) {
    throw std::invalid_argument("Sobol' study: " + m);
  }
  const int p = prior.size();
  if (const std::string m = options.validate(p); !m.empty()) throw std::invalid_argument(m);
  const int N = options.base_samples;

  SobolSummary r;
  r.parameters = prior.names();
  r.outputs = output_names(model);
  r.N = N;
  r.second_order = options.second_order;
  r.runs = static_cast<int>(sobol_runs(p, N, options.second_order));
  r.thetas = prior.unit_to_theta(saltelli_design(p, N, options.scrambling, options.seed, options.second_order));
  r.layout = sobol_layout(N, r.parameters, options.second_order);
  const std::vector<bool> ok = evaluate_design(model, options.ensemble, r);

  Eigen::MatrixXd Zuse = r.Z;
  if (!r.failed_runs.empty()) {
    std::ostringstream s;
    s << r.failed_runs.size() << " of " << r.runs << " runs failed";
    const bool all_failed = static_cast<int>(r.failed_runs.size()) == r.runs;
    if (options.failure_policy == SobolFailurePolicy::kStop || all_failed) {
      s << "; policy '" << to_string(options.failure_policy)
        << "': no indices computed (a Saltelli design cannot drop rows)";
      r.status = StudyStatus::kFailedRuns;
      r.message = s.str();
      return r;
    }
    for (Eigen::Index k = 0; k < Zuse.cols(); ++k) {
      double sum = 0.0;
      int count = 0;
      for (int run = 0; run < r.runs; ++run) {
        if (ok[static_cast<size_t>(run)]) {
          sum += Zuse(run, k);
          ++count;
        }
      }
      for (const FailedRun& f : r.failed_runs) Zuse(f.run, k) = sum / count;
    }
    s << "; policy 'impute-mean': their outputs were replaced by the mean of the successful runs";
    r.imputed = true;
    r.message = s.str();
  }

  for (int level = 0, n = N; level < options.convergence_levels && n >= 16; ++level, n /= 2) {
    r.convergence.push_back(sobol_estimate(Zuse, p, N, n, options));
  }
  r.estimate = r.convergence.front();
  for (Eigen::Index k = 0; k < r.estimate.variance.size(); ++k) {
    if (!(r.estimate.variance(k) > 0)) r.constant_outputs.push_back(r.outputs[static_cast<size_t>(k)]);
  }
  return r;
}

std::string SobolSummary::report() const {
  std::ostringstream s;
  s << "Sobol' indices: " << parameters.size() << " parameters, " << outputs.size()
    << " outputs, N = " << N << ", " << runs << " runs (Saltelli 2010 S1, Jansen ST"
    << (second_order ? ", Saltelli 2002 S2" : "") << ")\n";
  if (!failed_runs.empty()) {
    s << message << "\n";
    const size_t shown = std::min<size_t>(failed_runs.size(), 10);
    for (size_t i = 0; i < shown; ++i) {
      const FailedRun& f = failed_runs[i];
      s << "  run " << f.run << " (block " << f.block << ", row " << f.design_row << "): "
        << model::to_string(f.status.code) << " " << f.status.message << "; theta =";
      for (Eigen::Index j = 0; j < f.theta.size(); ++j) s << " " << f.theta(j);
      s << "\n";
    }
    if (shown < failed_runs.size()) s << "  ... " << failed_runs.size() - shown << " more\n";
  }
  if (!ok()) {
    s << "INVALID: no indices\n";
    return s.str();
  }
  for (const auto& c : constant_outputs) s << "output '" << c << "' is constant: indices NaN\n";
  s << std::fixed << std::setprecision(4);
  for (size_t k = 0; k < outputs.size(); ++k) {
    s << "output '" << outputs[k] << "'\n";
    for (size_t i = 0; i < parameters.size(); ++i) {
      const auto ii = static_cast<Eigen::Index>(i), kk = static_cast<Eigen::Index>(k);
      s << "  " << std::setw(14) << std::left << parameters[i] << std::right << " S1 "
        << std::setw(8) << estimate.S1(ii, kk) << " +- " << estimate.S1_conf(ii, kk) << "  ST "
        << std::setw(8) << estimate.ST(ii, kk) << " +- " << estimate.ST_conf(ii, kk) << "\n";
    }
  }
  return s.str();
}

}  // namespace sigmaheart::estimation::sensitivity
