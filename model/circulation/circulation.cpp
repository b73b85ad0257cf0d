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

namespace {
// sin(pi s / kick_duration) over the kick window ending at each beat start, 0 elsewhere.
double kick_sine(double t, double period, double kick_duration) {
  const double local = t - std::floor(t / period) * period;  // [0, period)
  const double start = period - kick_duration;
  if (kick_duration <= 0.0 || local < start) return 0.0;
  return std::sin(std::numbers::pi * (local - start) / kick_duration);
}
}  // namespace

double atrial_activation(double t, double period, double kick_duration) {
  const double s = kick_sine(t, period, kick_duration);
  return s * s;
}

double AtrialPressure::operator()(double t) const {
  const double s = kick_sine(t, period, kick_duration);
  return P_at0 + P_at_kick * s * s;  // this order: the prescribed beat stays bit for bit
}

double AtrialChamber::elastance(double t) const {
  return E_min + (E_max - E_min) * atrial_activation(t, period, kick_duration);
}

AtrialStep atrial_step(const AtrialChamber& a, double E, double P_v, double P_ar, double V_old,
                       double h, const CirculationParameters& c) {
  // r(P) = (V0 + P/E - V_old)/h - (P_pv - P)/R_pv + q_at(P_v, P_ar, P), q_at = -(mitral term of
  // valve_flow): K_at (P - P_v) for P >= P_v; for P < P_v: K_p (P - P_v) if P_v <= P_ar,
  // K_p (P - P_ar) if P < P_ar < P_v, 0 if P_ar <= P < P_v. Each piece is linear in P with slope
  // 1/(E h) + 1/R_pv + (K_at, K_p or 0) > 0, so exactly one piece holds the root.
  const double base = 1.0 / (E * h) + 1.0 / a.R_pv;
  const double r0 = (a.V0 - V_old) / h - a.P_pv / a.R_pv;  // r(P) = r0 + base P + q_at(P)
  struct Piece { double kP, kPv, kPar; };                   // q_at = kP P + kPv P_v + kPar P_ar
  auto piece_at = [&](double P) -> Piece {
    if (P >= P_v) return {c.K_at, -c.K_at, 0.0};
    if (P_v <= P_ar) return {c.K_p, -c.K_p, 0.0};
    if (P < P_ar) return {c.K_p, 0.0, -c.K_p};
    return {0.0, 0.0, 0.0};
  };
  auto r_at = [&](double P) {
    const Piece q = piece_at(P);
    return r0 + base * P + q.kP * P + q.kPv * P_v + q.kPar * P_ar;
  };
  // The pieces are bounded by the kinks lo <= hi; pick the one where r changes sign.
  const double lo = std::min(P_v, P_ar), hi = std::max(P_v, P_ar);
  double probe;  // a point inside the root's piece
  if (r_at(lo) >= 0.0) probe = lo - 1.0;
  else if (r_at(hi) >= 0.0) probe = hi > lo ? 0.5 * (lo + hi) : hi + 1.0;
  else probe = hi + 1.0;
  const Piece q = piece_at(probe);
  const double slope = base + q.kP;
  AtrialStep out;
  out.P_at = -(r0 + q.kPv * P_v + q.kPar * P_ar) / slope;
  out.V_at = a.V0 + out.P_at / E;
  out.dPat_dPv = -q.kPv / slope;
  out.dPat_dPar = -q.kPar / slope;
  return out;
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
  double mitral = 0.0, dm_dPv = 0.0, dm_dPar = 0.0, dm_dPat = 0.0;  // the second term of q
  if (P_v <= P_at) {
    mitral = c.K_at * (P_v - P_at);
    dm_dPv = c.K_at;
    dm_dPat = -c.K_at;
  } else if (P_v <= std::max(P_ar, P_at)) {
    mitral = c.K_p * (P_v - P_at);
    dm_dPv = c.K_p;
    dm_dPat = -c.K_p;
  } else if (P_ar > P_at) {
    mitral = c.K_p * (P_ar - P_at);
    dm_dPar = c.K_p;
    dm_dPat = -c.K_p;
  }
  f.q = f.q_ar + mitral;
  f.q_at = -mitral;
  f.dq_dPv = f.dqar_dPv + dm_dPv;
  f.dq_dPar = f.dqar_dPar + dm_dPar;
  f.dq_dPat = dm_dPat;
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
