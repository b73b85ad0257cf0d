// The lumped BCS sphere (Caruel et al. 2014, section 2.2, "0D model"; docs/models.md section 2).
//
// Unknowns per step, all at t^{n+1}: x = (y, v = dy/dt, P_v, P_ar, P_d, e_c, k_c, tau_c).
// Backward Euler on every equation (first order, L-stable: the e_c relaxation has a time
// constant mu/Es ~ 20 us and the cavity one C_cav/K ~ 1e-5 s, far below dt):
//   r0 = (y - y^n)/h - v
//   r1 = rho d0 (v - v^n)/h + (d0/R0)(1 + y/R0) Sigma - P_v (1 + y/R0)^2        (balance)
//   r2 = C_cav (P_v - P_v^n)/h + q(P_v, P_ar, P_at) + (V(y) - V^n)/h             (cavity)
//   r3, r4 = two-stage Windkessel (model/circulation)
//   r5..r7 = BCS active law (model/bcs), fibre strain e = (C - 1)/2, C = (1 + y/R0)^2
// r0, r4, r6, r7 are eliminated exactly and Newton runs on the remaining 4x4 system (analytic
// Jacobian; see newton_step). The activation enters as its exact average over the step.
// Sigma = Sigma_pas(C) + eta dC/dt (1 + 2 C^-6) + Es (e - e_c)/(1 + 2 e_c)^2, Sigma_pas = 2 dW/dC
// with W = c1 (J1 - 3) + c2 (J2 - 3) + c_exp (exp(b_exp (J1 - 3)^2) - 1) (see passive_stress).
// Diagnostic "phase": 0 filling, 1 isovolumic contraction, 2 ejection, 3 isovolumic relaxation
// (circulation::Phase); the closed-valve phases are told apart by state entry last_open_valve.
// The time grid restarts at each beat: t = b T + j dt, plus the beat ends b T, so that run() and
// advance() step on the same points and every beat ends exactly at a multiple of the period.
#include "model/lumped/sphere.h"

#include "model/lumped/shell.h"
#include "model/periodic_shooting.h"

