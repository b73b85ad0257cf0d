#include "estimation/sigma_points.h"

#include "estimation/enum_names.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

SIGMAHEART_ENUM_TEXT(SigmaRule, parse_sigma_rule,
    {SigmaRule::kSimplex, "simplex"}, {SigmaRule::kCanonical, "canonical"},
    {SigmaRule::kStar, "star"}, {SigmaRule::kScaled, "scaled"})

std::string SigmaOptions::validate(int p) const {
  std::ostringstream s;
  if (p < 1) {
    s << "sigma points need at least one parameter, got p = " << p;
    return s.str();
  }
  switch (rule) {
    case SigmaRule::kSimplex:
    case SigmaRule::kCanonical:
      return {};
    case SigmaRule::kStar:
      if (!std::isfinite(kappa) || !(p + kappa > 0)) {
        s << "star rule: needs p + kappa > 0, got p = " << p << ", kappa = " << kappa;
        return s.str();
      }
      return {};
    case SigmaRule::kScaled:
      if (!std::isfinite(alpha) || !(alpha > 0)) {
        s << "scaled rule: alpha must be positive, got " << alpha;
        return s.str();
      }
      if (!std::isfinite(beta)) return "scaled rule: beta must be finite";
      if (!std::isfinite(kappa) || !(p + kappa > 0)) {
        s << "scaled rule: needs p + kappa > 0 (so that p + lambda = alpha^2 (p + kappa) > 0), "
             "got p = "
          << p << ", kappa = " << kappa;
        return s.str();
      }
      return {};
  }
  return "unknown sigma rule";
}

namespace {

// Regular simplex of p+1 unit points with equal weights 1/(p+1): U = sqrt(p+1) H^T where the
// rows of H (p x (p+1)) are the Helmert contrasts, an orthonormal basis of the complement of the
// ones vector. Then U 1 = 0, U U^T / (p+1) = I, every |u_i| = sqrt(p) and u_i . u_j = -1 (i != j),
// so all points are equidistant. Simplex sets of p+1 points are Julier & Uhlmann's reduced
// sigma-point sets (ACC 2002); this recursive build is Julier's spherical simplex (ACC 2003) with
// a zero centre weight, and it is the unit simplex the ROUKF uses (Moireau & Chapelle 2011, ESAIM
// COCV 17:380: V with alpha_i = 1/(p+1), V D_alpha V^T = I, V alpha = 0).
SigmaPoints simplex_points(int p) {
  const int r = p + 1;
  SigmaPoints out;
  out.unit = Eigen::MatrixXd::Zero(p, r);
  const double scale = std::sqrt(static_cast<double>(r));
  for (int k = 1; k <= p; ++k) {  // row k-1: the k-th Helmert contrast
    const double c = 1.0 / std::sqrt(static_cast<double>(k) * (k + 1));
    for (int i = 0; i < k; ++i) out.unit(k - 1, i) = scale * c;
    out.unit(k - 1, k) = -scale * k * c;
  }
  out.wm = Eigen::VectorXd::Constant(r, 1.0 / r);
  out.wc = out.wm;
  return out;
}

// +-radius e_j in columns (offset, offset + 2p), ordered +e_1, -e_1, +e_2, -e_2, ...
void fill_axes(Eigen::MatrixXd& unit, int p, int offset, double radius) {
  for (int j = 0; j < p; ++j) {
    unit(j, offset + 2 * j) = radius;
    unit(j, offset + 2 * j + 1) = -radius;
  }
}

// Tier-1 invariant (docs/estimation.md s.2): sum wm = 1, U wm = 0, U diag(wc) U^T = I.
void check_moments(const SigmaPoints& sp, const SigmaOptions& options) {
  const int p = static_cast<int>(sp.unit.rows());
  // Weights of the scaled rule can be ~1/alpha^2; the tolerance follows their size.
  const double scale = std::max({1.0, sp.wm.cwiseAbs().maxCoeff(), sp.wc.cwiseAbs().maxCoeff()});
  const double tol = 1e-12 * scale * (sp.count() + 1);
  const double sum_error = std::abs(sp.wm.sum() - 1.0);
  const double mean_error = (sp.unit * sp.wm).cwiseAbs().maxCoeff();
  const double cov_error =
      (sp.unit * sp.wc.asDiagonal() * sp.unit.transpose() - Eigen::MatrixXd::Identity(p, p))
          .cwiseAbs()
          .maxCoeff();
  if (sum_error > tol || mean_error > tol || cov_error > tol) {
    std::ostringstream s;
    s << "sigma rule " << to_string(options.rule) << " (p = " << p
      << ") violates its moment properties: |sum wm - 1| = " << sum_error
      << ", |U wm| = " << mean_error << ", |U diag(wc) U^T - I| = " << cov_error
      << " (tolerance " << tol << ")";
    throw std::logic_error(s.str());
  }
}

}  // namespace

