#include "elastance_lv.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace foreign {
namespace {

// Unnormalised double-Hill product g1/(1+g1) * 1/(1+g2) (Stergiopulos et al. 1996).
double double_hill(double s, const ElastanceParameters& p) {
  if (s <= 0.0) return 0.0;
  const double g1 = std::pow(s / p.tau1, p.m1);
  const double g2 = std::pow(s / p.tau2, p.m2);
  return g1 / (1.0 + g1) / (1.0 + g2);
}

}  // namespace

ElastanceLv::ElastanceLv(const ElastanceParameters& p) : ThreeStateLv(p) {
  const double T = period();
  double mx = 0.0;
  for (int k = 0; k <= 20000; ++k) mx = std::max(mx, double_hill(T * k / 20000.0, p_));
  k_norm_ = 1.0 / mx;
}

double ElastanceLv::activation(double t) const {
  const double T = period();
  const double s = t - T * std::floor(t / T);
  return k_norm_ * double_hill(s, p_);
}

double ElastanceLv::atrial_activation(double t) const {
  return raised_cosine_atrium(t, period(), p_);
}

double ElastanceLv::lv_pressure(double t, double V) const {
  const double e = activation(t);
  const double active = p_.Ees * (V - p_.V0_es);
  const double passive = p_.A_ed * (std::exp(p_.B_ed * (V - p_.V0_ed)) - 1.0);
  return e * active + (1.0 - e) * passive;
}

}  // namespace foreign