#include "model/bcs/active_law.h"
#include "model/circulation/circulation.h"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::lumped {
namespace {

namespace circ = sigmaheart::model::circulation;

// Parameter order of default_parameters() (the shell's globals with sigma0 after k0).
enum P : int {
  kRho, kR0, kD0, kC1, kC2, kEta, kEs, kMu, kAlpha, kK0, kSigma0, kKATP, kKRS, kAPD, kPeriod,
  kKat, kKar, kKp, kRp, kRd, kCp, kCd, kPsv, kPat0, kPatKick, kCcav, kN0Slope, kN0Emax,
  kCexp, kBexp, kNumParams
};

// State layout (state_layout() documents it with units): the shell's five entries, then the
// active state, then the diagnostic flag.
using shell::kY, shell::kV, shell::kPv, shell::kPar, shell::kPd;
// With an atrial chamber (lumped-sphere-atrium) the atrial volume V_at follows as entry kVat;
// last_open_valve, a diagnostic flag and not an unknown, always ends the state.
enum X : int { kEc = 5, kKc, kTc, kVat };
constexpr int kUnknowns = 8;  // kY..kTc, without an atrial chamber
// The unknowns: N = kUnknowns, or kUnknowns + 1 with the atrial chamber. Fixed-size either way
// (the step code is instantiated for both; a dynamic size cost the prescribed sphere 10 % of its
// beat time).
template <int N>
using Vec = Eigen::Matrix<double, N, 1>;
using shell::kPref, shell::kVref;
using shell::cavity_volume, shell::passive_stress;

// The shell with its one contractility; index = shell::global_indices() then sigma0.
using Model = shell::Shell;
Model unpack(const Eigen::Ref<const Eigen::VectorXd>& theta, const std::vector<int>& idx,
             const std::vector<int>& atrium, const bcs::ActivationInput& input) {
  Model m = shell::unpack(theta, idx, atrium.empty() ? nullptr : &atrium, kVat);
  m.act.sigma0 = theta(idx.back());
  m.act.input = input;  // the shape of u(t): a numerics choice (SphereOptions::activation_input)
  return m;
}

// Name of parameter slot i (P): the shell's global names with sigma0 inserted at kSigma0.
std::string name_of(int i) {
  if (i == kSigma0) return "sigma0";
  return shell::global_names()[static_cast<size_t>(i < kSigma0 ? i : i - 1)];
}

// Tag (Parameter::family) of parameter slot i: its physical role, from the vocabulary of
// model/registry.h.
const char* family_of(int i) {
  switch (static_cast<P>(i)) {
    case kRho: return "wall_density";
    case kR0: case kD0: return "geometry";
    case kC1: case kC2: case kCexp: case kBexp: return "passive_stiffness";
    case kEta: return "passive_viscosity";
    case kEs: case kK0: return "active_stiffness";
    case kMu: return "active_viscosity";
    case kAlpha: case kN0Slope: case kN0Emax: return "crossbridge_kinetics";
    case kSigma0: return "contractility";
    case kKATP: return "activation_rate";
    case kKRS: return "relaxation_rate";
    case kAPD: return "activation_duration";
    case kPeriod: return "period";
    case kKat: case kKar: case kKp: return "valve_conductance";
    case kRp: case kRd: return "afterload_resistance";
    case kCp: case kCd: return "afterload_compliance";
    case kPsv: return "venous_pressure";
    case kPat0: case kPatKick: return "preload_pressure";
    case kCcav: return "cavity_compliance";
    case kNumParams: break;
  }
  return "";
}

// One backward-Euler step from xo over [t0, t0 + h]. Three of the eight equations are linear in
// one unknown each and are eliminated exactly before Newton: y = y^n + h v (r0), P_d from r4
// given P_ar, and (k_c, tau_c) from r6, r7 given e_c (bcs::reduced_step). Newton then runs on
// u = (v, P_v, P_ar, e_c) with an analytic 4x4 Jacobian; the result is the same backward-Euler
// solution as the full 8x8 system.
using Vec4 = Eigen::Matrix<double, 4, 1>;
using Mat4 = Eigen::Matrix<double, 4, 4>;

template <int N>
struct StepContext {
  const Model& m;
  const Vec<N>& xo;
  double h;
  double E_at;  // the atrial chamber's elastance at t^{n+1} (0 without a chamber)
  double P_at;  // the prescribed atrial pressure at t^{n+1} (0 with a chamber)
  bcs::StepActivation act;
  double V_old;
  double Pd_den;  // C_d/h + 1/R_p + 1/R_d
  double Pd_rhs;  // C_d/h P_d^n + P_sv/R_d  (P_d = (Pd_rhs + P_ar/R_p) / Pd_den)
};

// Scaled residuals r = (balance [1/kPref], cavity, proximal Windkessel [h/kVref], R_e [1/kPref])
// and their Jacobian in u. When `full` is given, it receives the complete state (8 entries, 9
// with the atrial chamber's volume, solved exactly with P_at by shell::circulation_rows).
template <int N>
void reduced_residual(const StepContext<N>& c, const Vec4& u, Vec4& r, Mat4& J, Vec<N>* full) {
  const Model& m = c.m;
  const double h = c.h;
  const double v = u(0), Pv = u(1), Par = u(2), ec = u(3);
  const double y = c.xo(kY) + h * v;
  const double s = 1.0 + y / m.R0;
  const double C = s * s;
  const double e = 0.5 * (C - 1.0);
  const double dC_dy = 2.0 * s / m.R0, de_dy = s / m.R0;

  double Sp = 0.0, dSp_dC = 0.0;
  passive_stress(m, C, Sp, dSp_dC);
  const double iC = 1.0 / C, iC2 = iC * iC, iC6 = iC2 * iC2 * iC2;
  const double g = 1.0 + 2.0 * iC6, dg_dC = -12.0 * iC6 * iC;
  const double Cdot = 2.0 * s * v / m.R0;
  const double Sv = m.eta * Cdot * g;
  const double dSv_dy = m.eta * (2.0 * v / (m.R0 * m.R0) * g + Cdot * dg_dC * dC_dy);
  const double dSv_dv = m.eta * g * 2.0 * s / m.R0;

  const bcs::ActiveState old{c.xo(kEc), c.xo(kKc), c.xo(kTc)};
  const bcs::ReducedStep a = bcs::reduced_step(m.act, old, ec, e, c.act, h);

  const double Sigma = Sp + Sv + a.stress;
  const double dSigma_dy = dSp_dC * dC_dy + dSv_dy + a.dstress_de * de_dy;

  // Balance of the shell.
  const double k1 = m.d0 / m.R0;
  r(0) = (m.rho * m.d0 * (v - c.xo(kV)) / h + k1 * s * Sigma - Pv * C) / kPref;
  const double dr0_dy = k1 * (Sigma / m.R0 + s * dSigma_dy) - Pv * dC_dy;
  J(0, 0) = (dr0_dy * h + m.rho * m.d0 / h + k1 * s * dSv_dv) / kPref;
  J(0, 1) = -C / kPref;
  J(0, 2) = 0.0;
  J(0, 3) = k1 * s * a.dstress_dec / kPref;
  // Cavity volume balance and proximal Windkessel.
  constexpr bool kChamber = N > kUnknowns;
  shell::AtriumRows atrium{kChamber ? c.xo(N - 1) : 0.0, c.E_at, {}};
  const double Pd = shell::circulation_rows(m, c, y, Pv, Par, r, J, kChamber ? &atrium : nullptr);
  J(1, 3) = 0.0;
  J(2, 3) = 0.0;
  // Contractile-element balance (k_c, tau_c already eliminated).
  r(3) = a.residual / kPref;
  J(3, 0) = a.dres_de * de_dy * h / kPref;
  J(3, 1) = 0.0;
  J(3, 2) = 0.0;
  J(3, 3) = a.dres_dec / kPref;

  if (full != nullptr) {
    full->template head<kUnknowns>() << y, v, Pv, Par, Pd, ec, a.state.k_c, a.state.tau_c;
    if constexpr (kChamber) (*full)(kVat) = atrium.step.V_at;
  }
}

// One backward-Euler step of size h = t1 - t0; xo, xn hold the unknowns. Returns iterations or -1.
template <int N>
int newton_step(const Model& m, const Vec<N>& xo, double t0, double t1, const SphereOptions& o,
                Vec<N>& xn) {
  const double h = t1 - t0;
  const double Pd_den = m.circ.C_d / h + 1.0 / m.circ.R_p + 1.0 / m.circ.R_d;
  const double Pd_rhs = m.circ.C_d / h * xo(kPd) + m.circ.P_sv / m.circ.R_d;
  const bcs::StepActivation act = bcs::step_activation(t0, t1, 0.0, m.period, m.act);
  StepContext<N> c{m, xo, h, m.chamber ? m.atrium.elastance(t1) : 0.0,
                m.chamber ? 0.0 : m.atrial(t1), act, cavity_volume(m, xo(kY)), Pd_den, Pd_rhs};
  // Predictor: the contractile element follows the fibre strain extrapolated with y' (it tracks
  // e closely except under load); everything else starts from the old values.
  const double s_old = 1.0 + xo(kY) / m.R0, s_pred = s_old + h * xo(kV) / m.R0;
  Vec4 u(xo(kV), xo(kPv), xo(kPar), xo(kEc) + 0.5 * (s_pred * s_pred - s_old * s_old));
  Vec4 r;
  Mat4 J;
  reduced_residual(c, u, r, J, &xn);
  auto eval = [&](const Vec4& ut, Vec4& rt, Mat4& Jt, Vec<N>& full) {
    if (1.0 + (xo(kY) + h * ut(0)) / m.R0 <= 0.05) return false;  // collapsed shell: not physical
    reduced_residual(c, ut, rt, Jt, &full);
    return true;
  };
  return shell::damped_newton(m, h, u, r, J, xn, eval, o);
}

// Backward-Euler steps of the N unknowns up to t_end (shell::step_with_cuts).
template <int N>
Status steps_to(const Model& m, const SphereOptions& o, State& state, double t_end,
                int* newton_iterations, int* step_cuts) {
  auto step = [&](const Vec<N>& xo, double ta, double tb, Vec<N>& xn) {
    return newton_step<N>(m, xo, ta, tb, o, xn);
  };
  return shell::step_with_cuts<Vec<N>>(state, m, o.dt, t_end, step, newton_iterations, step_cuts);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
std::string SphereOptions::validate() const {
  std::ostringstream s;
  // Messages start with the field name (app/ points at that key of the config).
  if (!(dt > 0.0 && dt <= 0.05)) s << "dt = " << dt << " s must lie in (0, 0.05]";
  else if (dt < kMinDt)
    s << "dt = " << dt << " s must be >= " << kMinDt << " s (one beat of 3 s would keep "
      << static_cast<long long>(3.0 / dt) << " samples)";
  else if (min_beats < 1) s << "min_beats = " << min_beats << " must be >= 1";
  else if (min_beats > kMaxBeats) s << "min_beats = " << min_beats << " must be <= " << kMaxBeats;
  else if (max_beats < min_beats) s << "max_beats = " << max_beats << " must be >= min_beats";
  else if (max_beats > kMaxBeats)
    s << "max_beats = " << max_beats << " must lie in [min_beats, " << kMaxBeats
      << "] (a beat that has not settled after " << kMaxBeats << " beats never will)";
  else if (!(periodic_tolerance >= kMinPeriodicTolerance && periodic_tolerance < 1.0))
    s << "periodic_tolerance = " << periodic_tolerance << " must lie in [" << kMinPeriodicTolerance
      << ", 1): the beat-to-beat change of states solved to newton_tolerance and rounded to "
         "double stalls at ~1e-14 to 1e-12, so a smaller tolerance is never met";
  else if (output_every < 1) s << "output_every = " << output_every << " must be >= 1";
  else if (!(newton_tolerance > 0.0 && newton_tolerance < 1e-2))
    s << "newton_tolerance = " << newton_tolerance << " must lie in (0, 1e-2)";
  else if (newton_max_iterations < 1) s << "newton_max_iterations must be >= 1";
  else if (const std::string m = activation_input.validate(); !m.empty()) s << "activation_shape: " << m;
  return s.str();
}

ParameterSpace LumpedSphere::default_parameters(Atrium atrium) {
  // Sources: [C14] Caruel et al. 2014 (Biomech Model Mechanobiol 13:897) and the CCMLC2014-like
  // working set of docs/models.md s.2; [T] tuned so that the healthy beat meets docs/models.md s.7.
  std::vector<Parameter> p(kNumParams);
  // family: the parameter's role (model/registry.h lists the vocabulary).
  auto set = [&](int i, const char* unit, double nominal, double lo, double hi, const char* doc) {
    p[static_cast<size_t>(i)] = Parameter{name_of(i), unit, nominal, lo, hi, doc, family_of(i), 0};
  };
  set(kRho, "kg/m^3", 1e3, 500.0, 2000.0, "wall density; tissue ~ water [C14]");
  set(kR0, "m", 2.4e-2, 5e-3, 6e-2, "reference (unloaded) sphere radius [C14 working set]");
  set(kD0, "m", 1.45e-2, 2e-3, 4e-2, "reference wall thickness [C14 working set]");
  set(kC1, "Pa", 100.0, 0.0, 1e5, "Mooney-Rivlin c1 [T: with c2, c_exp: EDV 144 mL, EDP 7 mmHg]");
  set(kC2, "Pa", 150.0, 0.0, 1e5, "Mooney-Rivlin c2 [T: with c1, c_exp, end-diastolic PV curve]");
  set(kEta, "Pa s", 70.0, 0.0, 1e4, "passive viscosity [C14 working set]");
  set(kEs, "Pa", 3e6, 1e4, 1e9, "series-element stiffness [C14 working set]");
  set(kMu, "Pa s", 70.0, 0.0, 1e4, "contractile-element viscosity [C14 working set]");
  set(kAlpha, "1", 1.5, 0.0, 100.0, "cross-bridge destruction by sliding [C14 working set]");
  set(kK0, "Pa", 1e5, 0.0, 1e8, "maximal active stiffness [C14 working set]");
  // Upper bound 1 MPa: ten times the peak isometric tension of myocardium, T_ref ~ 100 kPa (Hunter,
  // McCulloch & ter Keurs 1998, Prog Biophys Mol Biol 69:289). Above ~6 MPa, with a large
  // sliding destruction alpha, the backward-Euler step of the contractile element has no solution
  // near e_c' = 0 (the |e_c'| term makes its residual V-shaped) and runs failed.
  set(kSigma0, "Pa", 5.3e4, 0.0, 1e6, "contractility, maximal active stress [T: EF ~60 %]");
  set(kKATP, "1/s", 8.0, 0.1, 1000.0,
      "contraction rate [T: dP/dt max ~1500 mmHg/s; 35 (C14) gives ~15000 in 0D]");
  set(kKRS, "1/s", 20.0, 0.1, 1000.0, "relaxation rate [C14 working set]");
  set(kAPD, "s", 0.3, 0.01, 1.0, "action-potential duration (activation window) [T]");
  set(kPeriod, "s", 0.85, 0.2, 3.0, "heart period (70 bpm) [C14 working set]");
  set(kKat, "m^3/(Pa s)", 6e-7, 1e-10, 1e-3, "mitral valve conductance [C14 working set]");
  set(kKar, "m^3/(Pa s)", 5e-7, 1e-10, 1e-3,
      "aortic valve conductance [T: ~5 mmHg peak gradient; C14 set 1e-7 gives ~25]");
  set(kKp, "m^3/(Pa s)", 5e-11, 0.0, 1e-8, "closed-valve leak conductance [C14 working set]");
  set(kRp, "Pa s/m^3", 1e7, 1e5, 1e10,
      "proximal arterial resistance [T: diastolic P_ar ~65 mmHg; C14 set 5e7]");
  set(kRd, "Pa s/m^3", 1e8, 1e5, 1e11, "distal (peripheral) resistance [C14 working set]");
  set(kCp, "m^3/Pa", 8e-9, 1e-12, 1e-6,
      "proximal arterial compliance [T: pulse pressure ~50 mmHg; C14 set 6e-9]");
  set(kCd, "m^3/Pa", 1e-9, 1e-12, 1e-6, "distal arterial compliance [C14 working set]");
  set(kPsv, "Pa", 1e3, 0.0, 1e4, "venous pressure downstream of R_d [C14 working set]");
  set(kPat0, "Pa", 950.0, 0.0, 5e3, "atrial pressure baseline, 7.1 mmHg [T: EDP in 5-12 mmHg]");
  set(kPatKick, "Pa", 533.3, 0.0, 5e3, "atrial kick amplitude, 4 mmHg (sin^2, last 0.12 s) [T]");
  set(kCcav, "m^3/Pa", 5e-12, 1e-15, 1e-9, "cavity compliance, regularises isovolumic phases");
  set(kN0Slope, "1", 0.0, 0.0, 50.0,
      "length-dependent activation gain dn0/de_c; 0 = classical n0 = 1 (Caruel n0 unverified)");
  set(kN0Emax, "1", 0.0, -0.5, 0.5, "contractile strain where n0 reaches 1 (if n0_slope > 0)");
  set(kCexp, "Pa", 30.0, 0.0, 1e5,
      "exponential passive stiffening (docs/models.md s.2) [T: static EDP 5.5/7.8/13.5 mmHg at "
      "140/160/180 mL]");
  set(kBexp, "1", 1.0, 0.0, 50.0, "exponent b_exp of the passive stiffening (J1 - 3)^2 [T]");
  if (atrium == Atrium::kChamber) {
    // The atrial chamber (circulation::AtrialChamber) replaces P_at0 and P_at_kick.
    // [KS06] Korakianitis & Shi 2006, Med Eng Phys 28:613, Table 1 (left atrium, pulmonary veins).
    p.erase(p.begin() + kPatKick);
    p.erase(p.begin() + kPat0);
    auto add = [&](const char* name, const char* unit, double nominal, double lo, double hi,
                   const char* doc, const char* family) {
      p.push_back(Parameter{name, unit, nominal, lo, hi, doc, family, 0});
    };
    // Bounds: wide (elastances 0.0075-7.5 mmHg/mL, R_pv up to 7.5 mmHg s/mL). The 4096-point
    // census found 2 points whose periodic state the shooting reached only after 450 and 753
    // beats (not within the default 400): a nearly neutral arterial mode next to a valve kink,
    // not the atrium (experiments/lumped-census/NOTES.md; the re-armed full step of the shooting
    // settles them). Narrower atrium boxes moved the Sobol' points and did not remove such
    // failures, so the box stays.
    add("E_at_min", "Pa/m^3", 2.0e7, 1e6, 1e9, "passive atrial elastance, 0.15 mmHg/mL [KS06]",
        "elastance");
    add("E_at_max", "Pa/m^3", 5.33e7, 1e6, 1e9,
        "atrial elastance at the peak of the kick, 0.40 mmHg/mL [KS06: E_pas + E_act]",
        "elastance");
    add("V_at0", "m^3", 4e-6, 0.0, 1e-4, "unstressed atrial volume, 4 mL [KS06]",
        "unloaded_volume");
    add("P_pv", "Pa", 1050.0, 0.0, 5e3,
        "pulmonary-venous pressure, 7.9 mmHg [T: the healthy preset's mean atrial pressure]",
        "preload_pressure");
    add("R_pv", "Pa s/m^3", 8.0e5, 1e4, 1e9,
        "pulmonary-venous resistance, 0.006 mmHg s/mL [KS06]", "preload_resistance");
  }
  set_physiological_ranges(p);
  return ParameterSpace(std::move(p));
}

void set_physiological_ranges(std::vector<Parameter>& p) {
  // Physiological ranges (docs/models.md s.8.1 lists them with the full references). Sources:
  // [Hud05] Hudsmith et al. 2005 CMR volumes; [Lan15] Lang et al. 2015 chamber quantification;
  // [VB04] Vinnakota & Bassingthwaighte 2004 myocardial density; [HMK98] Hunter, McCulloch & ter
  // Keurs 1998 tension; [Pau07] Paulus et al. 2007 (tau, filling pressure); [Rau09] Rautaharju et
  // al. 2009 (QT); [Wes09] Westerhof, Lankhaar & Westerhof 2009 (Windkessel); [s.7] derived from
  // the index ranges of docs/models.md s.7; [D4] a model-internal parameter with no measured
  // value: the default (or [KS06]'s) x/÷ 4, the 95 % band of a 70 % log prior around it.
  const auto range = [&](const std::string& name, double lo, double hi, const char* source) {
    for (Parameter& q : p) {
      if (q.name == name) {
        q.range_lower = lo;
        q.range_upper = hi;
        q.range_source = source;
      }
    }
  };
  const auto d4 = [&](const std::string& name) {
    for (const Parameter& q : p) {
      if (q.name == name) range(name, q.nominal / 4, q.nominal * 4, "[D4]");
    }
  };
  range("rho", 1000.0, 1100.0, "[VB04] myocardium 1053 kg/m^3");
  range("R0", 0.020, 0.031, "[Hud05] EDV 83-300 mL as EDV ~ R0^3 from the defaults (144 mL at 24 mm)");
  range("d0", 0.006, 0.020, "[Lan15] LV wall 6-11 mm at end-diastole; unloaded and hypertrophied thicker");
  range("sigma0", 1.5e4, 2.0e5, "[HMK98] peak isometric tension of myocardium ~100 kPa");
  range("k_RS", 10.0, 60.0, "[Pau07] relaxation time constant tau 17-100 ms (> 48 ms: impaired)");
  range("APD", 0.20, 0.45, "[Rau09] QT interval 350-460 ms (APD + activation spread)");
  range("period", 0.5, 1.5, "[s.7] resting heart rates 40-120 bpm");
  range("R_d", 6.0e7, 3.0e8, "[s.7] mean aortic pressure 70-110 mmHg / cardiac output 3-8 L/min");
  range("R_p", 3.0e6, 3.0e7, "[Wes09] characteristic impedance 5-10 % of peripheral resistance");
  range("C_p", 3.75e-9, 2.25e-8, "[Wes09] total arterial compliance 0.5-3 mL/mmHg");
  range("P_at0", 267.0, 4000.0, "[Pau07] atrial pressure 2-30 mmHg (> 16 mmHg: raised filling pressure)");
  range("P_pv", 267.0, 4000.0, "[Pau07] pulmonary-venous pressure 2-30 mmHg (> 16 mmHg: raised)");
  for (const char* name : {"c1", "c2", "eta", "Es", "mu", "alpha", "k0", "k_ATP", "K_at", "K_ar", "K_p",
                           "C_d", "P_sv", "P_at_kick", "C_cav", "c_exp", "b_exp", "E_at_min",
                           "E_at_max", "V_at0", "R_pv", "K_patch"}) {
    d4(name);
  }
}

LumpedSphere::LumpedSphere(SphereOptions options)
    : LumpedSphere(options, default_parameters()) {}

LumpedSphere::LumpedSphere(SphereOptions options, ParameterSpace parameters, Atrium atrium)
    : options_(options), parameters_(std::move(parameters)), atrium_(atrium) {
  index_ = shell::global_indices(parameters_, atrium == Atrium::kChamber);
  index_.push_back(parameters_.index_or_throw("sigma0"));
  if (atrium == Atrium::kChamber) atrium_index_ = shell::atrium_indices(parameters_);
}

int LumpedSphere::unknowns() const { return kUnknowns + (atrium_ == Atrium::kChamber ? 1 : 0); }

std::vector<Channel> LumpedSphere::channels() const {
  std::vector<Channel> c = shell::circulation_channels();
  c.push_back({"e_fibre", "1", "fibre Green-Lagrange strain e = (C - 1)/2"});
  const std::vector<Channel> active = shell::active_state_entries("");
  c.insert(c.end(), active.begin(), active.end());
  c.insert(c.end(), {
      {"sigma_act", "Pa", "active fibre stress Es (e - e_c)/(1 + 2 e_c)^2"},
      {"viscous_power", "W/m^3",
       "passive viscous dissipation per unit reference wall volume, Sigma_vis (dC/dt)/2 >= 0"},
  });
  return c;
}

std::vector<Channel> LumpedSphere::state_layout() const {
  std::vector<Channel> s = shell::state_head();
  const std::vector<Channel> active = shell::active_state_entries("");
  s.insert(s.end(), active.begin(), active.end());
  if (atrium_ == Atrium::kChamber) s.push_back({"V_at", "m^3", "atrial volume (atrial chamber)"});
  s.push_back(shell::last_open_valve_entry());
  return s;
}

std::unique_ptr<Simulator> LumpedSphere::clone() const {
  return std::make_unique<LumpedSphere>(*this);
}

Status LumpedSphere::check_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (theta.size() != parameters_.size()) return shell::check_theta(parameters_, options_, theta, 0, 1);
  const Model m = unpack(theta, index_, atrium_index_, options_.activation_input);
  return shell::check_theta(parameters_, options_, theta, m.act.APD, m.period);
}

State LumpedSphere::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  State s;
  s.time = 0.0;
  s.x = Eigen::VectorXd::Zero(unknowns() + 1);
  if (theta.size() != parameters_.size() || !theta.allFinite()) {
    s.x.setConstant(std::numeric_limits<double>::quiet_NaN());
    return s;
  }
  // Relaxed (shell::fill_relaxed_state), the contractile element at rest (e_c = e, no active
  // stress).
  s.x(kEc) = shell::fill_relaxed_state(unpack(theta, index_, atrium_index_, options_.activation_input), s.x);
  s.x(unknowns()) = static_cast<double>(circ::ValveRegime::kFilling);
  return s;
}

