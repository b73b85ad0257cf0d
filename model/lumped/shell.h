// What the lumped sphere (sphere.h) and the regional ventricle (regional.h) share: the thin
// spherical shell's global parameters, passive law, cavity volume and initial equilibrium, the
// beat-local time grid, the Newton scaling, step cutting, the periodic-run loop, and the channel
// and state names common to both (docs/models.md s.2-3). One place, so that the one-patch regional
// model keeps stepping exactly like the sphere.
#pragma once

#include "model/bcs/active_law.h"
#include "model/circulation/circulation.h"
#include "model/lumped/sphere.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::model::lumped::shell {

// Scales that make the Newton rows dimensionless (the tolerance is on these scaled rows).
inline constexpr double kPref = 1e3;   // [Pa]
inline constexpr double kVref = 1e-6;  // [m^3] (1 mL)
inline constexpr int kMaxCuts = 8;     // step halvings before giving up (dt / 256)

// Common state entries 0..4: y, dy_dt, P_v, P_ar, P_d.
enum StateEntry : int { kY, kV, kPv, kPar, kPd };

// The global (whole-shell) parameters, in this order; the sphere adds sigma0, the regional model
// K_patch and per-patch parameters. Names as in LumpedSphere::default_parameters().
enum Global : int {
  kRho, kR0, kD0, kC1, kC2, kEta, kEs, kMu, kAlpha, kK0, kKATP, kKRS, kAPD, kPeriod,
  kKat, kKar, kKp, kRp, kRd, kCp, kCd, kPsv, kPat0, kPatKick, kCcav, kN0Slope, kN0Emax,
  kCexp, kBexp, kNumGlobal
};
const std::vector<std::string>& global_names();
// Positions of global_names() in a parameter space (throws std::invalid_argument if one is missing).
// With an atrial chamber the prescribed atrium's P_at0 and P_at_kick are not parameters (-1).
std::vector<int> global_indices(const ParameterSpace& space, bool atrial_chamber = false);

// The atrial chamber's parameters (circulation::AtrialChamber), in this order.
const std::vector<std::string>& atrium_names();
std::vector<int> atrium_indices(const ParameterSpace& space);  // throws if one is missing

// The shell's global parameters unpacked from theta. act.sigma0 is left at 0 (per model).
// chamber: the atrium is circulation::AtrialChamber, its volume the state entry atrium_entry;
// otherwise the prescribed pressure `atrial`.
struct Shell {
  double rho, R0, d0, c1, c2, c_exp, b_exp, eta, period;
  bcs::ActiveParameters act;
  circulation::CirculationParameters circ;
  circulation::AtrialPressure atrial;
  bool chamber = false;
  circulation::AtrialChamber atrium;
  int atrium_entry = -1;
};
// `atrium`: atrium_indices() for a chamber whose volume is state entry atrium_entry, else null.
Shell unpack(const Eigen::Ref<const Eigen::VectorXd>& theta, const std::vector<int>& global,
             const std::vector<int>* atrium = nullptr, int atrium_entry = -1);

// The atrial pressure of state x at time t (prescribed, or the chamber's from its volume).
template <class X>
double atrial_pressure(const Shell& m, const X& x, double t) {
  return m.chamber ? m.atrium.pressure(t, x(m.atrium_entry)) : m.atrial(t);
}

// Passive stress Sigma = 2 dW/dC and dSigma/dC (docs/models.md s.2): Mooney-Rivlin
// W = c1 (J1 - 3) + c2 (J2 - 3) plus the exponential stiffening named as the alternative in
// docs/models.md s.2, W_exp = c_exp (exp(b_exp (J1 - 3)^2) - 1), J1 = 2C + C^-2. Alone, Mooney-Rivlin
// gives an end-diastolic pressure-volume curve that flattens at large volumes (P ~ linear in R),
// which makes the filling volume ill-determined; the exponential term gives the steep one.
inline void passive_stress(const Shell& m, double C, double& S, double& dS_dC) {
  const double iC = 1.0 / C, iC3 = iC * iC * iC;
  const double g = 1.0 - iC3;  // dJ1/dC = 2 g
  S = 4.0 * g * (m.c1 + C * m.c2);
  dS_dC = 4.0 * (3.0 * iC3 * iC * (m.c1 + C * m.c2) + g * m.c2);
  if (m.c_exp > 0.0) {
    const double I = 2.0 * C + iC * iC - 3.0;
    const double E = std::exp(m.b_exp * I * I);
    const double k = 8.0 * m.b_exp * m.c_exp;
    S += k * I * g * E;
    dS_dC += k * E * (2.0 * g * g + 3.0 * I * iC3 * iC + 4.0 * m.b_exp * I * I * g * g);
  }
}

