// Valves, two-stage Windkessel and the atrium, prescribed or a chamber (docs/models.md section 2), shared by the
// lumped sphere, the regional lumped ventricle and the 3D model. After Caruel et al. 2014
// (Biomech Model Mechanobiol 13:897, section 2.3) and Sainte-Marie et al. 2006.
//
// Sign conventions (all flows in m^3/s):
//   q     ventricular outflow, q = q_ar - q_at; cavity balance C_cav dP_v/dt + q + dV/dt = 0
//   q_ar  flow through the aortic valve into the proximal artery (> 0 in ejection)
//   q_at  flow through the mitral valve into the ventricle (> 0 in filling, < 0 for the leak)
// Valve law (continuous in P_v, piecewise linear):
//   filling     P_v <= P_at        q = K_at (P_v - P_at)                   q_ar = 0
//   closed      P_at < P_v <= P_ar q = K_p (P_v - P_at)  (small leak)      q_ar = 0
//   ejection    P_v > P_ar         q = K_ar (P_v - P_ar) + K_p (P_ar - P_at)
//                                  q_ar = K_ar (P_v - P_ar)
// Windkessel: C_p dP_ar/dt = q_ar - (P_ar - P_d)/R_p
//             C_d dP_d/dt  = (P_ar - P_d)/R_p - (P_d - P_sv)/R_d
#pragma once

#include <string>

