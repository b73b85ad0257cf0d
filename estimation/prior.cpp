#include "estimation/prior.h"

#include "estimation/enum_names.h"

#include <Eigen/Cholesky>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

constexpr std::array<EnumName<PriorKind>, 2> kPriorKindNames{{
    {PriorKind::kGaussian, "gaussian"}, {PriorKind::kUniform, "uniform"},
}};
const char* to_string(PriorKind kind) { return enum_to_string(kPriorKindNames, kind); }

SIGMAHEART_ENUM_TEXT(SamplingSpace, parse_sampling_space,
    {SamplingSpace::kPhysical, "physical"}, {SamplingSpace::kEta, "eta"},
    {SamplingSpace::kPhysical, "theta"}, {SamplingSpace::kEta, "transformed"})

SIGMAHEART_ENUM_TEXT(SpreadKind, parse_spread_kind,
    {SpreadKind::kRelative, "relative"}, {SpreadKind::kAbsolute, "absolute"},
    {SpreadKind::kEta, "eta"})

PriorParameter PriorParameter::gaussian(std::string name, std::string unit, double theta_mean,
                                        double spread, SpreadKind spread_kind, Transform transform,
                                        double lower, double upper) {
  PriorParameter p;
  p.name = std::move(name);
  p.unit = std::move(unit);
  p.transform = transform;
  p.lower = lower;
  p.upper = upper;
  p.kind = PriorKind::kGaussian;
  p.theta_nominal = theta_mean;
  const std::string who = "parameter '" + p.name + "': ";
  try {
    p.mean_eta = transform.to_eta(theta_mean);
  } catch (const std::domain_error& e) {
    throw std::invalid_argument(who + "prior mean outside the transform's range: " + e.what());
  }
  const double slope = transform.dtheta_deta(p.mean_eta);
  switch (spread_kind) {
    case SpreadKind::kRelative: p.std_eta = spread * std::abs(theta_mean) / slope; break;
    case SpreadKind::kAbsolute: p.std_eta = spread / slope; break;
    case SpreadKind::kEta: p.std_eta = spread; break;
  }
  if (!(spread > 0) || !std::isfinite(spread) || !(p.std_eta > 0) || !std::isfinite(p.std_eta)) {
    std::ostringstream m;
    m << who << "prior std in eta is " << p.std_eta << " from spread " << spread << " ("
      << to_string(spread_kind) << "); a relative spread needs a non-zero prior mean";
    throw std::invalid_argument(m.str());
  }
  return p;
}

PriorParameter PriorParameter::uniform(std::string name, std::string unit, double lower,
                                       double upper, double nominal, SamplingSpace space,
                                       Transform transform) {
  PriorParameter p;
  p.name = std::move(name);
  p.unit = std::move(unit);
  p.lower = lower;
  p.upper = upper;
  p.kind = PriorKind::kUniform;
  p.space = space;
  p.transform = transform;
  p.theta_nominal = nominal;
  return p;
}

bool PriorParameter::bounded() const { return std::isfinite(lower) || std::isfinite(upper); }

bool PriorParameter::inside(double theta) const {
  return std::isfinite(theta) && theta >= lower && theta <= upper;
}

double PriorParameter::from_unit(double u) const {
  if (space == SamplingSpace::kPhysical) return lower + u * (upper - lower);
  const double a = transform.to_eta(lower);
  const double b = transform.to_eta(upper);
  return transform.to_theta(a + u * (b - a));
}

double PriorParameter::to_unit(double theta) const {
  if (space == SamplingSpace::kPhysical) return (theta - lower) / (upper - lower);
  const double a = transform.to_eta(lower);
  const double b = transform.to_eta(upper);
  return (transform.to_eta(theta) - a) / (b - a);
}

