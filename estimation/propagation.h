// Propagation of a posterior through responses (docs/estimation.md s.12): the unscented transform
// (Julier & Uhlmann 2004, Proc IEEE 92:401) of a Gaussian posterior over the transformed
// parameters eta, with a Monte Carlo reference.
//
// The posterior is what `calibrate` and `personalize` write: eta ~ N(mean, P) with theta = T(eta)
// per parameter (transform.h). A response is any function of theta (the acute response of a
// therapy, an index of the beat); the caller evaluates it at the points given here (in an Ensemble,
// on threads and ranks) and hands the rows back:
//  - kUnscented: the sigma points of sigma_points.h placed at mean + S u_i (S S^T = P) and mapped
//    through T; the response's mean is sum wm_i y_i and its covariance sum wc_i (y_i - ybar)(...)^T.
//    Exact for a response linear in eta (a test checks it) and the Gaussian's third moments;
//    the 90 % interval and the probabilities are those of the Gaussian with these moments.
//  - kMonteCarlo: `samples` draws of eta from N(mean, P) (seeded, the same for any thread count);
//    moments, interval (empirical quantiles) and probabilities from the sample.
//  - kPoint: the mean only (no spread): the response at T(mean) with zero variance.
#pragma once

#include "estimation/sigma_points.h"
#include "estimation/transform.h"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

struct Posterior {
  std::vector<std::string> names;      // the estimated parameters
  std::vector<std::string> units;      // SI
  std::vector<Transform> transforms;   // eta -> theta, one per parameter
  Eigen::VectorXd eta_mean;
  Eigen::MatrixXd eta_covariance;      // symmetric positive semi-definite
  int size() const { return static_cast<int>(names.size()); }
  Eigen::VectorXd theta(const Eigen::Ref<const Eigen::VectorXd>& eta) const;
  Eigen::VectorXd theta_mean() const { return theta(eta_mean); }
  // Empty when sizes agree, values are finite and the transforms valid, else a message.
  std::string validate() const;
};

enum class PropagationMethod { kUnscented, kMonteCarlo, kPoint };
const char* to_string(PropagationMethod method);
std::optional<PropagationMethod> parse_propagation_method(const std::string& text);  // unscented, monte-carlo, point

struct PropagationOptions {
  PropagationMethod method = PropagationMethod::kUnscented;
  // 2p+1 points with positive weights by default: the centre (weight 1/(p+1)) and +-sqrt(p+1)
  // along each axis of S (weight 1/(2(p+1))). simplex gives p+1 points.
  SigmaOptions sigma{SigmaRule::kStar, 1.0, 1.0, 0.0};
  int samples = 200;           // kMonteCarlo
  std::uint64_t seed = 1;      // kMonteCarlo draws and the Gaussian draws of probability_largest
  double interval = 0.90;      // central probability of the reported interval
  std::string validate(int p) const;
};

struct PropagationPoints {
  PropagationMethod method = PropagationMethod::kUnscented;
  Eigen::MatrixXd eta;    // points x p
  Eigen::MatrixXd theta;  // points x p, T(eta) row by row
  Eigen::VectorXd wm;     // mean weights (Monte Carlo: 1/N)
  Eigen::VectorXd wc;     // covariance weights (Monte Carlo: 1/(N - 1))
  int count() const { return static_cast<int>(eta.rows()); }
};

// Throws std::invalid_argument for an invalid posterior or options.
PropagationPoints propagation_points(const Posterior& posterior, const PropagationOptions& options);

struct ResponseMoments {
  Eigen::VectorXd mean, std;    // per response
  Eigen::VectorXd lower, upper; // the central `interval` (UT: Gaussian; Monte Carlo: quantiles)
  Eigen::MatrixXd covariance;   // responses x responses
  int failed_points = 0;        // rows of Y with a NaN (Monte Carlo drops them; UT cannot)
  bool ok = true;               // false: the UT lost a point (every moment NaN)
  // Per response, the standard deviation of an error added by add_response_error (empty: none).
  Eigen::VectorXd error_sd;
};

// Y: points x responses, NaN rows where the response failed. The unscented transform needs every
// point: with one missing its moments are NaN and ok is false; Monte Carlo uses the finite rows
// (at least two).
ResponseMoments response_moments(const PropagationPoints& points, const Eigen::MatrixXd& Y,
                                 const PropagationOptions& options);

// A response error independent of the parameters, y_true = y(theta) + delta with delta ~ N(0, sd^2)
// (a model's error against a reference, measured on a validation cohort: the part of the
// prediction's uncertainty no posterior over the model's own parameters can show; Kennedy &
// O'Hagan 2001, J R Stat Soc B 63:425). Column j's variance gains sd^2 (covariance diagonal, std)
// and its interval becomes the central `interval` of the sum: UT and point: the Gaussian of the
// widened moments; Monte Carlo: the sample convolved with N(0, sd^2), its quantiles solved for
// exactly (bisection on the mixture's CDF). Records sd in moments.error_sd, which
// probability_above then convolves too. Throws std::invalid_argument for sd < 0 or j out of range.
void add_response_error(ResponseMoments& moments, const PropagationPoints& points, const Eigen::MatrixXd& Y,
                        Eigen::Index j, double sd, const PropagationOptions& options);

// P(response_j > threshold) for each column: UT and point: the Gaussian of the moments (a point
// mean gives 0 or 1); Monte Carlo: the fraction of finite rows, or with an added error (error_sd)
// the mean over them of P(y_i + delta > threshold).
Eigen::VectorXd probability_above(const PropagationPoints& points, const Eigen::MatrixXd& Y,
                                  const ResponseMoments& moments, double threshold,
                                  const PropagationOptions& options);

// P(column j is the largest of the columns of Y) (ties to the lowest index): UT: 20 000 draws of
// the joint Gaussian (mean, covariance) of the columns, seeded by options.seed; Monte Carlo: the
// fraction of finite rows (with added errors, error_sd: each row with seeded draws of them, about
// 20 000 in all); point: 1 for the largest mean, or with added errors the draws of the UT. Sums to 1
// (NaN when no moments).
Eigen::VectorXd probability_largest(const PropagationPoints& points, const Eigen::MatrixXd& Y,
                                    const ResponseMoments& moments, const PropagationOptions& options);

}  // namespace sigmaheart::estimation
