// Foreign LV (c): a thin-walled sphere with a Mooney-Rivlin wall and an active stress prescribed
// in time (no length or velocity dependence), an elastance left atrium fed from a
// pulmonary-venous pressure, diode-resistance valves and a three-element Windkessel. Written apart
// from model/ and from the other bench simulators (it shares foreign_bench.h only).
//
//   geometry      lambda = (V_lv / V0)^(1/3) (equibiaxial stretch of the wall, incompressible,
//                 thin: h r^2 = const, so V_w / V_lv = 3 h / r)
//   passive       sigma_p = 2 (lambda^2 - lambda^-4) (C1 + C2 lambda^2)      (Cauchy stress of an
//                 incompressible Mooney-Rivlin membrane in equibiaxial extension; Adkins & Rivlin
//                 1952, Phil Trans R Soc A 244:505; Beatty 1987, Appl Mech Rev 40:1699, s.6)
//   active        sigma_a = T_max a(t) max(0, 1 + beta (lambda - 1)), a(t) the piecewise-cosine
//                 activation of Korakianitis & Shi 2006 (Med Eng Phys 28:613, eq. for e(t)):
//                 0.5 (1 - cos(pi t / T1)) on [0, T1), 0.5 (1 + cos(pi (t - T1) / (T2 - T1)))
//                 on [T1, T2), 0 after; the time course is prescribed (no calcium or
//                 cross-bridge dynamics), scaled by the linear tension-length relation of Hunter,
//                 McCulloch & ter Keurs 1998 (Prog Biophys Mol Biol 69:289, eq. 3, beta_0 1.45
//                 there). With the Laplace law below P ~ sigma / lambda^3, so beta < 3 makes the
//                 end-systolic pressure fall with volume and the sphere empties itself; beta = 4.5
//                 here gives a rising end-systolic pressure-volume relation.
//   Laplace       P_lv = 2 (sigma_p + sigma_a) h / r = (2/3) (V_w / V_lv) (sigma_p + sigma_a)
//                 (thin-walled sphere; with C2 / C1 >= 0.25 the passive P(V) has no limit point,
//                 Muller & Strehlow 2004, Rubber and Rubber Balloons, Lect Notes Phys 637, s.6.1)
//   atrium, valves, Windkessel, inflow: as in elastance_lv.h.
// The values (MooneyRivlinParameters, cases.yaml) were tuned here for the cases. Stresses in kPa,
// pressures in mmHg (1 kPa = 7.50062 mmHg).
// State y = [V_lv (mL), V_la (mL), P_c (mmHg)].
#pragma once

#include "foreign_bench.h"

namespace foreign {

struct MooneyRivlinParameters {
  double heart_rate = 68.0;  ///< [bpm] (defaults = the healthy case)
  double V_wall = 150.0;     ///< [mL] wall volume
  double V0 = 62.0;          ///< [mL] unloaded cavity volume (lambda = 1)
  double C1 = 0.26;          ///< [kPa] Mooney-Rivlin c1
  double C2 = 0.13;          ///< [kPa] Mooney-Rivlin c2
  double T_max = 10.5;       ///< [kPa] peak active stress at lambda = 1
  double beta = 4.5;         ///< [-] slope of the tension-length relation
  double T1 = 0.22;          ///< [s] time of peak activation after onset (Korakianitis & Shi: 0.3 T)
  double T2 = 0.38;          ///< [s] end of activation after onset (Korakianitis & Shi: 0.45 T)
  // left atrium
  double E_la_min = 0.15;    ///< [mmHg/mL]
  double E_la_max = 0.35;    ///< [mmHg/mL]
  double V0_la = 5.0;        ///< [mL]
  double kick = 1.0;         ///< [-] atrial contraction on (1) or off (0)
  double t_la_onset = 0.10;  ///< [s] atrial activation starts this long before ventricular onset
  double T_la = 0.14;        ///< [s]
  // valves and circulation
  double P_pv = 8.0;     ///< [mmHg]
  double R_pv = 0.02;    ///< [mmHg s/mL]
  double R_mv = 0.005;   ///< [mmHg s/mL]
  double R_av = 0.005;   ///< [mmHg s/mL]
  double Zc = 0.05;      ///< [mmHg s/mL]
  double R_sys = 0.80;   ///< [mmHg s/mL]
  double C_sys = 1.6;    ///< [mL/mmHg]
  double P_ven = 5.0;    ///< [mmHg]
};

class MooneyRivlinLv final : public ThreeStateLv<MooneyRivlinLv, MooneyRivlinParameters> {
 public:
  explicit MooneyRivlinLv(const MooneyRivlinParameters& p) : ThreeStateLv(p) {}

  double activation(double t) const;          ///< a(t) in [0, 1], t after ventricular onset (mod T)
  double atrial_activation(double t) const;   ///< raised cosine of T_la, starting t_la_onset early
  double passive_stress(double lambda) const; ///< [kPa]
  double lv_pressure(double t, double V) const;  ///< [mmHg]

 private:
};

}  // namespace foreign