SigmaPoints make_sigma_points(int p, const SigmaOptions& options) {
  if (const std::string error = options.validate(p); !error.empty()) {
    throw std::invalid_argument(error);
  }
  SigmaPoints sp;
  switch (options.rule) {
    case SigmaRule::kSimplex:
      sp = simplex_points(p);
      break;
    case SigmaRule::kCanonical: {
      sp.unit = Eigen::MatrixXd::Zero(p, 2 * p);
      fill_axes(sp.unit, p, 0, std::sqrt(static_cast<double>(p)));
      sp.wm = Eigen::VectorXd::Constant(2 * p, 1.0 / (2.0 * p));
      sp.wc = sp.wm;
      break;
    }
    case SigmaRule::kStar: {
      // Julier & Uhlmann's symmetric set: W0 = kappa/(p+kappa), Wj = 1/(2(p+kappa)).
      const double pk = p + options.kappa;
      sp.unit = Eigen::MatrixXd::Zero(p, 2 * p + 1);
      fill_axes(sp.unit, p, 1, std::sqrt(pk));
      sp.wm = Eigen::VectorXd::Constant(2 * p + 1, 1.0 / (2.0 * pk));
      sp.wm(0) = options.kappa / pk;
      sp.wc = sp.wm;
      break;
    }
    case SigmaRule::kScaled: {
      // Wan & van der Merwe (2000): lambda = alpha^2 (p+kappa) - p; W0c = W0m + 1 - alpha^2 + beta.
      const double pl = options.alpha * options.alpha * (p + options.kappa);  // p + lambda
      const double lambda = pl - p;
      sp.unit = Eigen::MatrixXd::Zero(p, 2 * p + 1);
      fill_axes(sp.unit, p, 1, std::sqrt(pl));
      sp.wm = Eigen::VectorXd::Constant(2 * p + 1, 1.0 / (2.0 * pl));
      sp.wm(0) = lambda / pl;
      sp.wc = sp.wm;
      sp.wc(0) = sp.wm(0) + 1.0 - options.alpha * options.alpha + options.beta;
      break;
    }
  }
  check_moments(sp, options);
  return sp;
}

Eigen::MatrixXd covariance_sqrt(const Eigen::MatrixXd& P, bool* used_fallback) {
  if (P.rows() != P.cols()) {
    std::ostringstream s;
    s << "covariance_sqrt: P must be square, got " << P.rows() << " x " << P.cols();
    throw std::invalid_argument(s.str());
  }
  if (!P.allFinite()) throw std::invalid_argument("covariance_sqrt: P has non-finite entries");
  if (used_fallback) *used_fallback = false;
  const Eigen::MatrixXd sym = 0.5 * (P + P.transpose());
  Eigen::LLT<Eigen::MatrixXd> llt(sym);
  if (llt.info() == Eigen::Success) return llt.matrixL();
  // Semi-definite or slightly indefinite (round-off after an update): S = V max(D, 0)^1/2, which
  // is a square root (S S^T = P with negative eigenvalues clamped) but not triangular.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sym);
  if (eig.info() != Eigen::Success) {
    throw std::runtime_error("covariance_sqrt: eigen decomposition failed");
  }
  if (used_fallback) *used_fallback = true;
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

Eigen::MatrixXd place_points(const Eigen::VectorXd& mean, const Eigen::MatrixXd& S,
                             const SigmaPoints& points) {
  if (S.rows() != mean.size() || S.cols() != points.unit.rows()) {
    std::ostringstream s;
    s << "place_points: mean has " << mean.size() << " entries, S is " << S.rows() << " x "
      << S.cols() << ", unit points are " << points.unit.rows() << " x " << points.unit.cols();
    throw std::invalid_argument(s.str());
  }
  return (S * points.unit).colwise() + mean;
}

}  // namespace sigmaheart::estimation
