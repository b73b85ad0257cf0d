#include "estimation/transform.h"

#include "estimation/enum_names.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

SIGMAHEART_ENUM_TEXT(TransformKind, parse_transform_kind,
    {TransformKind::kIdentity, "identity"}, {TransformKind::kLog, "log"},
    {TransformKind::kLogit, "logit"}, {TransformKind::kIdentity, "none"})

double Transform::to_theta(double eta) const {
  switch (kind) {
    case TransformKind::kIdentity: return eta;
    case TransformKind::kLog: return reference * std::exp(eta);
    case TransformKind::kLogit: {
      // Written so that large |eta| neither overflows nor loses the bound side.
      if (eta >= 0) return lower + (upper - lower) / (1.0 + std::exp(-eta));
      const double e = std::exp(eta);
      return lower + (upper - lower) * e / (1.0 + e);
    }
  }
  return eta;
}

double Transform::to_eta(double theta) const {
  switch (kind) {
    case TransformKind::kIdentity: return theta;
    case TransformKind::kLog:
      if (!(theta > 0)) {
        std::ostringstream s;
        s << "log transform needs a positive value, got " << theta;
        throw std::domain_error(s.str());
      }
      return std::log(theta / reference);
    case TransformKind::kLogit: {
      if (!(theta > lower && theta < upper)) {
        std::ostringstream s;
        s << "logit transform needs a value strictly inside (" << lower << ", " << upper
          << "), got " << theta;
        throw std::domain_error(s.str());
      }
      const double u = (theta - lower) / (upper - lower);
      return std::log(u / (1.0 - u));
    }
  }
  return theta;
}

double Transform::dtheta_deta(double eta) const {
  switch (kind) {
    case TransformKind::kIdentity: return 1.0;
    case TransformKind::kLog: return reference * std::exp(eta);
    case TransformKind::kLogit: {
      const double s = 1.0 / (1.0 + std::exp(-std::abs(eta)));  // sigmoid(|eta|), stable
      return (upper - lower) * s * (1.0 - s);
    }
  }
  return 1.0;
}

std::string Transform::validate() const {
  if (kind == TransformKind::kLog && !(reference > 0 && std::isfinite(reference))) {
    return "log transform: reference must be positive and finite";
  }
  if (kind == TransformKind::kLogit &&
      !(std::isfinite(lower) && std::isfinite(upper) && lower < upper)) {
    return "logit transform: needs finite bounds with lower < upper";
  }
  return {};
}

}  // namespace sigmaheart::estimation
