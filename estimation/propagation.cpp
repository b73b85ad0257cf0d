#include "estimation/propagation.h"

#include "estimation/enum_names.h"
#include "estimation/sensitivity/design.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

namespace {

constexpr int kLargestDraws = 20000;
constexpr std::uint64_t kMonteCarloStream = 0, kLargestStream = 1;

// Standard normal pairs by Marsaglia's polar method on a seeded mt19937_64 (written out: the
// algorithm of std::normal_distribution is the library's, so its draws differ between libraries).
class PolarNormal {
 public:
  explicit PolarNormal(std::mt19937_64 engine) : rng_(std::move(engine)) {}
  double next() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    double u = 0.0, v = 0.0, s = 0.0;
    do {
      u = 2.0 * ((static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53) - 1.0;
      v = 2.0 * ((static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53) - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    have_spare_ = true;
    return u * f;
  }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool have_spare_ = false;
};

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// The q-quantile of sorted values (linear interpolation between order statistics, type 7).
double quantile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto i = static_cast<size_t>(std::floor(pos));
  const double w = pos - static_cast<double>(i);
  return i + 1 < sorted.size() ? (1.0 - w) * sorted[i] + w * sorted[i + 1] : sorted[i];
}

std::vector<int> finite_rows(const Eigen::MatrixXd& Y) {
  std::vector<int> rows;
  for (Eigen::Index i = 0; i < Y.rows(); ++i)
    if (Y.row(i).allFinite()) rows.push_back(static_cast<int>(i));
  return rows;
}

}  // namespace

SIGMAHEART_ENUM_TEXT(PropagationMethod, parse_propagation_method,
    {PropagationMethod::kUnscented, "unscented"},
    {PropagationMethod::kMonteCarlo, "monte-carlo"},
    {PropagationMethod::kPoint, "point"})

Eigen::VectorXd Posterior::theta(const Eigen::Ref<const Eigen::VectorXd>& eta) const {
  Eigen::VectorXd out(eta.size());
  for (Eigen::Index j = 0; j < eta.size(); ++j) out(j) = transforms[static_cast<size_t>(j)].to_theta(eta(j));
  return out;
}

std::string Posterior::validate() const {
  const auto p = static_cast<Eigen::Index>(names.size());
  std::ostringstream s;
  if (p == 0) return "the posterior has no parameters";
  if (static_cast<Eigen::Index>(transforms.size()) != p || eta_mean.size() != p || eta_covariance.rows() != p ||
      eta_covariance.cols() != p || (!units.empty() && static_cast<Eigen::Index>(units.size()) != p)) {
    s << "sizes disagree: " << p << " names, " << transforms.size() << " transforms, mean of " << eta_mean.size()
      << ", covariance " << eta_covariance.rows() << " x " << eta_covariance.cols();
    return s.str();
  }
  if (!eta_mean.allFinite() || !eta_covariance.allFinite()) return "the posterior mean or covariance is not finite";
  if ((eta_covariance - eta_covariance.transpose()).cwiseAbs().maxCoeff() >
      1e-9 * std::max(1.0, eta_covariance.cwiseAbs().maxCoeff()))
    return "the posterior covariance is not symmetric";
  for (Eigen::Index j = 0; j < p; ++j) {
    if (eta_covariance(j, j) < 0.0) return "parameter '" + names[static_cast<size_t>(j)] + "': negative variance";
    if (const std::string t = transforms[static_cast<size_t>(j)].validate(); !t.empty())
      return "parameter '" + names[static_cast<size_t>(j)] + "': " + t;
  }
  return {};
}

std::string PropagationOptions::validate(int p) const {
  std::ostringstream s;
  if (!(interval > 0.0 && interval < 1.0)) {
    s << "interval = " << interval << " must lie in (0, 1)";
    return s.str();
  }
  if (method == PropagationMethod::kMonteCarlo && (samples < 10 || samples > 1000000)) {
    s << "samples = " << samples << " must lie in [10, 1000000]";
    return s.str();
  }
  if (method == PropagationMethod::kUnscented) return sigma.validate(p);
  return {};
}

PropagationPoints propagation_points(const Posterior& posterior, const PropagationOptions& options) {
  if (const std::string m = posterior.validate(); !m.empty()) throw std::invalid_argument("posterior: " + m);
  const int p = posterior.size();
  if (const std::string m = options.validate(p); !m.empty()) throw std::invalid_argument("propagation: " + m);
  PropagationPoints out;
  out.method = options.method;
  if (options.method == PropagationMethod::kPoint) {
    out.eta = posterior.eta_mean.transpose();
    out.wm = out.wc = Eigen::VectorXd::Ones(1);
  } else if (options.method == PropagationMethod::kUnscented) {
    const SigmaPoints sp = make_sigma_points(p, options.sigma);
    out.eta = place_points(posterior.eta_mean, covariance_sqrt(posterior.eta_covariance), sp).transpose();
    out.wm = sp.wm;
    out.wc = sp.wc;
  } else {
    const Eigen::MatrixXd S = covariance_sqrt(posterior.eta_covariance);
    PolarNormal normal(sensitivity::make_stream(options.seed, kMonteCarloStream));
    out.eta.resize(options.samples, p);
    for (int i = 0; i < options.samples; ++i) {
      Eigen::VectorXd z(p);
      for (int j = 0; j < p; ++j) z(j) = normal.next();
      out.eta.row(i) = (posterior.eta_mean + S * z).transpose();
    }
    out.wm = Eigen::VectorXd::Constant(options.samples, 1.0 / options.samples);
    out.wc = Eigen::VectorXd::Constant(options.samples, 1.0 / (options.samples - 1));
  }
  out.theta.resize(out.eta.rows(), p);
  for (Eigen::Index i = 0; i < out.eta.rows(); ++i) out.theta.row(i) = posterior.theta(out.eta.row(i).transpose()).transpose();
  return out;
}

ResponseMoments response_moments(const PropagationPoints& points, const Eigen::MatrixXd& Y,
                                 const PropagationOptions& options) {
  if (Y.rows() != points.count())
    throw std::invalid_argument("response_moments: " + std::to_string(Y.rows()) + " rows for " +
                                std::to_string(points.count()) + " points");
  const Eigen::Index r = Y.cols();
  ResponseMoments m;
  const std::vector<int> rows = finite_rows(Y);
  m.failed_points = points.count() - static_cast<int>(rows.size());
  const double nan = std::nan("");
  auto fail = [&] {
    m.ok = false;
    m.mean = m.std = m.lower = m.upper = Eigen::VectorXd::Constant(r, nan);
    m.covariance = Eigen::MatrixXd::Constant(r, r, nan);
    return m;
  };
  if (points.method != PropagationMethod::kMonteCarlo) {
    if (m.failed_points > 0) return fail();
    m.mean = Y.transpose() * points.wm;
    const Eigen::MatrixXd D = Y.rowwise() - m.mean.transpose();
    m.covariance = D.transpose() * points.wc.asDiagonal() * D;
    m.std = m.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    const double z = sensitivity::normal_quantile(0.5 + 0.5 * options.interval);
    m.lower = m.mean - z * m.std;
    m.upper = m.mean + z * m.std;
    return m;
  }
  if (rows.size() < 2) return fail();
  Eigen::MatrixXd F(static_cast<Eigen::Index>(rows.size()), r);
  for (size_t i = 0; i < rows.size(); ++i) F.row(static_cast<Eigen::Index>(i)) = Y.row(rows[i]);
  m.mean = F.colwise().mean().transpose();
  const Eigen::MatrixXd D = F.rowwise() - m.mean.transpose();
  m.covariance = D.transpose() * D / static_cast<double>(F.rows() - 1);
  m.std = m.covariance.diagonal().cwiseSqrt();
  m.lower.resize(r);
  m.upper.resize(r);
  for (Eigen::Index j = 0; j < r; ++j) {
    std::vector<double> v(F.col(j).data(), F.col(j).data() + F.rows());
    std::sort(v.begin(), v.end());
    m.lower(j) = quantile(v, 0.5 - 0.5 * options.interval);
    m.upper(j) = quantile(v, 0.5 + 0.5 * options.interval);
  }
  return m;
}

void add_response_error(ResponseMoments& m, const PropagationPoints& points, const Eigen::MatrixXd& Y,
                        Eigen::Index j, double sd, const PropagationOptions& options) {
  if (!(sd >= 0.0 && std::isfinite(sd))) throw std::invalid_argument("add_response_error: sd must be >= 0");
  if (j < 0 || j >= Y.cols()) throw std::invalid_argument("add_response_error: no response column " + std::to_string(j));
  if (m.error_sd.size() != Y.cols()) m.error_sd = Eigen::VectorXd::Zero(Y.cols());
  const double previous = m.error_sd(j);
  m.error_sd(j) = std::sqrt(previous * previous + sd * sd);
  if (!m.ok || sd == 0.0) return;
  m.covariance(j, j) += sd * sd;
  m.std(j) = std::sqrt(std::max(0.0, m.covariance(j, j)));
  if (points.method != PropagationMethod::kMonteCarlo) {
    const double z = sensitivity::normal_quantile(0.5 + 0.5 * options.interval);
    m.lower(j) = m.mean(j) - z * m.std(j);
    m.upper(j) = m.mean(j) + z * m.std(j);
    return;
  }
  // The mixture F(x) = mean_i Phi((x - y_i) / e) of the finite rows, e the whole added error.
  std::vector<double> y;
  for (Eigen::Index i = 0; i < Y.rows(); ++i)
    if (Y.row(i).allFinite()) y.push_back(Y(i, j));
  const double e = m.error_sd(j);
  auto cdf = [&](double x) {
    double sum = 0.0;
    for (double v : y) sum += normal_cdf((x - v) / e);
    return sum / static_cast<double>(y.size());
  };
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  auto solve = [&](double q) {
    double a = *lo - 10.0 * e, b = *hi + 10.0 * e;  // F(a) < 1e-20 < q < 1 - 1e-20 < F(b)
    for (int it = 0; it < 200 && b - a > 1e-12 * (1.0 + std::abs(a) + std::abs(b)); ++it) {
      const double c = 0.5 * (a + b);
      (cdf(c) < q ? a : b) = c;
    }
    return 0.5 * (a + b);
  };
  m.lower(j) = solve(0.5 - 0.5 * options.interval);
  m.upper(j) = solve(0.5 + 0.5 * options.interval);
}

Eigen::VectorXd probability_above(const PropagationPoints& points, const Eigen::MatrixXd& Y,
                                  const ResponseMoments& moments, double threshold,
                                  const PropagationOptions& options) {
  (void)options;
  const Eigen::Index r = Y.cols();
  Eigen::VectorXd p = Eigen::VectorXd::Constant(r, std::nan(""));
  if (!moments.ok) return p;
  for (Eigen::Index j = 0; j < r; ++j) {
    if (points.method == PropagationMethod::kMonteCarlo) {
      const double e = moments.error_sd.size() == r ? moments.error_sd(j) : 0.0;
      double above = 0.0;
      int n = 0;
      for (Eigen::Index i = 0; i < Y.rows(); ++i) {
        if (!Y.row(i).allFinite()) continue;
        ++n;
        above += e > 0.0 ? normal_cdf((Y(i, j) - threshold) / e) : (Y(i, j) > threshold ? 1.0 : 0.0);
      }
      p(j) = above / n;
    } else if (moments.std(j) > 0.0) {
      p(j) = normal_cdf((moments.mean(j) - threshold) / moments.std(j));
    } else {
      p(j) = moments.mean(j) > threshold ? 1.0 : 0.0;
    }
  }
  return p;
}

Eigen::VectorXd probability_largest(const PropagationPoints& points, const Eigen::MatrixXd& Y,
                                    const ResponseMoments& moments, const PropagationOptions& options) {
  const Eigen::Index r = Y.cols();
  Eigen::VectorXd count = Eigen::VectorXd::Zero(r);
  if (!moments.ok || r == 0) return Eigen::VectorXd::Constant(r, std::nan(""));
  auto vote = [&](const Eigen::VectorXd& y) {
    Eigen::Index best = 0;
    y.maxCoeff(&best);  // first of equal maxima
    count(best) += 1.0;
  };
  const bool added = moments.error_sd.size() == r && moments.error_sd.maxCoeff() > 0.0;
  if (points.method == PropagationMethod::kMonteCarlo && added) {
    // Each finite row with draws of the independent errors, about kLargestDraws votes in all.
    std::vector<int> rows = finite_rows(Y);
    const int per_row = std::max(1, kLargestDraws / std::max<int>(1, static_cast<int>(rows.size())));
    PolarNormal normal(sensitivity::make_stream(options.seed, kLargestStream));
    Eigen::VectorXd y(r);
    for (int i : rows)
      for (int k = 0; k < per_row; ++k) {
        for (Eigen::Index j = 0; j < r; ++j) y(j) = Y(i, j) + moments.error_sd(j) * normal.next();
        vote(y);
      }
  } else if (points.method == PropagationMethod::kMonteCarlo) {
    for (Eigen::Index i = 0; i < Y.rows(); ++i)
      if (Y.row(i).allFinite()) vote(Y.row(i).transpose());
  } else if (moments.covariance.cwiseAbs().maxCoeff() == 0.0) {
    vote(moments.mean);
  } else {
    const Eigen::MatrixXd S = covariance_sqrt(moments.covariance);
    PolarNormal normal(sensitivity::make_stream(options.seed, kLargestStream));
    Eigen::VectorXd z(r);
    for (int k = 0; k < kLargestDraws; ++k) {
      for (Eigen::Index j = 0; j < r; ++j) z(j) = normal.next();
      vote(moments.mean + S * z);
    }
  }
  return count / count.sum();
}

}  // namespace sigmaheart::estimation
