#include "estimation/specificity/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <utility>
#include <vector>

namespace sigmaheart::estimation::specificity {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The continued fraction for I_x(a, b) (Press et al. 2007, eq. 6.4.5), by modified Lentz.
double beta_continued_fraction(double a, double b, double x) {
  constexpr int kMaxIterations = 10000;
  constexpr double kEps = 1e-15;
  constexpr double kTiny = 1e-300;
  const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
  double c = 1.0;
  double d = 1.0 - qab * x / qap;
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= kMaxIterations; ++m) {
    const double m2 = 2.0 * m;
    // Even step: d_{2m} = m (b - m) x / ((a + 2m - 1)(a + 2m)).
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    // Odd step: d_{2m+1} = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < kEps) return h;
  }
  return h;  // not reached for the arguments used here (a, b <= ~1e6)
}

double log_binomial(int n, int k) {
  return std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0);
}

}  // namespace

double regularized_incomplete_beta(double a, double b, double x) {
  if (!(a > 0.0 && b > 0.0) || !(x >= 0.0 && x <= 1.0)) {
    throw std::domain_error("regularized_incomplete_beta: needs a, b > 0 and x in [0, 1]");
  }
  if (x == 0.0) return 0.0;
  if (x == 1.0) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) +
                           b * std::log1p(-x);
  const double front = std::exp(log_front);
  if (x < (a + 1.0) / (a + b + 2.0)) return front * beta_continued_fraction(a, b, x) / a;
  return 1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b;
}

double student_t_cdf(double t, double df) {
  if (!(df > 0.0)) throw std::domain_error("student_t_cdf: df must be positive");
  if (std::isnan(t)) return kNaN;
  if (std::isinf(t)) return t > 0 ? 1.0 : 0.0;
  const double tail = 0.5 * regularized_incomplete_beta(0.5 * df, 0.5, df / (df + t * t));
  return t >= 0.0 ? 1.0 - tail : tail;
}

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

GroupSummary summarise(const Eigen::Ref<const Eigen::VectorXd>& x) {
  GroupSummary g;
  g.n = static_cast<int>(x.size());
  if (g.n == 0) return {0, kNaN, kNaN};
  g.mean = x.mean();
  g.sd = g.n > 1 ? std::sqrt((x.array() - g.mean).square().sum() / (g.n - 1)) : kNaN;
  return g;
}

EffectSize effect_size(const Eigen::Ref<const Eigen::VectorXd>& x,
                       const Eigen::Ref<const Eigen::VectorXd>& y) {
  const GroupSummary gx = summarise(x), gy = summarise(y);
  EffectSize e;
  if (gx.n < 2 || gy.n < 2) return {kNaN, kNaN};
  const double pooled = std::sqrt(((gx.n - 1) * gx.sd * gx.sd + (gy.n - 1) * gy.sd * gy.sd) /
                                  (gx.n + gy.n - 2));
  e.cohen_d = (gx.mean - gy.mean) / pooled;
  e.hedges_g = e.cohen_d * (1.0 - 3.0 / (4.0 * (gx.n + gy.n) - 9.0));
  return e;
}