inline double cavity_volume(const Shell& m, double y) {
  const double R = m.R0 + y;
  return 4.0 / 3.0 * std::numbers::pi * R * R * R;
}

// Stopping test of the per-step Newton solves, after the update u += du, on the reduced unknowns
// u = (v [m/s], P_v [Pa], P_ar [Pa], then dimensionless strains and stretches) and the scaled rows
// r: converged when max |r_i| <= tol, or when the step is negligible relative to the unknowns,
// max_i |du_i| / max(|u_i|, typ_i) <= tol (the relative step test of Dennis & Schnabel 1996,
// Numerical Methods for Unconstrained Optimization and Nonlinear Equations, s.7.2; KINSOL's
// scsteptol). The step test matters for stiff walls (E_s ~ 6e8 Pa): the balance row then carries
// terms of ~1e6 kPa whose rounding alone keeps |r| above 1e-10 however exact u is, and steps were
// cut for nothing. Quadratic convergence makes the error after a step of relative size tol of
// order tol^2, so runs that met the residual test before change by far less than 1e-9 relative.
// typ_i, the floors for unknowns that pass through 0: kPref for pressures, 1 for strains, and for
// v the velocity that moves the cavity volume by kVref over the step h (the cavity row's scale).
template <class V>
bool newton_converged(const Shell& m, double h, const V& u, const V& du, const V& r, double tol) {
  if (!r.allFinite()) return false;
  if (r.cwiseAbs().maxCoeff() <= tol) return true;
  const double typ_v = kVref / (h * 4.0 * std::numbers::pi * m.R0 * m.R0);
  for (Eigen::Index i = 0; i < u.size(); ++i) {
    const double typ = i == 0 ? typ_v : (i <= 2 ? kPref : 1.0);
    if (!(std::abs(du(i)) <= tol * std::max(std::abs(u(i)), typ))) return false;
  }
  return true;
}

// The per-step Newton solve of both models on the reduced unknowns u, from u with r = r(u) and
// J = dr/du already evaluated. eval(u, r, J, full) evaluates at u (full: the complete state) and
// returns false where the state is not physical (a collapsed shell or patch). Each Newton step is
// damped by backtracking on |r|_2 (Armijo constant 1e-4, halving; Dennis & Schnabel 1996, alg.
// A6.3.1): the valve law is piecewise linear, and undamped iterates can cycle across its kinks
// when a large valve conductance makes the flow rows steep (a 10 mL cavity against an aortic valve
// conductance of 3e-4 m^3/(Pa s)); if no trial decreases |r|, the one with the smallest |r| is
// taken. Returns the iterations, or -1 (not finite, not physical, or newton_max_iterations spent).
template <class V, class M, class Full, class Eval>
int damped_newton(const Shell& m, double h, V& u, V& r, M& J, Full& full, Eval&& eval,
                  const SphereOptions& o) {
  constexpr int kMaxHalvings = 10;
  using std::swap;
  // Trial and best buffers, allocated once per solve; an improving trial is swapped in, not copied
  // (the regional model's J is dense, 56 x 56 with 17 patches).
  V ut = u, rt = r, best_u = u, best_r = r;
  M Jt = J, best_J = J;
  Full ft = full, best_full = full;
  for (int it = 1; it <= o.newton_max_iterations; ++it) {
    if (!r.allFinite()) return -1;
    const V du = J.partialPivLu().solve(-r);
    if (!du.allFinite()) return -1;
    const double f0 = r.squaredNorm();
    double best_f = std::numeric_limits<double>::infinity(), best_lambda = 1.0;
    double lambda = 1.0;
    for (int k = 0; k <= kMaxHalvings; ++k, lambda *= 0.5) {
      ut = u + lambda * du;
      if (!eval(ut, rt, Jt, ft) || !rt.allFinite()) continue;
      const double f = rt.squaredNorm();
      if (f < best_f) {
        best_f = f;
        best_lambda = lambda;
        swap(best_u, ut);
        swap(best_r, rt);
        swap(best_J, Jt);
        swap(best_full, ft);
      }
      if (f <= (1.0 - 2e-4 * lambda) * f0) break;
    }
    if (!(best_f < std::numeric_limits<double>::infinity())) return -1;  // no physical trial
    swap(u, best_u);
    swap(r, best_r);
    swap(J, best_J);
    swap(full, best_full);
    if (newton_converged(m, h, u, V(best_lambda * du), r, o.newton_tolerance)) return it;
  }
  return -1;
}

