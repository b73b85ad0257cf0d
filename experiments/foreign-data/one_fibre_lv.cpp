#include "one_fibre_lv.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace foreign {
namespace {

constexpr double kKpaPerMmHg = 0.133322;

double tanh2(double x) {
  const double th = std::tanh(x);
  return th * th;
}

}  // namespace

Eigen::VectorXd OneFibreLv::initial_state() const {
  Eigen::VectorXd y(4);
  y << 120.0, p_.l_s_ref * fibre_stretch(120.0) - 1.0 / p_.E_a, 60.0, 80.0;
  return y;
}

double OneFibreLv::fibre_stretch(double V_lv) const {
  return std::cbrt((V_lv + p_.V_wall / 3.0) / (p_.V_ref + p_.V_wall / 3.0));
}

double OneFibreLv::fibre_stress(double t, double V_lv, double l_c) const {
  const double lambda = fibre_stretch(V_lv);
  const double sigma_p = lambda > 1.0 ? p_.c_p * (std::exp(p_.k_p * (lambda - 1.0)) - 1.0)
                                      : p_.c_p * p_.k_p * (lambda - 1.0);
  const double l_s = p_.l_s_ref * lambda;
  const double T = period();
  const double t_a = t - T * std::floor(t / T);  // time since ventricular activation
  const double t_max = p_.b * (l_s - p_.l_d);
  double g = 0.0;
  if (t_a < t_max) g = tanh2(t_a / p_.tau_r) * tanh2((t_max - t_a) / p_.tau_d);
  const double f = l_c > p_.l_c0 ? tanh2(p_.a_l * (l_c - p_.l_c0)) : 0.0;
  const double sigma_a = p_.T0 * f * g * p_.E_a * (l_s - l_c);
  return sigma_p + sigma_a;
}

double OneFibreLv::cavity_pressure(double t, double V_lv, double l_c) const {
  const double sigma_f = fibre_stress(t, V_lv, l_c);
  return sigma_f / 3.0 * std::log(1.0 + p_.V_wall / V_lv) / kKpaPerMmHg;
}

Sample OneFibreLv::observe(double t, const Eigen::VectorXd& y) const {
  Sample s = sample_with_volumes(t, y(0), y(2));
  const double P_c = y(3);
  s.P_lv = cavity_pressure(t, s.V_lv, y(1));
  // atrial twitch sin^2(pi s / T_la) starting t_la_lead before ventricular activation
  const double T = period();
  double since = t + p_.t_la_lead;
  since -= T * std::floor(since / T);
  double act = 0.0;
  if (p_.atrial_contraction && since < p_.T_la) {
    const double sn = std::sin(std::numbers::pi * since / p_.T_la);
    act = sn * sn;
  }
  s.P_la = (p_.E_la_passive + act * (p_.E_la_active - p_.E_la_passive)) * (s.V_la - p_.V0_la);
  s.Q_pv = (p_.P_pv - s.P_la) / p_.R_pv;
  s.Q_mv = s.P_la > s.P_lv ? (s.P_la - s.P_lv) / p_.R_mv : 0.0;
  s.Q_av = s.P_lv > P_c ? (s.P_lv - P_c) / (p_.R_av + p_.Zc) : 0.0;
  s.P_ao = P_c + p_.Zc * s.Q_av;
  s.Q_per = (P_c - p_.P_ven) / p_.R_sys;
  return s;
}

void OneFibreLv::rhs(double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) const {
  const Sample s = observe(t, y);
  const double l_s = p_.l_s_ref * fibre_stretch(y(0));
  dy(0) = s.Q_mv - s.Q_av;
  dy(1) = p_.v0 * (p_.E_a * (l_s - y(1)) - 1.0);
  dy(2) = s.Q_pv - s.Q_mv;
  dy(3) = (s.Q_av - s.Q_per) / p_.C_sys;
}

}  // namespace foreign
