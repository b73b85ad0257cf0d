// One prior for every estimator (docs/estimation.md, "The prior"): UT calibration, the ROUKF and
// the samplers of the sensitivity study all read this type.
//
// Each estimated parameter has a name and SI unit, physical bounds, a transform eta -> theta
// (transform.h; eta is where sigma points, filter states and samples live) and a distribution:
//  - kGaussian: eta ~ N(mean_eta, std_eta^2), with an optional correlation between parameters
//    (calibration and filtering);
//  - kUniform: uniform over [lower, upper], in theta (space kPhysical) or in eta (kEta; with a log
//    transform this is log-uniform) (sensitivity designs).
// theta_nominal is the parameter's centre in physical units: the prior median T(mean_eta) for a
// Gaussian, the one-at-a-time nominal for a uniform.
#pragma once

#include "estimation/transform.h"

#include <Eigen/Core>

#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

enum class PriorKind { kGaussian, kUniform };
const char* to_string(PriorKind kind);

// Where a uniform prior is uniform.
enum class SamplingSpace {
  kPhysical,  // theta uniform on [lower, upper]
  kEta,       // eta uniform on [to_eta(lower), to_eta(upper)]
};
const char* to_string(SamplingSpace space);
std::optional<SamplingSpace> parse_sampling_space(const std::string& text);  // "physical", "eta"

// How a Gaussian prior's spread is given in a config (converted to std_eta once, at set-up).
enum class SpreadKind {
  kRelative,  // std of theta relative to |theta mean|: std_eta = spread |theta0| / T'(eta0)
  kAbsolute,  // std of theta in its SI unit: std_eta = spread / T'(eta0)
  kEta,       // std in eta directly
};
const char* to_string(SpreadKind kind);
std::optional<SpreadKind> parse_spread_kind(const std::string& text);  // "relative", "absolute", "eta"

struct PriorParameter {
  std::string name;
  std::string unit;  // SI
  Transform transform;
  double lower = -std::numeric_limits<double>::infinity();  // physical bounds, SI
  double upper = std::numeric_limits<double>::infinity();
  PriorKind kind = PriorKind::kGaussian;
  double mean_eta = 0.0;  // kGaussian
  double std_eta = 1.0;   // kGaussian, > 0
  SamplingSpace space = SamplingSpace::kPhysical;  // kUniform
  double theta_nominal = 0.0;
  // Physiological range (SI) and its source, from model::Parameter (docs/models.md s.8); NaN: none.
  // Not a bound: an estimate may leave it, and prior_conflict.h says so.
  double range_lower = std::numeric_limits<double>::quiet_NaN();
  double range_upper = std::numeric_limits<double>::quiet_NaN();
  std::string range_source;

  // A Gaussian parameter centred (in eta) on theta_mean with the spread converted by `spread_kind`
  // at theta_mean. Throws std::invalid_argument naming the parameter when theta_mean is outside
  // the transform's range or the spread gives no positive finite std_eta.
  static PriorParameter gaussian(std::string name, std::string unit, double theta_mean,
                                 double spread, SpreadKind spread_kind, Transform transform,
                                 double lower = -std::numeric_limits<double>::infinity(),
                                 double upper = std::numeric_limits<double>::infinity());
  // A uniform parameter over [lower, upper] (finite), nominal inside.
  static PriorParameter uniform(std::string name, std::string unit, double lower, double upper,
                                double nominal, SamplingSpace space = SamplingSpace::kPhysical,
                                Transform transform = {});

  double to_theta(double eta) const { return transform.to_theta(eta); }
  double to_eta(double theta) const { return transform.to_eta(theta); }
  bool bounded() const;                 // a finite lower or upper bound
  bool inside(double theta) const;      // lower <= theta <= upper and finite
  // kUniform: u in [0, 1] -> theta, uniform in the chosen space, and its inverse.
  double from_unit(double u) const;
  double to_unit(double theta) const;
  // Empty when consistent, else a message starting with "parameter '<name>': ".
  std::string validate() const;
};

struct Prior {
  std::vector<PriorParameter> parameters;
  // Correlation of the Gaussian etas (p x p, symmetric positive definite, unit diagonal); empty:
  // independent parameters.
  Eigen::MatrixXd correlation;

  int size() const { return static_cast<int>(parameters.size()); }
  const PriorParameter& operator[](int i) const { return parameters.at(static_cast<size_t>(i)); }
  std::vector<std::string> names() const;
  std::vector<std::string> units() const;
  Eigen::VectorXd mean_eta() const;
  Eigen::VectorXd std_eta() const;
  Eigen::MatrixXd covariance_eta() const;   // diag(std) C diag(std)
  Eigen::MatrixXd sqrt_covariance_eta() const;  // lower Cholesky factor of covariance_eta()
  Eigen::VectorXd nominal_theta() const;
  // Delta-method standard deviation of theta = T(eta): |T'(eta_j)| eta_std_j per parameter.
  Eigen::VectorXd theta_std(const Eigen::Ref<const Eigen::VectorXd>& eta,
                            const Eigen::Ref<const Eigen::VectorXd>& eta_std) const;
  // The prior's own: theta_std(mean_eta(), std_eta()).
  Eigen::VectorXd prior_theta_std() const;
  // Index of the parameter called `name`; nullopt when there is none.
  std::optional<int> index(const std::string& name) const;
  Eigen::VectorXd lower() const;
  Eigen::VectorXd upper() const;
  Eigen::VectorXd to_theta(const Eigen::Ref<const Eigen::VectorXd>& eta) const;
  Eigen::VectorXd to_eta(const Eigen::Ref<const Eigen::VectorXd>& theta) const;  // throws std::domain_error
  // Rows of U (runs x p, entries in [0, 1]) mapped to theta (kUniform parameters).
  Eigen::MatrixXd unit_to_theta(const Eigen::MatrixXd& U) const;
  // Empty when theta lies inside every parameter's bounds, else the first offender with value,
  // unit and bounds.
  std::string check_inside(const Eigen::Ref<const Eigen::VectorXd>& theta) const;
  // Empty when every parameter is valid, names are distinct and the correlation fits.
  std::string validate() const;
};

}  // namespace sigmaheart::estimation
