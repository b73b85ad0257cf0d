#include "model/bcs/active_law.h"

#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

namespace sigmaheart::model::bcs {

std::string ActiveParameters::validate() const {
  std::ostringstream s;
  auto finite_nonneg = [&](const char* name, double v) {
    if (!std::isfinite(v) || v < 0.0) {
      s << name << " = " << v << " must be finite and >= 0";
      return false;
    }
    return true;
  };
  if (!finite_nonneg("Es", Es) || !finite_nonneg("mu", mu) || !finite_nonneg("alpha", alpha) ||
      !finite_nonneg("k0", k0) || !finite_nonneg("sigma0", sigma0) ||
      !finite_nonneg("k_ATP", k_ATP) || !finite_nonneg("k_RS", k_RS) ||
      !finite_nonneg("APD", APD) || !finite_nonneg("n0_slope", n0_slope)) {
    return s.str();
  }
  if (Es <= 0.0) return "Es must be > 0 (the series element carries the active stress)";
  return input.validate();
}

double active_fraction(double t0, double t1, double T_d, double APD, double period) {
  const double h = t1 - t0;
  if (!(h > 0.0)) return 0.0;
  if (APD >= period) return 1.0;
  if (APD <= 0.0) return 0.0;
  const double m_min = std::floor((t0 - T_d - APD) / period);
  const double m_max = std::floor((t1 - T_d) / period);
  double inside = 0.0;
  for (double m = m_min; m <= m_max; m += 1.0) {
    const double a = T_d + m * period;
    const double lo = std::max(a, t0);
    const double hi = std::min(a + APD, t1);
    if (hi > lo) inside += hi - lo;
  }
  return std::clamp(inside / h, 0.0, 1.0);
}

const char* to_string(ActivationShape shape) {
  return shape == ActivationShape::kSquare ? "square" : "ramped";
}

std::string ActivationInput::validate() const {
  if (shape == ActivationShape::kSquare) return {};
  std::ostringstream s;
  const RampedActivation& r = ramp;
  if (!(r.rise > 0.0 && r.rise < 1.0)) s << "rise = " << r.rise << " must lie in (0, 1) (a fraction of APD)";
  else if (!(r.fall > 0.0 && r.fall < 1.0)) s << "fall = " << r.fall << " must lie in (0, 1) (a fraction of APD)";
  else if (r.rise + r.fall > 1.0) s << "rise + fall = " << r.rise + r.fall << " must be <= 1 (fractions of APD)";
  else if (!(r.relax_ramp >= 0.0 && r.relax_ramp < 10.0)) s << "relax_ramp = " << r.relax_ramp << " s must lie in [0, 10)";
  else if (!(r.relax_hold >= 0.0 && r.relax_hold < 10.0)) s << "relax_hold = " << r.relax_hold << " s must lie in [0, 10)";
  else if (!(r.rest_ramp >= 0.0 && r.rest_ramp < 10.0)) s << "rest_ramp = " << r.rest_ramp << " s must lie in [0, 10)";
  else if (!(r.rest >= 0.0 && r.rest <= 1.0)) s << "rest = " << r.rest << " must lie in [0, 1] (a fraction of k_RS)";
  return s.str();
}

namespace {

// The knots (s_k, u_k) of the ramped profile on [0, period], cut at the period; s_0 = 0, the last
// knot at the period. Seven segments at most.
struct Knots {
  std::array<double, 9> s{}, u{};
  int n = 0;
};

Knots ramped_knots(const ActiveParameters& p, double period) {
  const RampedActivation& r = p.input.ramp;
  const double rest = -r.rest * p.k_RS;
  const std::array<double, 7> s = {0.0,
                                   r.rise * p.APD,
                                   (1.0 - r.fall) * p.APD,
                                   p.APD,
                                   p.APD + r.relax_ramp,
                                   p.APD + r.relax_ramp + r.relax_hold,
                                   p.APD + r.relax_ramp + r.relax_hold + r.rest_ramp};
  const std::array<double, 7> u = {rest, p.k_ATP, p.k_ATP, 0.0, -p.k_RS, -p.k_RS, rest};
  Knots k;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] >= period) {  // cut: the value at the period on the segment that crosses it
      const double w = (period - s[i - 1]) / (s[i] - s[i - 1]);
      k.s[static_cast<size_t>(k.n)] = period;
      k.u[static_cast<size_t>(k.n++)] = u[i - 1] + w * (u[i] - u[i - 1]);
      return k;
    }
    k.s[static_cast<size_t>(k.n)] = s[i];
    k.u[static_cast<size_t>(k.n++)] = u[i];
  }
  k.s[static_cast<size_t>(k.n)] = period;  // the diastolic rate held to the period
  k.u[static_cast<size_t>(k.n++)] = rest;
  return k;
}