// Static passive balance (d0/R0) s Sigma_pas(s^2) = P s^2 for y (bisection: robust, one call/run).
double static_radius_offset(const Shell& m, double P);

// The next point of the beat-local grid after t, capped at t_end: t = b T + j dt plus the beat
// ends b T, so that run() and advance() step on the same points and every beat ends exactly at a
// multiple of the period.
double next_time(double t, double t_end, double dt, double period);

// Rows 1 and 2 of both models' reduced Newton systems, scaled by h/kVref: the cavity volume balance
// and the proximal Windkessel (the distal one is solved exactly for P_d, which is returned), with
// their derivatives in u = (v, P_v, P_ar, ...) in columns 0..2 of J (dy/dv = h). `c` is the step
// context: xo (the state at t^n), h, P_at, V_old, Pd_den = C_d/h + 1/R_p + 1/R_d and
// Pd_rhs = C_d/h P_d^n + P_sv/R_d.
// With an atrial chamber (m.chamber), `atrium` is given: its V_old and its elastance E at t^{n+1}
// in, and the atrial step out (circulation::atrial_step, exact); P_at then depends on (P_v, P_ar),
// and so does the mitral flow of the cavity row (chain rule). Without a chamber, P_at = c.P_at.
struct AtriumRows {
  double V_old = 0.0, E = 0.0;   // in
  circulation::AtrialStep step;  // out
};
template <class Context, class Res, class Jac>
double circulation_rows(const Shell& m, const Context& c, double y, double Pv, double Par, Res& r,
                        Jac& J, AtriumRows* atrium = nullptr) {
  namespace circ = circulation;
  const double h = c.h;
  const double Pd = (c.Pd_rhs + Par / m.circ.R_p) / c.Pd_den;
  const double dPd_dPar = 1.0 / (m.circ.R_p * c.Pd_den);
  double P_at = c.P_at;
  if (atrium != nullptr) {
    atrium->step = circ::atrial_step(m.atrium, atrium->E, Pv, Par, atrium->V_old, h, m.circ);
    P_at = atrium->step.P_at;
  }
  circ::ValveFlow q = circ::valve_flow(Pv, Par, P_at, m.circ);
  if (atrium != nullptr) {
    q.dq_dPv += q.dq_dPat * atrium->step.dPat_dPv;
    q.dq_dPar += q.dq_dPat * atrium->step.dPat_dPar;
  }
  const circ::WindkesselResidual w =
      circ::windkessel_residual(Par, Pd, c.xo(kPar), c.xo(kPd), q.q_ar, h, m.circ);
  const double R = m.R0 + y;
  const double V = 4.0 / 3.0 * std::numbers::pi * R * R * R;
  const double dV_dy = 4.0 * std::numbers::pi * R * R;
  const double fv = h / kVref;
  // Cavity volume balance.
  r(1) = (m.circ.C_cav * (Pv - c.xo(kPv)) / h + q.q + (V - c.V_old) / h) * fv;
  J(1, 0) = dV_dy * fv;  // (dV/dy) (dy/dv) / h = dV/dy
  J(1, 1) = (m.circ.C_cav / h + q.dq_dPv) * fv;
  J(1, 2) = q.dq_dPar * fv;
  // Proximal Windkessel.
  r(2) = w.r_ar * fv;
  J(2, 0) = 0.0;
  J(2, 1) = -q.dqar_dPv * fv;
  J(2, 2) = (w.dar_dPar + w.dar_dPd * dPd_dPar - q.dqar_dPar) * fv;
  return Pd;
}

std::vector<Channel> state_head();        // the StateEntry entries, with units
Channel last_open_valve_entry();          // the diagnostic flag that ends every state
// The active (contractile-element) state entries e_c, k_c, tau_c with `suffix` appended to each
// name: "" for the sphere, "_07" for patch 7 of the regional model.
std::vector<Channel> active_state_entries(const std::string& suffix);
std::vector<Channel> circulation_channels();  // V_lv, P_lv, P_ar, P_at, q_ar, q_at, phase, P_d

// The values of circulation_channels() for a state (its last entry is last_open_valve).
Eigen::Matrix<double, 8, 1> circulation_sample(const Shell& m, const State& state);

// The result of a run() whose theta failed the checks.
RunResult failed_run(std::vector<Channel> channels, Status status);

