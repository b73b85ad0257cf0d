#include "model/circulation/circulation.h"

#include "model/enum_names.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

namespace sigmaheart::model::circulation {

std::string CirculationParameters::validate() const {
  const struct { const char* name; double v; } positive[] = {
      {"K_at", K_at}, {"K_ar", K_ar}, {"R_p", R_p}, {"R_d", R_d},
      {"C_p", C_p},   {"C_d", C_d},   {"C_cav", C_cav}};
  for (const auto& f : positive) {
    if (!std::isfinite(f.v) || f.v <= 0.0) {
      std::ostringstream s;
      s << f.name << " = " << f.v << " must be finite and > 0";
      return s.str();
    }
  }
  if (!std::isfinite(K_p) || K_p < 0.0) return "K_p must be finite and >= 0";
  if (!std::isfinite(P_sv)) return "P_sv must be finite";
  return {};
}

double AtrialPressure::operator()(double t) const {
  const double local = t - std::floor(t / period) * period;  // [0, period)
  const double start = period - kick_duration;
  if (kick_duration <= 0.0 || local < start) return P_at0;
  const double s = std::sin(std::numbers::pi * (local - start) / kick_duration);
  return P_at0 + P_at_kick * s * s;
}

Phase phase(ValveRegime now, ValveRegime last_open) {
  switch (now) {
    case ValveRegime::kFilling: return Phase::kFilling;
    case ValveRegime::kEjection: return Phase::kEjection;
    case ValveRegime::kClosed:
      return last_open == ValveRegime::kEjection ? Phase::kIsovolumicRelaxation
                                                 : Phase::kIsovolumicContraction;
  }
  return Phase::kFilling;
}

constexpr std::array<EnumName<Phase>, 4> kPhaseNames{{
    {Phase::kFilling, "filling"}, {Phase::kIsovolumicContraction, "isovolumic contraction"},
    {Phase::kEjection, "ejection"}, {Phase::kIsovolumicRelaxation, "isovolumic relaxation"},
}};
const char* to_string(Phase p) { return enum_to_string(kPhaseNames, p); }

ValveFlow valve_flow(double P_v, double P_ar, double P_at, const CirculationParameters& c) {
  // Caruel et al. 2014 s.2.3 (docs/models.md s.2.2), written as two valves so that it stays
  // continuous when the atrial pressure exceeds the arterial one (both valves open, a corner of the
  // parameter box that the regime-by-regime form left discontinuous):
  //   q = K_ar (P_v - P_ar)^+ + { K_at (P_v - P_at)                         if P_v <= P_at
  //                             { K_p (min(P_v, max(P_ar, P_at)) - P_at)     otherwise.
  // For P_at <= P_ar this is the published law term by term: filling K_at (P_v - P_at), closed
  // K_p (P_v - P_at), ejection K_ar (P_v - P_ar) + K_p (P_ar - P_at).
  ValveFlow f;
  const bool aortic_open = P_v > P_ar;
  if (aortic_open) {
    f.q_ar = c.K_ar * (P_v - P_ar);
    f.dqar_dPv = c.K_ar;
    f.dqar_dPar = -c.K_ar;
  }
  double mitral = 0.0, dm_dPv = 0.0, dm_dPar = 0.0;  // the second term of q
  if (P_v <= P_at) {
    mitral = c.K_at * (P_v - P_at);
    dm_dPv = c.K_at;
  } else if (P_v <= std::max(P_ar, P_at)) {
    mitral = c.K_p * (P_v - P_at);
    dm_dPv = c.K_p;
  } else if (P_ar > P_at) {
    mitral = c.K_p * (P_ar - P_at);
    dm_dPar = c.K_p;
  }
  f.q = f.q_ar + mitral;
  f.q_at = -mitral;
  f.dq_dPv = f.dqar_dPv + dm_dPv;
  f.dq_dPar = f.dqar_dPar + dm_dPar;
  f.regime = aortic_open ? ValveRegime::kEjection
                         : (P_v <= P_at ? ValveRegime::kFilling : ValveRegime::kClosed);
  return f;
}

WindkesselResidual windkessel_residual(double P_ar, double P_d, double P_ar_old, double P_d_old,
                                       double q_ar, double h, const CirculationParameters& c) {
  WindkesselResidual r;
  const double q_p = (P_ar - P_d) / c.R_p;
  r.r_ar = c.C_p * (P_ar - P_ar_old) / h - q_ar + q_p;
  r.r_d = c.C_d * (P_d - P_d_old) / h - q_p + (P_d - c.P_sv) / c.R_d;
  r.dar_dPar = c.C_p / h + 1.0 / c.R_p;
  r.dar_dPd = -1.0 / c.R_p;
  r.dd_dPar = -1.0 / c.R_p;
  r.dd_dPd = c.C_d / h + 1.0 / c.R_p + 1.0 / c.R_d;
  return r;
}

}  // namespace sigmaheart::model::circulation
