// Sigma-point rules (docs/estimation.md s.2). Unit points U (p x r) with weights wm (mean) and wc
// (covariance) satisfy sum wm = 1, U wm = 0 and U diag(wc) U^T = I; the points for (mean, P) are
// mean + S U_i with S S^T = P.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <string>

namespace sigmaheart::estimation {

enum class SigmaRule {
  kSimplex,    // p+1 points, regular simplex, weights 1/(p+1) (Julier 2002; Moireau-Chapelle 2011)
  kCanonical,  // 2p points +-sqrt(p) e_j, weights 1/(2p)
  kStar,       // 2p+1 points: centre and +-sqrt(p+kappa) e_j; W0 = kappa/(p+kappa)
  kScaled,     // 2p+1 points, Wan-van der Merwe alpha, beta, kappa
};

const char* to_string(SigmaRule rule);
std::optional<SigmaRule> parse_sigma_rule(const std::string& text);  // "simplex", "canonical", "star", "scaled"

struct SigmaOptions {
  SigmaRule rule = SigmaRule::kSimplex;
  double kappa = 0.5;   // star and scaled
  double alpha = 1.0;   // scaled
  double beta = 0.0;    // scaled
  std::string validate(int p) const;
};

struct SigmaPoints {
  Eigen::MatrixXd unit;  // p x r unit points
  Eigen::VectorXd wm;    // r weights for the mean
  Eigen::VectorXd wc;    // r weights for the covariance
  int count() const { return static_cast<int>(unit.cols()); }
};

SigmaPoints make_sigma_points(int p, const SigmaOptions& options);

// Lower-triangular S with S S^T = P (Cholesky of the symmetrised P). When Cholesky fails a
// symmetric eigen decomposition with negative eigenvalues clamped to zero is used and
// *used_fallback is set.
Eigen::MatrixXd covariance_sqrt(const Eigen::MatrixXd& P, bool* used_fallback = nullptr);

// Columns mean + S * unit.col(i).
Eigen::MatrixXd place_points(const Eigen::VectorXd& mean, const Eigen::MatrixXd& S,
                             const SigmaPoints& points);

}  // namespace sigmaheart::estimation
