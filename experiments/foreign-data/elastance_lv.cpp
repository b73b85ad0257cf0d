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

ElastanceLv::ElastanceLv(const ElastanceParameters& p) : p_(p) {
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
  const double T = period();
  double s = t + p_.t_la_onset;  // time since atrial onset
  s -= T * std::floor(s / T);
  if (s >= p_.T_la) return 0.0;
  return 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * s / p_.T_la));
}

double ElastanceLv::lv_pressure(double t, double V) const {
  const double e = activation(t);
  const double active = p_.Ees * (V - p_.V0_es);
  const double passive = p_.A_ed * (std::exp(p_.B_ed * (V - p_.V0_ed)) - 1.0);
  return e * active + (1.0 - e) * passive;
}

Eigen::VectorXd ElastanceLv::initial_state() const {
  Eigen::VectorXd y(3);
  y << 120.0, 60.0, 80.0;
  return y;
}

Sample ElastanceLv::observe(double t, const Eigen::VectorXd& y) const {
  Sample s = sample_with_volumes(t, y(0), y(1));
  const double P_c = y(2);
  s.P_lv = lv_pressure(t, s.V_lv);
  const double E_la = p_.E_la_min + p_.kick * atrial_activation(t) * (p_.E_la_max - p_.E_la_min);
  s.P_la = E_la * (s.V_la - p_.V0_la);
  s.Q_pv = (p_.P_pv - s.P_la) / p_.R_pv;
  s.Q_mv = std::max(s.P_la - s.P_lv, 0.0) / p_.R_mv;
  s.Q_av = std::max(s.P_lv - P_c, 0.0) / (p_.R_av + p_.Zc);
  s.P_ao = P_c + p_.Zc * s.Q_av;
  s.Q_per = (P_c - p_.P_ven) / p_.R_sys;
  return s;
}

void ElastanceLv::rhs(double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) const {
  const Sample s = observe(t, y);
  dy(0) = s.Q_mv - s.Q_av;
  dy(1) = s.Q_pv - s.Q_mv;
  dy(2) = (s.Q_av - s.Q_per) / p_.C_sys;
}

}  // namespace foreign