std::string PriorParameter::validate() const {
  std::ostringstream s;
  const std::string who = "parameter '" + name + "': ";
  if (name.empty()) return "prior parameter without a name";
  if (const std::string t = transform.validate(); !t.empty()) return who + t;
  if (kind == PriorKind::kUniform &&
      !(std::isfinite(lower) && std::isfinite(upper) && lower < upper)) {
    s << who << "needs finite bounds with lower < upper, got [" << lower << ", " << upper << "]";
    return s.str();
  }
  if (!(lower <= upper) || std::isnan(lower) || std::isnan(upper)) {
    s << who << "bounds [" << lower << ", " << upper << "] are not ordered";
    return s.str();
  }
  if (kind == PriorKind::kGaussian) {
    if (!std::isfinite(mean_eta) || !(std_eta > 0) || !std::isfinite(std_eta)) {
      s << who << "Gaussian prior needs a finite mean and a positive finite std in eta, got "
        << mean_eta << " +- " << std_eta;
      return s.str();
    }
    if (bounded() && transform.kind != TransformKind::kLogit) {
      // Bounds must be respected by every member (docs/estimation.md): a transform whose range
      // is wider than the bounds could put sigma points outside them.
      const bool log_ok = transform.kind == TransformKind::kLog && lower <= 0 && !std::isfinite(upper);
      if (!log_ok) {
        s << who << "has bounds [" << lower << ", " << upper << "] " << unit
          << " but a " << to_string(transform.kind)
          << " transform, whose range is wider; use transform: logit";
        return s.str();
      }
    }
    if (!inside(to_theta(mean_eta))) {
      s << who << "prior mean " << to_theta(mean_eta) << " " << unit << " outside its bounds ["
        << lower << ", " << upper << "]";
      return s.str();
    }
    return {};
  }
  if (!(std::isfinite(lower) && std::isfinite(upper) && lower < upper)) {
    s << who << "needs finite bounds with lower < upper, got [" << lower << ", " << upper << "]";
    return s.str();
  }
  if (!(lower <= theta_nominal && theta_nominal <= upper)) {
    s << who << "nominal " << theta_nominal << " outside [" << lower << ", " << upper << "]";
    return s.str();
  }
  if (space == SamplingSpace::kEta) {
    try {
      const double a = transform.to_eta(lower);
      const double b = transform.to_eta(upper);
      if (!(std::isfinite(a) && std::isfinite(b) && a < b)) {
        s << who << "the " << to_string(transform.kind)
          << " transform maps [lower, upper] to a non-finite eta range";
        return s.str();
      }
    } catch (const std::domain_error& e) {
      return who + "bounds outside the transform's range: " + e.what();
    }
  }
  return {};
}

std::vector<std::string> Prior::names() const {
  std::vector<std::string> out;
  for (const auto& p : parameters) out.push_back(p.name);
  return out;
}

std::vector<std::string> Prior::units() const {
  std::vector<std::string> out;
  for (const auto& p : parameters) out.push_back(p.unit);
  return out;
}

namespace {
template <class F>
Eigen::VectorXd per_parameter(const std::vector<PriorParameter>& ps, F f) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(ps.size()));
  for (size_t i = 0; i < ps.size(); ++i) v(static_cast<Eigen::Index>(i)) = f(ps[i]);
  return v;
}
}  // namespace

Eigen::VectorXd Prior::mean_eta() const {
  return per_parameter(parameters, [](const PriorParameter& p) { return p.mean_eta; });
}
Eigen::VectorXd Prior::std_eta() const {
  return per_parameter(parameters, [](const PriorParameter& p) { return p.std_eta; });
}
Eigen::VectorXd Prior::nominal_theta() const {
  return per_parameter(parameters, [](const PriorParameter& p) { return p.theta_nominal; });
}
Eigen::VectorXd Prior::theta_std(const Eigen::Ref<const Eigen::VectorXd>& eta,
                                 const Eigen::Ref<const Eigen::VectorXd>& eta_std) const {
  Eigen::VectorXd s(eta.size());
  for (Eigen::Index i = 0; i < eta.size(); ++i) {
    s(i) = std::abs(parameters[static_cast<size_t>(i)].transform.dtheta_deta(eta(i))) * eta_std(i);
  }
  return s;
}