// Integrals of |u| and max(u, 0) of the linear u from (a, ua) to (b, ub), b >= a.
void add_linear(double a, double ua, double b, double ub, StepActivation& sum) {
  const double h = b - a;
  if (!(h > 0.0)) return;
  if (ua >= 0.0 && ub >= 0.0) {
    sum.u_abs += 0.5 * (ua + ub) * h;
    sum.u_plus += 0.5 * (ua + ub) * h;
  } else if (ua <= 0.0 && ub <= 0.0) {
    sum.u_abs -= 0.5 * (ua + ub) * h;
  } else {  // one zero inside: two triangles
    const double z = h * ua / (ua - ub);  // distance from a to the zero
    const double pos = 0.5 * (ua > 0.0 ? ua * z : ub * (h - z));
    const double neg = 0.5 * (ua < 0.0 ? -ua * z : -ub * (h - z));
    sum.u_abs += pos + neg;
    sum.u_plus += pos;
  }
}

// Integrals over [lo, hi] (within [0, period]) of the ramped profile.
void add_profile(const Knots& k, double lo, double hi, StepActivation& sum) {
  for (int i = 0; i + 1 < k.n; ++i) {
    const double s0 = k.s[static_cast<size_t>(i)], s1 = k.s[static_cast<size_t>(i + 1)];
    const double a = std::max(lo, s0), b = std::min(hi, s1);
    if (!(b > a)) continue;
    const double u0 = k.u[static_cast<size_t>(i)], u1 = k.u[static_cast<size_t>(i + 1)];
    const double slope = (u1 - u0) / (s1 - s0);
    add_linear(a, u0 + slope * (a - s0), b, u0 + slope * (b - s0), sum);
  }
}

double profile_value(const Knots& k, double s) {
  for (int i = 0; i + 1 < k.n; ++i) {
    const double s0 = k.s[static_cast<size_t>(i)], s1 = k.s[static_cast<size_t>(i + 1)];
    if (s < s1 || i + 2 == k.n) {
      if (!(s1 > s0)) return k.u[static_cast<size_t>(i + 1)];
      return k.u[static_cast<size_t>(i)] + (s - s0) / (s1 - s0) * (k.u[static_cast<size_t>(i + 1)] - k.u[static_cast<size_t>(i)]);
    }
  }
  return k.u[0];
}

}  // namespace

double activation(double t, double T_d, double period, const ActiveParameters& p) {
  const double local = t - T_d - std::floor((t - T_d) / period) * period;  // in [0, period)
  if (p.input.shape == ActivationShape::kRamped) return profile_value(ramped_knots(p, period), local);
  return local < p.APD ? p.k_ATP : -p.k_RS;
}

StepActivation step_activation(double t0, double t1, double T_d, double period,
                               const ActiveParameters& p) {
  if (p.input.shape == ActivationShape::kSquare) {
    const double f = active_fraction(t0, t1, T_d, p.APD, period);
    return {f * p.k_ATP + (1.0 - f) * p.k_RS, f * p.k_ATP};
  }
  const double h = t1 - t0;
  if (!(h > 0.0)) return {std::abs(activation(t0, T_d, period, p)), std::max(activation(t0, T_d, period, p), 0.0)};
  const Knots k = ramped_knots(p, period);
  StepActivation sum;
  // Every copy [T_d + m period, T_d + (m + 1) period) of the profile that meets [t0, t1].
  const double m_min = std::floor((t0 - T_d) / period), m_max = std::floor((t1 - T_d) / period);
  for (double m = m_min; m <= m_max; m += 1.0) {
    const double origin = T_d + m * period;
    add_profile(k, std::max(t0 - origin, 0.0), std::min(t1 - origin, period), sum);
  }
  sum.u_abs /= h;
  sum.u_plus /= h;
  return sum;
}

double length_factor(double e_c, const ActiveParameters& p, double* derivative) {
  const double n = 1.0 - p.n0_slope * (p.n0_e_max - e_c);
  if (derivative) *derivative = (n > 0.0 && n < 1.0) ? p.n0_slope : 0.0;
  return std::clamp(n, 0.0, 1.0);
}

double active_stress(double e, double e_c, double Es) {
  const double a = 1.0 + 2.0 * e_c;
  return Es * (e - e_c) / (a * a);
}

