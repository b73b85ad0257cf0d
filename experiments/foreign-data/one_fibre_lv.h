// Foreign LV (b): a one-fibre ventricle (Arts, Bovendeerd, Prinzen & Reneman 1991, Biophys J
// 59:93) with a sarcomere-based active stress (Kerckhoffs et al. 2003, Ann Biomed Eng 31:536;
// used in the one-fibre LV of Bovendeerd, Borsje, Arts & van de Vosse 2006, Ann Biomed Eng
// 34:1833), an elastance left atrium fed from a pulmonary-venous pressure, diode-resistance
// valves and a three-element Windkessel. Written apart from model/ and from elastance_lv.*.
//
//   fibre stretch   lambda = ((V_lv + V_w/3) / (V_ref + V_w/3))^(1/3)      (Arts 1991, one-fibre
//                   relation: lambda^3 = (1 + 3 V_lv/V_w) / (1 + 3 V_ref/V_w))
//   cavity pressure p_lv = (sigma_f / 3) ln(1 + V_w / V_lv)                 (Arts 1991, radial
//                   wall stress neglected)
//   fibre stress    sigma_f = sigma_p(lambda) + sigma_a
//   passive         sigma_p = c_p (exp(k_p (lambda - 1)) - 1) for lambda > 1, linear below
//   active          sigma_a = T0 f(l_c) g(t_a, l_s) E_a (l_s - l_c), l_s = l_s_ref lambda
//                   f(l_c) = tanh^2(a_l (l_c - l_c0)) for l_c > l_c0, else 0
//                   g = tanh^2(t_a / tau_r) tanh^2((t_max - t_a) / tau_d), 0 <= t_a <= t_max
//                   t_max = b (l_s - l_d)           (longer twitch at longer sarcomeres)
//                   dl_c/dt = v0 (E_a (l_s - l_c) - 1)                       (Kerckhoffs 2003)
// The length dependence of f and t_max is the cellular Frank-Starling mechanism. The form follows
// Kerckhoffs 2003 / Bovendeerd 2006; the values (OneFibreParameters, cases.yaml) were tuned here
// for the cases, not copied from their tables.
// State y = [V_lv (mL), l_c (um), V_la (mL), P_c (mmHg)].
#pragma once

#include "foreign_bench.h"

namespace foreign {

struct OneFibreParameters {
  double heart_rate = 72.0;  ///< [bpm] (defaults = the healthy case)
  // geometry (one-fibre model)
  double V_wall = 160.0;     ///< [mL] wall volume (LV mass ~ 170 g)
  double V_ref = 60.0;       ///< [mL] cavity volume at fibre stretch 1
  double l_s_ref = 1.9;      ///< [um] sarcomere length at fibre stretch 1
  // passive fibre stress
  double c_p = 0.7;          ///< [kPa]
  double k_p = 10.0;         ///< [-]
  // active fibre stress (Kerckhoffs 2003 form)
  double T0 = 130.0;         ///< [kPa] contractility
  double E_a = 20.0;         ///< [1/um] series-elastic stiffness
  double a_l = 2.0;          ///< [1/um] length dependence of the contractile element
  double l_c0 = 1.5;         ///< [um] contractile length of zero active stress
  double v0 = 7.5;           ///< [um/s] unloaded shortening velocity
  double tau_r = 0.075;      ///< [s] rise time
  double tau_d = 0.15;       ///< [s] decay time
  double b = 0.20;           ///< [s/um] twitch duration per sarcomere length
  double l_d = -0.6;         ///< [um] sarcomere length of zero twitch duration
  // left atrium
  double E_la_passive = 0.15;  ///< [mmHg/mL]
  double E_la_active = 0.35;   ///< [mmHg/mL] peak elastance with contraction
  double V0_la = 5.0;          ///< [mL]
  bool atrial_contraction = true;
  double t_la_lead = 0.10;     ///< [s] atrial onset before ventricular onset
  double T_la = 0.14;          ///< [s] atrial twitch duration
  // valves and circulation
  double P_pv = 8.5;     ///< [mmHg]
  double R_pv = 0.02;    ///< [mmHg s/mL]
  double R_mv = 0.005;   ///< [mmHg s/mL]
  double R_av = 0.005;   ///< [mmHg s/mL]
  double Zc = 0.05;      ///< [mmHg s/mL]
  double R_sys = 0.95;   ///< [mmHg s/mL]
  double C_sys = 1.6;    ///< [mL/mmHg]
  double P_ven = 5.0;    ///< [mmHg]
};

class OneFibreLv final : public LvCircuit {
 public:
  explicit OneFibreLv(const OneFibreParameters& p) : p_(p) {}
  double period() const override { return 60.0 / p_.heart_rate; }
  Eigen::VectorXd initial_state() const override;
  void rhs(double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) const override;
  Sample observe(double t, const Eigen::VectorXd& y) const override;

  double fibre_stretch(double V_lv) const;
  /// Fibre stress [kPa] at cycle time t, cavity volume V_lv [mL], contractile length l_c [um].
  double fibre_stress(double t, double V_lv, double l_c) const;
  /// Cavity pressure [mmHg] from fibre stress (Arts 1991).
  double cavity_pressure(double t, double V_lv, double l_c) const;
  const OneFibreParameters& parameters() const { return p_; }

 private:
  OneFibreParameters p_;
};

}  // namespace foreign