Status LumpedSphere::step_to(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                             double t_end, int* newton_iterations, int* step_cuts) const {
  const Model m = unpack(theta, index_, atrium_index_, options_.activation_input);
  return m.chamber ? steps_to<kUnknowns + 1>(m, options_, state, t_end, newton_iterations, step_cuts)
                   : steps_to<kUnknowns>(m, options_, state, t_end, newton_iterations, step_cuts);
}

Status LumpedSphere::advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                             double t_end) {
  if (Status st = check_theta(theta); !st.ok()) return st;
  if (Status st = shell::check_advance(state, unknowns() + 1, t_end); !st.ok()) return st;
  return step_to(state, theta, t_end, nullptr, nullptr);
}

Eigen::VectorXd LumpedSphere::sample(const State& state,
                                     const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  const Model m = unpack(theta, index_, atrium_index_, options_.activation_input);
  const auto& x = state.x;
  const double s = 1.0 + x(kY) / m.R0;
  const double C = s * s;
  const double e = 0.5 * (C - 1.0);
  const double Cdot = 2.0 * s * x(kV) / m.R0;
  const double iC2 = 1.0 / (C * C);
  const double Svis = m.eta * Cdot * (1.0 + 2.0 * iC2 * iC2 * iC2);
  Eigen::VectorXd out(14);
  out << shell::circulation_sample(m, state), e, x(kEc), x(kKc), x(kTc),
      bcs::active_stress(e, x(kEc), m.act.Es), 0.5 * Svis * Cdot;
  return out;
}

RunResult LumpedSphere::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  return run_warm(theta, Eigen::VectorXd(), nullptr);
}

int LumpedSphere::warm_start_size() const { return ShootingWarmStart::packed_size(unknowns()); }

RunResult LumpedSphere::run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                 const Eigen::VectorXd& from, Eigen::VectorXd* produce) {
  if (Status st = check_theta(theta); !st.ok()) {
    if (produce) *produce = Eigen::VectorXd::Zero(warm_start_size());
    return shell::failed_run(channels(), st);
  }
  return shell::run_periodic(
      unpack(theta, index_, atrium_index_, options_.activation_input), options_, channels(), initial_state(theta),
      [&](State& s, double t1, int* its, int* cuts) { return step_to(s, theta, t1, its, cuts); },
      [&](const State& s) { return sample(s, theta); }, from.size() > 0 ? &from : nullptr,
      produce);
}

}  // namespace sigmaheart::model::lumped
