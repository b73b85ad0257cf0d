#include "estimation/prior_conflict.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

std::string PriorConflict::detail(int j) const {
  const auto k = static_cast<size_t>(j);
  std::ostringstream s;
  s.precision(2);
  s << std::showpos << std::fixed << prior_z(j) << std::noshowpos << " prior std";
  s.unsetf(std::ios::fixed);
  s.precision(2);
  if (std::isfinite(ratio(j))) s << ", " << ratio(j) << "x prior";
  if (in_range[k] == 0) {
    s.precision(3);
    s << ", outside " << range_lower[k] << "-" << range_upper[k];
    if (!range_source[k].empty()) s << " " << range_source[k].substr(0, range_source[k].find(']') + 1);
  }
  return s.str();
}

std::string PriorConflict::describe() const {
  if (absorbed_by.empty()) return {};
  std::ostringstream s;
  s << "prior conflict: model discrepancy absorbed by ";
  for (size_t a = 0; a < absorbed_by.size(); ++a) {
    for (size_t j = 0; j < names.size(); ++j) {
      if (names[j] == absorbed_by[a]) s << (a ? ", " : "") << names[j] << " (" << detail(static_cast<int>(j)) << ")";
    }
  }
  return s.str();
}

PriorConflict prior_conflict(const Prior& prior, const Eigen::Ref<const Eigen::VectorXd>& eta,
                             double z_limit) {
  const int p = prior.size();
  if (eta.size() != p) {
    throw std::invalid_argument("prior conflict: " + std::to_string(eta.size()) + " estimates for " +
                                std::to_string(p) + " parameters");
  }
  if (!(z_limit > 0)) throw std::invalid_argument("prior conflict: z_limit must be > 0");
  PriorConflict c;
  c.z_limit = z_limit;
  c.names = prior.names();
  c.prior_z = (eta - prior.mean_eta()).cwiseQuotient(prior.std_eta());
  const Eigen::VectorXd theta = prior.to_theta(eta);
  const Eigen::VectorXd theta0 = prior.nominal_theta();
  c.ratio.resize(p);
  for (int j = 0; j < p; ++j) {
    const PriorParameter& q = prior[j];
    c.ratio(j) = theta0(j) != 0.0 ? theta(j) / theta0(j) : std::nan("");
    const bool ranged = !std::isnan(q.range_lower) && !std::isnan(q.range_upper);
    c.in_range.push_back(!ranged ? -1 : (theta(j) >= q.range_lower && theta(j) <= q.range_upper) ? 1 : 0);
    c.range_lower.push_back(q.range_lower);
    c.range_upper.push_back(q.range_upper);
    c.range_source.push_back(q.range_source);
    if (std::abs(c.prior_z(j)) > z_limit || c.in_range.back() == 0) c.absorbed_by.push_back(q.name);
  }
  return c;
}

}  // namespace sigmaheart::estimation