namespace sigmaheart::model::circulation {

struct CirculationParameters {
  double K_at = 6e-7;   // mitral (atrio-ventricular) valve conductance [m^3/(Pa s)]
  double K_ar = 1e-7;   // aortic valve conductance [m^3/(Pa s)]
  double K_p = 5e-11;   // leak conductance of the closed valves [m^3/(Pa s)]
  double R_p = 5e7;     // proximal resistance [Pa s/m^3]
  double R_d = 1e8;     // distal resistance [Pa s/m^3]
  double C_p = 6e-9;    // proximal compliance [m^3/Pa]
  double C_d = 1e-9;    // distal compliance [m^3/Pa]
  double P_sv = 1e3;    // venous (downstream) pressure [Pa]
  double C_cav = 5e-12; // cavity compliance, regularises the isovolumic phases [m^3/Pa]
  std::string validate() const;  // empty when valid
};

// Prescribed atrial pressure: a baseline plus an atrial kick, a sin^2 bump of amplitude P_at_kick
// over the kick_duration that ends at the start of each beat (t mod period = 0, the ventricular
// depolarisation of the lumped models). P_at0 and P_at_kick are estimated parameters; the kick
// timing is fixed (atrial systole precedes the QRS by about 0.1 s; Guyton & Hall, ch. 9).
struct AtrialPressure {
  double P_at0 = 1e3;          // baseline [Pa]
  double P_at_kick = 0.5e3;    // amplitude of the atrial kick [Pa]
  double kick_duration = 0.12; // [s]
  double period = 0.85;        // heart period [s]
  double operator()(double t) const;
};

// The atrial activation of both atrium forms: sin^2(pi s / kick_duration) over the kick_duration
// that ends at each beat start (s the time since the kick began), 0 elsewhere; in [0, 1].
double atrial_activation(double t, double period, double kick_duration);

// The left atrium as a chamber (docs/models.md s.2.2): a time-varying elastance filled from the
// pulmonary veins through a resistance, emptied through the mitral valve,
//   P_at = E_at(t) (V_at - V_at0),  E_at(t) = E_at_min + (E_at_max - E_at_min) a(t),
//   dV_at/dt = (P_pv - P_at) / R_pv - q_at,
// a(t) = atrial_activation(t) (the kick of AtrialPressure). Unlike a prescribed pressure it stores
// the pulmonary-venous inflow of systole and gives it back when the mitral valve opens: the rapid
// early filling (E wave) followed by slow conduit filling (diastasis). The time-varying elastance
// atrium of Korakianitis & Shi 2006 (Med Eng Phys 28:613, Table 1: E_pas 0.15, E_act 0.25
// mmHg/mL, V_ref 4 mL; pulmonary-vein resistance 0.006 mmHg s/mL) with the kick's timing.
struct AtrialChamber {
  double E_min = 2.0e7;        // passive elastance [Pa/m^3] (0.15 mmHg/mL)
  double E_max = 5.33e7;       // elastance at the peak of the kick [Pa/m^3] (0.40 mmHg/mL)
  double V0 = 4e-6;            // unstressed volume [m^3]
  double P_pv = 1050.0;        // pulmonary-venous pressure [Pa]
  double R_pv = 8.0e5;         // pulmonary-venous resistance [Pa s/m^3] (0.006 mmHg s/mL)
  double kick_duration = 0.12; // [s]
  double period = 0.85;        // heart period [s]
  double elastance(double t) const;
  double pressure(double t, double V_at) const { return elastance(t) * (V_at - V0); }
};

// Which valve is open, from the valve law.
enum class ValveRegime { kFilling = 0, kClosed = 1, kEjection = 2 };

// Cardiac phase recorded as the diagnostic channel "phase" (unit "1"):
//   0 filling (mitral open), 1 isovolumic contraction (both closed after filling),
//   2 ejection (aortic open), 3 isovolumic relaxation (both closed after ejection).
// Closed valves are told apart by the last regime with an open valve.
enum class Phase {
  kFilling = 0,
  kIsovolumicContraction = 1,
  kEjection = 2,
  kIsovolumicRelaxation = 3,
};
Phase phase(ValveRegime now, ValveRegime last_open);
const char* to_string(Phase p);

// Valve flows and their partial derivatives (for Newton Jacobians).
struct ValveFlow {
  ValveRegime regime = ValveRegime::kFilling;
  double q = 0.0;       // ventricular outflow q_ar - q_at [m^3/s]
  double q_ar = 0.0;    // aortic flow [m^3/s]
  double q_at = 0.0;    // mitral inflow [m^3/s]
  double dq_dPv = 0.0, dq_dPar = 0.0, dq_dPat = 0.0;
  double dqar_dPv = 0.0, dqar_dPar = 0.0;
};
ValveFlow valve_flow(double P_v, double P_ar, double P_at, const CirculationParameters& c);

// One backward-Euler step of the atrial chamber over [t1 - h, t1], with the mitral flow of
// valve_flow() at the new (P_v, P_ar) and E = a.elastance(t1) (computed once per step by the
// caller): the atrial pressure P_at at t1 that solves
//   (V0 + P_at / E - V_old) / h = (P_pv - P_at) / R_pv - q_at(P_v, P_ar, P_at),
// exactly (the residual is continuous, piecewise linear and strictly increasing in P_at, with
// kinks at P_v and P_ar only), the atrial volume and the derivatives of P_at in (P_v, P_ar).
struct AtrialStep {
  double P_at = 0.0, V_at = 0.0;
  double dPat_dPv = 0.0, dPat_dPar = 0.0;
};
AtrialStep atrial_step(const AtrialChamber& a, double E, double P_v, double P_ar, double V_old,
                       double h, const CirculationParameters& c);

// Backward-Euler residuals of the Windkessel (units m^3/s) and their derivatives with respect to
// (P_ar, P_d) at t^{n+1}; q_ar enters with its own derivative through valve_flow().
struct WindkesselResidual {
  double r_ar = 0.0, r_d = 0.0;
  double dar_dPar = 0.0, dar_dPd = 0.0;  // d r_ar / d(P_ar, P_d), q_ar excluded
  double dd_dPar = 0.0, dd_dPd = 0.0;
};
WindkesselResidual windkessel_residual(double P_ar, double P_d, double P_ar_old, double P_d_old,
                                       double q_ar, double h, const CirculationParameters& c);

}  // namespace sigmaheart::model::circulation