namespace {

// Welch's t from the two group means and the variances of those means (vx, vy), n >= 2 each.
WelchResult welch_from_variances(double mx, double vx, int nx, double my, double vy, int ny) {
  WelchResult w;
  w.mean_difference = mx - my;
  const double se2 = vx + vy;
  if (se2 == 0.0) {
    w.df = nx + ny - 2.0;
    if (w.mean_difference == 0.0) {
      w.t = kNaN;
      w.p_value = kNaN;
    } else {
      w.t = std::copysign(std::numeric_limits<double>::infinity(), w.mean_difference);
      w.p_value = 0.0;
    }
    return w;
  }
  w.t = w.mean_difference / std::sqrt(se2);
  w.df = se2 * se2 / (vx * vx / (nx - 1) + vy * vy / (ny - 1));
  // Two-sided: 2 P(T > |t|) = I_{df/(df+t^2)}(df/2, 1/2).
  w.p_value = regularized_incomplete_beta(0.5 * w.df, 0.5, w.df / (w.df + w.t * w.t));
  return w;
}

// Inverse-variance weighted mean and its variance with var x_i = tau^2 + s_i^2 (see the header).
std::pair<double, double> random_effects_mean(const Eigen::Ref<const Eigen::VectorXd>& x,
                                              const Eigen::Ref<const Eigen::VectorXd>& sd) {
  const GroupSummary g = summarise(x);
  const Eigen::ArrayXd s2 = sd.array().isNaN().select(0.0, sd.array().square());
  const Eigen::ArrayXd v = g.sd * g.sd + s2;
  if ((v == 0.0).any()) return {g.mean, 0.0};  // tau = 0 and an exact estimate: no spread
  const Eigen::ArrayXd w = v.inverse();
  return {(w * x.array()).sum() / w.sum(), 1.0 / w.sum()};
}

}  // namespace

WelchResult welch_t_test(const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& y) {
  const GroupSummary gx = summarise(x), gy = summarise(y);
  if (gx.n < 2 || gy.n < 2) throw std::invalid_argument("welch_t_test: needs n >= 2 in each group");
  return welch_from_variances(gx.mean, gx.sd * gx.sd / gx.n, gx.n, gy.mean, gy.sd * gy.sd / gy.n, gy.n);
}

WelchResult posterior_welch_test(const Eigen::Ref<const Eigen::VectorXd>& x,
                                 const Eigen::Ref<const Eigen::VectorXd>& sd_x,
                                 const Eigen::Ref<const Eigen::VectorXd>& y,
                                 const Eigen::Ref<const Eigen::VectorXd>& sd_y) {
  if (x.size() < 2 || y.size() < 2) {
    throw std::invalid_argument("posterior_welch_test: needs n >= 2 in each group");
  }
  if (sd_x.size() != x.size() || sd_y.size() != y.size()) {
    throw std::invalid_argument("posterior_welch_test: one posterior sd per estimate");
  }
  const auto [mx, vx] = random_effects_mean(x, sd_x);
  const auto [my, vy] = random_effects_mean(y, sd_y);
  return welch_from_variances(mx, vx, static_cast<int>(x.size()), my, vy, static_cast<int>(y.size()));
}

const char* to_string(PAdjust method) {
  return method == PAdjust::kHolm ? "holm" : "benjamini-hochberg";
}

Eigen::VectorXd adjust_p_values(const Eigen::Ref<const Eigen::VectorXd>& p, PAdjust method) {
  Eigen::VectorXd out = Eigen::VectorXd::Constant(p.size(), kNaN);
  std::vector<Eigen::Index> order;
  for (Eigen::Index i = 0; i < p.size(); ++i) {
    if (!std::isnan(p(i))) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return p(a) < p(b); });
  const auto m = static_cast<double>(order.size());
  if (method == PAdjust::kHolm) {
    double running = 0.0;  // step-down: the running maximum from the smallest p
    for (size_t j = 0; j < order.size(); ++j) {
      running = std::max(running, std::min(1.0, (m - static_cast<double>(j)) * p(order[j])));
      out(order[j]) = running;
    }
  } else {
    double running = 1.0;  // step-up: the running minimum from the largest p
    for (size_t j = order.size(); j-- > 0;) {
      running = std::min(running, std::min(1.0, m * p(order[j]) / static_cast<double>(j + 1)));
      out(order[j]) = running;
    }
  }
  return out;
}

std::string auc_direction(double auc) {
  if (auc > 0.5) return "higher";
  if (auc < 0.5) return "lower";
  return "none";
}