Eigen::VectorXd Prior::prior_theta_std() const { return theta_std(mean_eta(), std_eta()); }

std::optional<int> Prior::index(const std::string& name) const {
  for (size_t i = 0; i < parameters.size(); ++i) {
    if (parameters[i].name == name) return static_cast<int>(i);
  }
  return std::nullopt;
}

Eigen::VectorXd Prior::lower() const {
  return per_parameter(parameters, [](const PriorParameter& p) { return p.lower; });
}
Eigen::VectorXd Prior::upper() const {
  return per_parameter(parameters, [](const PriorParameter& p) { return p.upper; });
}

Eigen::MatrixXd Prior::covariance_eta() const {
  const Eigen::VectorXd s = std_eta();
  if (correlation.size() == 0) return s.array().square().matrix().asDiagonal();
  return s.asDiagonal() * correlation * s.asDiagonal();
}

Eigen::MatrixXd Prior::sqrt_covariance_eta() const {
  if (correlation.size() == 0) return std_eta().asDiagonal();
  return covariance_eta().llt().matrixL();
}

Eigen::VectorXd Prior::to_theta(const Eigen::Ref<const Eigen::VectorXd>& eta) const {
  Eigen::VectorXd t(eta.size());
  for (Eigen::Index i = 0; i < eta.size(); ++i) t(i) = parameters[static_cast<size_t>(i)].to_theta(eta(i));
  return t;
}

Eigen::VectorXd Prior::to_eta(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  Eigen::VectorXd e(theta.size());
  for (Eigen::Index i = 0; i < theta.size(); ++i) e(i) = parameters[static_cast<size_t>(i)].to_eta(theta(i));
  return e;
}

Eigen::MatrixXd Prior::unit_to_theta(const Eigen::MatrixXd& U) const {
  Eigen::MatrixXd T(U.rows(), U.cols());
  for (Eigen::Index c = 0; c < U.cols(); ++c) {  // column by column: both matrices are column-major
    const PriorParameter& p = parameters[static_cast<size_t>(c)];
    for (Eigen::Index r = 0; r < U.rows(); ++r) T(r, c) = p.from_unit(U(r, c));
  }
  return T;
}

std::string Prior::check_inside(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  for (size_t i = 0; i < parameters.size(); ++i) {
    const auto& p = parameters[i];
    const double v = theta(static_cast<Eigen::Index>(i));
    if (!p.inside(v)) {
      std::ostringstream s;
      s << "parameter '" << p.name << "' = " << v << " " << p.unit << " outside its bounds ["
        << p.lower << ", " << p.upper << "]";
      return s.str();
    }
  }
  return {};
}

std::string Prior::validate() const {
  if (parameters.empty()) return "the prior has no parameters";
  for (size_t i = 0; i < parameters.size(); ++i) {
    if (const std::string e = parameters[i].validate(); !e.empty()) return e;
    for (size_t j = 0; j < i; ++j) {
      if (parameters[j].name == parameters[i].name) {
        return "parameter '" + parameters[i].name + "' appears twice in the prior";
      }
    }
  }
  if (correlation.size() != 0) {
    const auto p = static_cast<Eigen::Index>(parameters.size());
    if (correlation.rows() != p || correlation.cols() != p) return "prior correlation: wrong size";
    if (!correlation.isApprox(correlation.transpose(), 1e-12) ||
        (correlation.diagonal().array() - 1.0).abs().maxCoeff() > 1e-12) {
      return "prior correlation: must be symmetric with a unit diagonal";
    }
    if (correlation.llt().info() != Eigen::Success) return "prior correlation: not positive definite";
  }
  return {};
}

}  // namespace sigmaheart::estimation
