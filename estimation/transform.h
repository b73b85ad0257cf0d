// Parameter transforms eta (unconstrained, where sigma points live) -> theta (physical, what the
// simulator sees). docs/estimation.md s.1. Clipping to bounds is never done silently.
#pragma once

#include <optional>
#include <string>

namespace sigmaheart::estimation {

enum class TransformKind {
  kIdentity,  // theta = eta
  kLog,       // theta = reference * exp(eta)            (positive parameters)
  kLogit,     // theta = lower + (upper - lower) / (1 + exp(-eta))   (bounded parameters)
};

const char* to_string(TransformKind kind);
std::optional<TransformKind> parse_transform_kind(const std::string& text);  // "identity", "log", "logit"

struct Transform {
  TransformKind kind = TransformKind::kIdentity;
  double reference = 1.0;  // kLog only, > 0
  double lower = 0.0;      // kLogit only, lower < upper
  double upper = 1.0;

  double to_theta(double eta) const;
  // Inverse; throws std::domain_error when theta is outside the transform's range.
  double to_eta(double theta) const;
  double dtheta_deta(double eta) const;
  // Empty when the fields are consistent, else a message.
  std::string validate() const;
};

}  // namespace sigmaheart::estimation
