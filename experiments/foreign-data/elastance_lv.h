// Foreign LV (a): a time-varying elastance ventricle with an exponential EDPVR, a time-varying
// elastance left atrium fed from a pulmonary-venous pressure, diode-resistance mitral and aortic
// valves and a three-element Windkessel. Written apart from model/ (no shared code).
//
//   LV:   P_lv = e(t) Ees (V_lv - V0_es) + (1 - e(t)) A (exp(B (V_lv - V0_ed)) - 1)
//         e(t) = k (t/tau1)^m1 / (1 + (t/tau1)^m1) * 1 / (1 + (t/tau2)^m2), k: max e = 1
//         (the double-Hill normalised elastance of Stergiopulos, Meister & Westerhof 1996,
//         Am J Physiol 270:H2050, with their human-LV steepness m1 = 1.32, m2 = 27.4); the blend
//         of a linear end-systolic and an exponential end-diastolic relation weighted by e(t) is
//         the ventricle of Smith, Chase, Nokes, Shaw & Wake 2004, Med Eng Phys 26:131.
//   LA:   P_la = (E_min + k_a a(t) (E_max - E_min)) (V_la - V0_la), a(t) a raised-cosine twitch
//         ending shortly after ventricular onset; k_a = 0 removes atrial contraction.
//   Valves: Q = max(dP, 0) / R (ideal diode + resistance: no regurgitation, no inertance; the
//         dynamic valve of Mynard et al. 2012, Int J Numer Meth Biomed Eng 28:626, is not used).
//   Windkessel (Westerhof 3-element): P_ao = P_c + Zc Q_av, C dP_c/dt = Q_av - (P_c - P_ven)/R.
//   Inflow: Q_pv = (P_pv - P_la) / R_pv (P_pv: the preload).
// State y = [V_lv (mL), V_la (mL), P_c (mmHg)].
#pragma once

#include "foreign_bench.h"

namespace foreign {

struct ElastanceParameters {
  double heart_rate = 65.0;  ///< [bpm] (defaults = the healthy case)
  // LV end-systolic line and end-diastolic exponential
  double Ees = 2.6;       ///< [mmHg/mL] end-systolic elastance
  double V0_es = 15.0;    ///< [mL] ESPVR volume intercept
  double A_ed = 0.35;     ///< [mmHg] EDPVR scale
  double B_ed = 0.024;    ///< [1/mL] EDPVR stiffness exponent
  double V0_ed = 10.0;    ///< [mL] EDPVR zero-pressure volume
  // double-Hill activation (Stergiopulos 1996), times in s after activation onset
  double tau1 = 0.18;     ///< [s] rise time constant (Stergiopulos: 0.269 T)
  double tau2 = 0.36;     ///< [s] decay time constant (Stergiopulos: 0.452 T)
  double m1 = 1.32;       ///< [-] rise steepness
  double m2 = 27.4;       ///< [-] decay steepness
  // left atrium
  double E_la_min = 0.15;   ///< [mmHg/mL] passive atrial elastance
  double E_la_max = 0.35;   ///< [mmHg/mL] peak atrial elastance with contraction
  double V0_la = 5.0;       ///< [mL]
  double kick = 1.0;        ///< [-] atrial contraction on (1) or off (0)
  double t_la_onset = 0.10; ///< [s] atrial activation starts this long before ventricular onset
  double T_la = 0.14;       ///< [s] duration of the atrial activation pulse
  // valves and circulation
  double P_pv = 7.5;     ///< [mmHg] pulmonary-venous pressure (preload)
  double R_pv = 0.02;    ///< [mmHg s/mL]
  double R_mv = 0.005;   ///< [mmHg s/mL] open mitral valve
  double R_av = 0.005;   ///< [mmHg s/mL] open aortic valve
  double Zc = 0.05;      ///< [mmHg s/mL] aortic characteristic impedance
  double R_sys = 0.9;    ///< [mmHg s/mL] systemic resistance
  double C_sys = 1.7;    ///< [mL/mmHg] systemic compliance
  double P_ven = 5.0;    ///< [mmHg] systemic venous pressure
};

class ElastanceLv final : public ThreeStateLv<ElastanceLv, ElastanceParameters> {
 public:
  explicit ElastanceLv(const ElastanceParameters& p);

  /// Normalised ventricular elastance e(t) in [0, 1] (Stergiopulos 1996 double Hill, max 1).
  double activation(double t) const;
  /// Atrial activation a(t) in [0, 1]: 0.5 (1 - cos(2 pi s / T_la)) for s in [0, T_la].
  double atrial_activation(double t) const;
  double lv_pressure(double t, double V) const;

 private:
  double k_norm_ = 1.0;  // 1 / max of the double-Hill product over a beat
};

}  // namespace foreign