// Fills entries y, P_v, P_ar, P_d of a relaxed initial state (static passive equilibrium with the
// atrial pressure at t = 0, arteries at a typical diastolic pressure; the periodic loop settles
// within a few beats) and returns the fibre strain of that radius, for the contractile elements.
// An atrial chamber starts at the pulmonary-venous pressure (no inflow).
double fill_relaxed_state(const Shell& m, Eigen::Ref<Eigen::VectorXd> x);

// Validity checks of theta shared by both models (size, bounds, APD < period, dt <= period).
Status check_theta(const ParameterSpace& space, const SphereOptions& numerics,
                   const Eigen::Ref<const Eigen::VectorXd>& theta, double APD, double period);

// Backward-Euler steps on the beat-local grid from state.time to t_end, each tried whole, then in
// halves, quarters, ... (kMaxCuts). `step(xo, ta, tb, xn)` does one step on the unknowns (the state
// without its last entry, last_open_valve) and returns Newton iterations or -1. On failure the
// state is left at the last good point.
template <class Vec, class StepFn>
Status step_with_cuts(State& state, const Shell& m, double dt, double t_end, StepFn&& step,
                      int* newton_iterations, int* step_cuts) {
  const Eigen::Index nu = state.x.size() - 1;
  Vec x = state.x.head(nu);
  double last_open = state.x(nu);
  double t = state.time;
  while (t < t_end) {
    const double t1 = next_time(t, t_end, dt, m.period);
    if (!(t1 > t)) {  // dt below the resolution of t: never loop without advancing
      state.x.head(nu) = x;
      state.x(nu) = last_open;
      state.time = t;
      std::ostringstream s;
      s << "time step " << dt << " s is below the resolution of t = " << t << " s";
      return Status::Error(StatusCode::kInvalidArgument, s.str());
    }
    Vec xn = x;
    bool done = false;
    for (int cut = 0; cut <= kMaxCuts && !done; ++cut) {
      const int n = 1 << cut;
      Vec xs = x;
      bool ok = true;
      for (int k = 0; k < n && ok; ++k) {
        const double ta = t + (t1 - t) * k / n;
        const double tb = (k + 1 == n) ? t1 : t + (t1 - t) * (k + 1) / n;
        Vec xk = xs;
        const int its = step(xs, ta, tb, xk);
        if (its < 0) {
          ok = false;
        } else {
          xs = xk;
          if (newton_iterations) *newton_iterations += its;
        }
      }
      if (ok) {
        xn = xs;
        done = true;
        if (cut > 0 && step_cuts) *step_cuts += cut;
      }
    }
    if (!done || !xn.allFinite()) {
      state.x.head(nu) = x;
      state.x(nu) = last_open;
      state.time = t;
      std::ostringstream s;
      s << "Newton did not converge at t = " << t1 << " s after " << kMaxCuts
        << " step halvings (V = " << cavity_volume(m, x(kY)) * 1e6 << " mL, P_v = " << x(kPv)
        << " Pa)";
      return Status::Error(xn.allFinite() ? StatusCode::kDiverged : StatusCode::kNonFinite,
                           s.str());
    }
    const auto regime =
        circulation::valve_flow(xn(kPv), xn(kPar), atrial_pressure(m, xn, t1), m.circ).regime;
    if (regime != circulation::ValveRegime::kClosed) last_open = static_cast<double>(regime);
    x = xn;
    t = t1;
  }
  state.x.head(nu) = x;
  state.x(nu) = last_open;
  state.time = t_end;
  return Status::Ok();
}

// The checks of advance() on the state and t_end (size, finiteness, order).
Status check_advance(const State& state, Eigen::Index state_size, double t_end);

// run() of both models: beats from `initial` until the beat-to-beat change of V, P_v, P_ar, P_d at
// the beat start is below numerics.periodic_tolerance (after min_beats), returning the last beat
// on t in [0, period]. step_to(state, t1, &newton_iterations, &step_cuts) advances; sample(state)
// gives the channel row.
// warm_from / warm_out: Simulator::run_warm's `from` and `produce` (null: a cold run, none
// produced); a warm start holds ShootingWarmStart::packed_size(n) entries, n the unknowns.
RunResult run_periodic(const Shell& m, const SphereOptions& numerics, std::vector<Channel> channels,
                       State initial,
                       const std::function<Status(State&, double, int*, int*)>& step_to,
                       const std::function<Eigen::VectorXd(const State&)>& sample,
                       const Eigen::VectorXd* warm_from = nullptr,
                       Eigen::VectorXd* warm_out = nullptr);

}  // namespace sigmaheart::model::lumped::shell
