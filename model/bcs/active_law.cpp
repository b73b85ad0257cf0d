#include "model/bcs/active_law.h"

#include <Eigen/LU>

#include <algorithm>
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
  return {};
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

double activation(double t, double T_d, double period, const ActiveParameters& p) {
  const double local = t - T_d - std::floor((t - T_d) / period) * period;  // in [0, period)
  return local < p.APD ? p.k_ATP : -p.k_RS;
}

StepActivation step_activation(double t0, double t1, double T_d, double period,
                               const ActiveParameters& p) {
  const double f = active_fraction(t0, t1, T_d, p.APD, period);
  return {f * p.k_ATP + (1.0 - f) * p.k_RS, f * p.k_ATP};
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