MannWhitneyResult mann_whitney(const Eigen::Ref<const Eigen::VectorXd>& x,
                               const Eigen::Ref<const Eigen::VectorXd>& y) {
  const int nx = static_cast<int>(x.size()), ny = static_cast<int>(y.size());
  if (nx < 1 || ny < 1) throw std::invalid_argument("mann_whitney: needs n >= 1 in each group");
  MannWhitneyResult r;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      if (x(i) > y(j)) r.U += 1.0;
      else if (x(i) == y(j)) r.U += 0.5;
    }
  }
  const double nxy = static_cast<double>(nx) * ny;
  r.auc = r.U / nxy;

  // Tie groups of the pooled sample.
  std::vector<double> all(static_cast<size_t>(nx + ny));
  for (int i = 0; i < nx; ++i) all[static_cast<size_t>(i)] = x(i);
  for (int j = 0; j < ny; ++j) all[static_cast<size_t>(nx + j)] = y(j);
  std::sort(all.begin(), all.end());
  double tie_term = 0.0;
  bool ties = false;
  for (size_t i = 0; i < all.size();) {
    size_t k = i;
    while (k < all.size() && all[k] == all[i]) ++k;
    const double t = static_cast<double>(k - i);
    if (t > 1) ties = true;
    tie_term += t * t * t - t;
    i = k;
  }
  const int n = nx + ny;

  if (!ties && n <= 40) {
    // count[i][j][u]: orderings of i x's and j y's with U = u; the largest element is an x
    // (adds j pairs) or a y (adds none): count[i][j][u] = count[i-1][j][u-j] + count[i][j-1][u].
    const int umax = nx * ny;
    std::vector<double> prev((static_cast<size_t>(ny) + 1) * (umax + 1), 0.0), cur(prev.size());
    auto at = [&](std::vector<double>& v, int j, int u) -> double& {
      return v[static_cast<size_t>(j) * (umax + 1) + static_cast<size_t>(u)];
    };
    for (int j = 0; j <= ny; ++j) at(prev, j, 0) = 1.0;  // i = 0: one ordering, U = 0
    for (int i = 1; i <= nx; ++i) {
      std::fill(cur.begin(), cur.end(), 0.0);
      for (int j = 0; j <= ny; ++j) {
        for (int u = 0; u <= i * j; ++u) {
          double c = 0.0;
          if (u - j >= 0) c += at(prev, j, u - j);
          if (j > 0) c += at(cur, j - 1, u);
          at(cur, j, u) = c;
        }
      }
      std::swap(prev, cur);
    }
    const double total = std::exp(log_binomial(n, nx));
    const int u_obs = static_cast<int>(std::lround(r.U));
    double lower = 0.0, upper = 0.0;
    for (int u = 0; u <= umax; ++u) {
      const double c = at(prev, ny, u) / total;
      if (u <= u_obs) lower += c;
      if (u >= u_obs) upper += c;
    }
    r.exact = true;
    r.p_value = std::min(1.0, 2.0 * std::min(lower, upper));
  } else {
    const double mu = nxy / 2.0;
    const double var = nxy / 12.0 * ((n + 1.0) - tie_term / (static_cast<double>(n) * (n - 1)));
    const double diff = r.U - mu;
    const double corrected = std::abs(diff) <= 0.5 ? 0.0 : diff - std::copysign(0.5, diff);
    r.z = var > 0 ? corrected / std::sqrt(var) : 0.0;
    r.p_value = var > 0 ? std::erfc(std::abs(r.z) / std::sqrt(2.0)) : 1.0;
  }

  const double A = r.auc;
  const double q1 = A / (2.0 - A), q2 = 2.0 * A * A / (1.0 + A);
  r.auc_se = std::sqrt(std::max(0.0, (A * (1.0 - A) + (nx - 1.0) * (q1 - A * A) +
                                      (ny - 1.0) * (q2 - A * A)) / nxy));
  return r;
}

}  // namespace sigmaheart::estimation::specificity