ActiveStep step_residual(const ActiveParameters& p, const ActiveState& previous,
                         const ActiveState& trial, double e, const StepActivation& act,
                         double h) {
  const double ec = trial.e_c, kc = trial.k_c, tc = trial.tau_c;
  const double a = 1.0 + 2.0 * ec;
  const double a2 = a * a, a3 = a2 * a;
  const double b = 1.0 + 2.0 * e;
  const double vc = (ec - previous.e_c) / h;
  const double sg = (vc > 0.0) ? 1.0 : ((vc < 0.0) ? -1.0 : 0.0);
  const double damp = act.u_abs + p.alpha * std::abs(vc);
  double dn0 = 0.0;
  const double n0 = length_factor(ec, p, &dn0);

  ActiveStep s;
  s.residual(0) = (tc + p.mu * vc) * a3 - p.Es * (e - ec) * b;
  s.residual(1) = (kc - previous.k_c) / h + damp * kc - n0 * p.k0 * act.u_plus;
  s.residual(2) = (tc - previous.tau_c) / h + damp * tc - kc * vc - n0 * p.sigma0 * act.u_plus;

  s.d_state.setZero();
  s.d_state(0, 0) = (p.mu / h) * a3 + (tc + p.mu * vc) * 6.0 * a2 + p.Es * b;
  s.d_state(0, 2) = a3;
  s.d_state(1, 0) = p.alpha * sg / h * kc - dn0 * p.k0 * act.u_plus;
  s.d_state(1, 1) = 1.0 / h + damp;
  s.d_state(2, 0) = p.alpha * sg / h * tc - kc / h - dn0 * p.sigma0 * act.u_plus;
  s.d_state(2, 1) = -vc;
  s.d_state(2, 2) = 1.0 / h + damp;

  s.d_strain << -p.Es * (b + 2.0 * (e - ec)), 0.0, 0.0;

  s.stress = p.Es * (e - ec) / a2;
  s.dstress_dstrain = p.Es / a2;
  s.dstress_dstate << -p.Es / a2 - 4.0 * p.Es * (e - ec) / a3, 0.0, 0.0;
  return s;
}

ReducedStep reduced_step(const ActiveParameters& p, const ActiveState& previous, double e_c,
                         double e, const StepActivation& act, double h) {
  ReducedStep r;
  const double vc = (e_c - previous.e_c) / h;
  const double sg = (vc > 0.0) ? 1.0 : ((vc < 0.0) ? -1.0 : 0.0);
  const double den = 1.0 / h + act.u_abs + p.alpha * std::abs(vc);
  const double dden = p.alpha * sg / h;  // d den / d e_c
  double dn0 = 0.0;
  const double n0 = length_factor(e_c, p, &dn0);
  const double kc = (previous.k_c / h + n0 * p.k0 * act.u_plus) / den;
  r.dk_dec = (dn0 * p.k0 * act.u_plus - kc * dden) / den;
  const double tc = (previous.tau_c / h + kc * vc + n0 * p.sigma0 * act.u_plus) / den;
  r.dtau_dec = (r.dk_dec * vc + kc / h + dn0 * p.sigma0 * act.u_plus - tc * dden) / den;
  r.state = {e_c, kc, tc};

  const double a = 1.0 + 2.0 * e_c;
  const double a2 = a * a, a3 = a2 * a;
  const double b = 1.0 + 2.0 * e;
  r.residual = (tc + p.mu * vc) * a3 - p.Es * (e - e_c) * b;
  r.dres_dec = (r.dtau_dec + p.mu / h) * a3 + (tc + p.mu * vc) * 6.0 * a2 + p.Es * b;
  r.dres_de = -p.Es * (b + 2.0 * (e - e_c));
  r.stress = p.Es * (e - e_c) / a2;
  r.dstress_dec = -p.Es / a2 - 4.0 * p.Es * (e - e_c) / a3;
  r.dstress_de = p.Es / a2;
  return r;
}

bool condense_step(const ActiveParameters& p, const ActiveState& previous, double e,
                   const StepActivation& act, double h, CondensedStep& out, int max_iterations,
                   double tolerance) {
  // Scalar Newton on R_e(e_c) with k_c, tau_c eliminated (reduced_step).
  double ec = previous.e_c;
  out.iterations = 0;
  for (int it = 0; it < max_iterations; ++it) {
    const ReducedStep r = reduced_step(p, previous, ec, e, act, h);
    if (!std::isfinite(r.residual) || !(r.dres_dec != 0.0)) return false;
    const double dec = -r.residual / r.dres_dec;
    ec += dec;
    out.iterations = it + 1;
    if (std::abs(dec) <= tolerance * (1.0 + std::abs(ec))) {
      const ReducedStep f = reduced_step(p, previous, ec, e, act, h);
      out.state = f.state;
      out.stress = f.stress;
      // d sigma/de along the solution: d e_c/d e = -(dR_e/de)/(dR_e/de_c).
      out.tangent = f.dstress_de - f.dstress_dec * f.dres_de / f.dres_dec;
      return true;
    }
  }
  out.state = reduced_step(p, previous, ec, e, act, h).state;
  return false;
}

}  // namespace sigmaheart::model::bcs
