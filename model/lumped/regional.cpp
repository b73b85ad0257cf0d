// The regional lumped ventricle (MultiPatch on a sphere); equations in regional.h.
//
// Full unknowns per step (all at t^{n+1}), stored in State::x in this order (the sphere's order
// for one patch): y, v = dy/dt, P_v, P_ar, P_d, c_1..c_{N-1}, (e_c, k_c, tau_c)_1..N, with
// c_N = (1 - sum_{q<N} w_q c_q)/w_N. As in LumpedSphere (sphere.cpp) the backward-Euler step
// eliminates y = y^n + h v, P_d (distal Windkessel, linear) and every patch's (k_c, tau_c)
// (bcs::reduced_step) exactly, and Newton runs on
//   u = (v, P_v, P_ar, c_1..c_{N-1}, e_c,1..e_c,N)       (2N + 2 unknowns; the sphere's 4 for N = 1)
// with the rows, scaled as the sphere's,
//   balance    (rho d0 (v - v^n)/h + (d0/R0) s Sigma_bar - P_v s^2)/Pref
//   cavity     (C_cav (P_v - P_v^n)/h + q + (V - V^n)/h) h/Vref
//   Windkessel proximal residual * h/Vref
//   tension    (Sigma_p - Sigma_N)/Pref, p < N
//   active     R_e,p / Pref, p = 1..N.
#include "model/lumped/regional.h"

#include "model/lumped/shell.h"
#include "model/periodic_shooting.h"

#include "model/bcs/active_law.h"
#include "model/circulation/circulation.h"
#include "model/enum_names.h"

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

using shell::kPref, shell::kVref;
using shell::cavity_volume, shell::passive_stress;

struct Patch {
  bcs::ActiveParameters act;  // sigma0 per patch
  double Td = 0.0, stiff = 1.0, scar = 0.0, w = 1.0;
};

// The shell's global parameters (its act holds no sigma0: each patch has its own), K_patch and
// the patches.
struct Model : shell::Shell {
  double K_patch = 0.0;  // mean-field tethering stiffness [Pa]
  std::vector<Patch> patch;
};

// Layout of the full state for N patches.
struct Layout {
  int n;
  int c0() const { return 5; }                      // first c_p
  int a0() const { return 5 + (n - 1); }            // first active unknown
  int size() const { return 5 + (n - 1) + 3 * n; }  // unknowns (last_open_valve follows)
  int active(int p) const { return a0() + 3 * p; }
  // Reduced Newton unknowns u: v, P_v, P_ar, c_1..c_{N-1}, e_c,1..N.
  int reduced() const { return 2 * n + 2; }
  int uc(int p) const { return 3 + p; }
  int ue(int p) const { return 3 + (n - 1) + p; }
};
using shell::kY, shell::kV, shell::kPv, shell::kPar, shell::kPd;

std::string two_digits(int i) {
  const std::string s = std::to_string(i);
  return s.size() < 2 ? "0" + s : s;
}

// c_p of every patch from the full state (the last from the compatibility condition).
void relative_stretches(const Model& m, const Layout& l, const Eigen::VectorXd& x,
                        std::vector<double>& c) {
  const int N = l.n;
  c.resize(static_cast<size_t>(N));
  double rest = 1.0;
  for (int p = 0; p + 1 < N; ++p) {
    c[static_cast<size_t>(p)] = x(l.c0() + p);
    rest -= m.patch[static_cast<size_t>(p)].w * x(l.c0() + p);
  }
  c[static_cast<size_t>(N - 1)] = rest / m.patch[static_cast<size_t>(N - 1)].w;
}

struct StepContext {
  const Model& m;
  const Layout& l;
  const Eigen::VectorXd& xo;      // full unknowns at t^n
  const std::vector<double>& co;  // c_p at t^n
  double h;
  double P_at;
  std::vector<bcs::StepActivation> act;
  double V_old;
  double Pd_den;  // C_d/h + 1/R_p + 1/R_d
  double Pd_rhs;  // C_d/h P_d^n + P_sv/R_d
};

// Scaled reduced residuals and their Jacobian in u; fills `full` (the complete state) if given.
void reduced_residual(const StepContext& c, const Eigen::VectorXd& u, Eigen::VectorXd& r,
                      Eigen::MatrixXd& J, Eigen::RowVectorXd& dSig, std::vector<double>& cp,
                      Eigen::VectorXd* full) {
  const Model& m = c.m;
  const Layout& l = c.l;
  const int N = l.n;
  const double h = c.h;
  const double v = u(0), Pv = u(1), Par = u(2);
  const double y = c.xo(kY) + h * v;
  const double s = 1.0 + y / m.R0;
  const double Cg = s * s;
  const double dCg_dy = 2.0 * s / m.R0;
  cp.resize(static_cast<size_t>(N));
  double rest = 1.0;
  for (int p = 0; p + 1 < N; ++p) {
    cp[static_cast<size_t>(p)] = u(l.uc(p));
    rest -= m.patch[static_cast<size_t>(p)].w * u(l.uc(p));
  }
  const double wN = m.patch[static_cast<size_t>(N - 1)].w;
  cp[static_cast<size_t>(N - 1)] = rest / wN;

  J.setZero();
  r.setZero();
  const double k1 = m.d0 / m.R0;
  const int first_tension = 3, nu = l.reduced();
  double Sbar = 0.0;
  Eigen::RowVectorXd dSbar = Eigen::RowVectorXd::Zero(nu);  // total derivatives in u (v via y too)
  for (int p = 0; p < N; ++p) {
    const Patch& pa = m.patch[static_cast<size_t>(p)];
    const double cpp = cp[static_cast<size_t>(p)], cpo = c.co[static_cast<size_t>(p)];
    const double C = Cg * cpp;
    const double e = 0.5 * (C - 1.0);
    // Derivatives of C_p and of dC_p/dt in v (through y = y^n + h v and explicitly) and in c_p.
    const double dC_dv = dCg_dy * cpp * h;
    const double dC_dc = Cg;
    double Sp = 0.0, dSp_dC = 0.0;
    passive_stress(m, C, Sp, dSp_dC);
    const double iC = 1.0 / C, iC2 = iC * iC, iC6 = iC2 * iC2 * iC2;
    const double g = 1.0 + 2.0 * iC6, dg_dC = -12.0 * iC6 * iC;
    const double Cdot = (2.0 * s * v / m.R0) * cpp + Cg * (cpp - cpo) / h;
    const double dCdot_dv =
        ((2.0 * v / (m.R0 * m.R0)) * cpp + dCg_dy * (cpp - cpo) / h) * h + (2.0 * s / m.R0) * cpp;
    const double dCdot_dc = 2.0 * s * v / m.R0 + Cg / h;

    const int ie = l.ue(p);
    const int ia = l.active(p);
    const bcs::ActiveState old{c.xo(ia), c.xo(ia + 1), c.xo(ia + 2)};
    const bcs::ReducedStep a =
        bcs::reduced_step(pa.act, old, u(ie), e, c.act[static_cast<size_t>(p)], h);
    const double live = 1.0 - pa.scar;

    const double Sigma = pa.stiff * Sp + m.eta * Cdot * g + live * a.stress + m.K_patch * (cpp - 1.0);
    const double dS_dC = pa.stiff * dSp_dC + m.eta * Cdot * dg_dC + live * a.dstress_de * 0.5;
    const double dS_dCdot = m.eta * g;
    dSig.setZero();
    dSig(0) = dS_dC * dC_dv + dS_dCdot * dCdot_dv;
    const double dS_dcp = dS_dC * dC_dc + dS_dCdot * dCdot_dc + m.K_patch;
    if (p + 1 < N) {
      dSig(l.uc(p)) = dS_dcp;
    } else {
      for (int q = 0; q + 1 < N; ++q) {
        dSig(l.uc(q)) = dS_dcp * (-m.patch[static_cast<size_t>(q)].w / wN);
      }
    }
    dSig(ie) = live * a.dstress_dec;

    Sbar += pa.w * Sigma;
    dSbar += pa.w * dSig;
    if (p + 1 < N) {
      r(first_tension + p) = Sigma / kPref;
      J.row(first_tension + p) = dSig / kPref;
    } else {
      for (int q = 0; q + 1 < N; ++q) {
        r(first_tension + q) -= Sigma / kPref;
        J.row(first_tension + q) -= dSig / kPref;
      }
    }

    // Contractile-element balance of patch p (k_c, tau_c eliminated), e_p = (s^2 c_p - 1)/2.
    const int row = first_tension + (N - 1) + p;
    r(row) = a.residual / kPref;
    J(row, 0) = a.dres_de * 0.5 * dC_dv / kPref;
    if (p + 1 < N) {
      J(row, l.uc(p)) = a.dres_de * 0.5 * dC_dc / kPref;
    } else {
      for (int q = 0; q + 1 < N; ++q) {
        J(row, l.uc(q)) = a.dres_de * 0.5 * dC_dc * (-m.patch[static_cast<size_t>(q)].w / wN) / kPref;
      }
    }
    J(row, ie) = a.dres_dec / kPref;
    if (full != nullptr) {
      (*full)(ia) = a.state.e_c;
      (*full)(ia + 1) = a.state.k_c;
      (*full)(ia + 2) = a.state.tau_c;
    }
  }

  // Balance of the shell (inertia of the whole wall, mean stress Sigma_bar).
  r(0) = (m.rho * m.d0 * (v - c.xo(kV)) / h + k1 * s * Sbar - Pv * Cg) / kPref;
  J.row(0) = (k1 * s / kPref) * dSbar;
  J(0, 0) = ((k1 * Sbar / m.R0 - Pv * dCg_dy) * h + m.rho * m.d0 / h + k1 * s * dSbar(0)) / kPref;
  J(0, 1) = -Cg / kPref;
  // Cavity volume balance and proximal Windkessel.
  const double Pd = shell::circulation_rows(m, c, y, Pv, Par, r, J);

  if (full != nullptr) {
    (*full)(kY) = y;
    (*full)(kV) = v;
    (*full)(kPv) = Pv;
    (*full)(kPar) = Par;
    (*full)(kPd) = Pd;
    for (int p = 0; p + 1 < N; ++p) (*full)(l.c0() + p) = u(l.uc(p));
  }
}

// One backward-Euler step over [t0, t1]; xn receives the full unknowns. Returns Newton iterations
// or -1.
int newton_step(const Model& m, const Layout& l, const Eigen::VectorXd& xo, double t0, double t1,
                const SphereOptions& o, Eigen::VectorXd& xn) {
  const double h = t1 - t0;
  std::vector<double> co;
  relative_stretches(m, l, xo, co);
  StepContext c{m, l, xo, co, h, m.atrial(t1), {}, cavity_volume(m, xo(kY)),
                m.circ.C_d / h + 1.0 / m.circ.R_p + 1.0 / m.circ.R_d,
                m.circ.C_d / h * xo(kPd) + m.circ.P_sv / m.circ.R_d};
  c.act.reserve(m.patch.size());
  for (const Patch& p : m.patch) c.act.push_back(bcs::step_activation(t0, t1, p.Td, m.period, p.act));
  const int nu = l.reduced();
  Eigen::VectorXd u(nu), r(nu);
  u(0) = xo(kV);
  u(1) = xo(kPv);
  u(2) = xo(kPar);
  for (int p = 0; p + 1 < l.n; ++p) u(l.uc(p)) = xo(l.c0() + p);
  for (int p = 0; p < l.n; ++p) u(l.ue(p)) = xo(l.active(p));
  Eigen::MatrixXd J(nu, nu);
  Eigen::RowVectorXd scratch(nu);
  std::vector<double> cp;
  xn.resize(xo.size());
  reduced_residual(c, u, r, J, scratch, cp, &xn);
  auto eval = [&](const Eigen::VectorXd& ut, Eigen::VectorXd& rt, Eigen::MatrixXd& Jt,
                  Eigen::VectorXd& full) {
    if (1.0 + (xo(kY) + h * ut(0)) / m.R0 <= 0.05) return false;  // the shell collapsed
    reduced_residual(c, ut, rt, Jt, scratch, cp, &full);
    for (double cq : cp) {
      if (!(cq > 0.05)) return false;  // a patch collapsed
    }
    return true;
  };
  return shell::damped_newton(m, h, u, r, J, xn, eval, o);
}

// ---- AHA geometry (truncated prolate ellipsoid, see regional.h).
constexpr double kRs = 25e-3, kRl = 45e-3, kZbase = 5e-3 * 45.0 / 17.0;

// r(z) sqrt(1 + r'(z)^2) = sqrt(r^2 + (r r')^2), finite at the apex.
double band_density(double z) {
  const double r2 = kRs * kRs * (1.0 - z * z / (kRl * kRl));
  const double rr = -kRs * kRs * z / (kRl * kRl);
  return 2.0 * std::numbers::pi * std::sqrt(std::max(r2, 0.0) + rr * rr);
}
double band_area(double z0, double z1) {  // Gauss-Legendre, 5 points on 400 panels
  static const double xg[5] = {-0.9061798459386640, -0.5384693101056831, 0.0,
                               0.5384693101056831, 0.9061798459386640};
  static const double wg[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                               0.4786286704993665, 0.2369268850561891};
  const int panels = 400;
  const double hz = (z1 - z0) / panels;
  double a = 0.0;
  for (int k = 0; k < panels; ++k) {
    const double mid = z0 + (k + 0.5) * hz;
    for (int g = 0; g < 5; ++g) a += wg[g] * 0.5 * hz * band_density(mid + 0.5 * hz * xg[g]);
  }
  return a;
}
// Long-axis heights: base, the ring boundaries and the top of the apical cap.
struct Heights {
  double base, b_mid, mid_ap, cap, apex;
};
Heights heights() {
  const double apex = -kRl, L = kZbase - apex;
  return {kZbase, kZbase - L / 3.0, kZbase - 2.0 * L / 3.0, apex + L / 12.0, apex};
}
// Meridian arc length from the apex to height z.
double meridian(double z) {
  const Heights H = heights();
  const int panels = 400;
  const double hz = (z - H.apex) / panels;
  double s = 0.0;
  for (int k = 0; k < panels; ++k) {
    const double zm = H.apex + (k + 0.5) * hz;
    const double dr = -kRs * zm / (kRl * kRl * std::sqrt(std::max(1.0 - zm * zm / (kRl * kRl), 1e-300)));
    s += hz * std::sqrt(1.0 + dr * dr);
  }
  return s;
}
double ring_radius(double z) { return kRs * std::sqrt(std::max(1.0 - z * z / (kRl * kRl), 0.0)); }

// Centre (height, azimuth [rad]) of each AHA segment. Azimuths from a fixed reference direction
// (the ellipsoid has no RV insertion): basal/mid centres at 30 + 60 j deg in the order anterior,
// anteroseptal, inferoseptal, inferior, inferolateral, anterolateral; apical at 30, 120, 210,
// 300 deg (anterior, septal, inferior, lateral); the apex on the axis.
void segment_centre(int seg, double& z, double& phi) {
  const Heights H = heights();
  const double deg = std::numbers::pi / 180.0;
  if (seg < 6) {
    z = 0.5 * (H.base + H.b_mid);
    phi = (30.0 + 60.0 * seg) * deg;
  } else if (seg < 12) {
    z = 0.5 * (H.b_mid + H.mid_ap);
    phi = (30.0 + 60.0 * (seg - 6)) * deg;
  } else if (seg < 16) {
    z = 0.5 * (H.mid_ap + H.cap);
    phi = (30.0 + 90.0 * (seg - 12)) * deg;
  } else {
    z = H.apex;
    phi = 0.0;
  }
}
double wall_path(double z1, double phi1, double z2, double phi2) {
  const double ds = meridian(z2) - meridian(z1);
  double dphi = std::abs(phi2 - phi1);
  dphi = std::min(dphi, 2.0 * std::numbers::pi - dphi);
  const double rm = 0.5 * (ring_radius(z1) + ring_radius(z2));
  return std::sqrt(ds * ds + rm * dphi * rm * dphi);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
SIGMAHEART_ENUM_TEXT(ActivationPattern, parse_activation_pattern,
    {ActivationPattern::kSynchronous, "synchronous"}, {ActivationPattern::kLbbb, "lbbb"},
    {ActivationPattern::kPacing, "pacing"}, {ActivationPattern::kExplicit, "explicit"})

int RegionalOptions::patches() const {
  return area_shares.empty() ? 17 : static_cast<int>(area_shares.size());
}

std::string RegionalOptions::validate() const {
  std::ostringstream s;
  if (const std::string e = numerics.validate(); !e.empty()) return "numerics: " + e;
  if (!area_shares.empty()) {
    double sum = 0.0;
    for (double w : area_shares) {
      if (!(w > 0.0 && std::isfinite(w))) return "area_shares must be positive";
      sum += w;
    }
    if (std::abs(sum - 1.0) > 1e-12) {
      s << "area_shares must sum to 1, got " << sum;
      return s.str();
    }
  }
  const bool aha = patches() == 17;
  if ((activation == ActivationPattern::kLbbb || activation == ActivationPattern::kPacing) && !aha) {
    return std::string("activation '") + to_string(activation) + "' needs the 17 AHA segments";
  }
  if (activation == ActivationPattern::kLbbb && !(lbbb_duration >= 0.0 && lbbb_duration < 0.5)) {
    return "lbbb_duration must lie in [0, 0.5) s";
  }
  if (activation == ActivationPattern::kPacing) {
    if (pacing_segment < 1 || pacing_segment > 17) return "pacing_segment must lie in 1..17";
    if (!(conduction_velocity > 0.0 && std::isfinite(conduction_velocity))) {
      return "conduction_velocity must be positive";
    }
  }
  if (activation == ActivationPattern::kExplicit) {
    if (static_cast<int>(activation_times.size()) != patches()) {
      s << "activation_times has " << activation_times.size() << " entries, expected "
        << patches();
      return s.str();
    }
    for (double t : activation_times) {
      if (!(t >= 0.0 && t < 1.0)) return "activation_times must lie in [0, 1) s";
    }
  }
  return {};
}

const std::vector<std::string>& aha17_segment_names() {
  static const std::vector<std::string> names = {
      "basal anterior",     "basal anteroseptal", "basal inferoseptal", "basal inferior",
      "basal inferolateral", "basal anterolateral", "mid anterior",     "mid anteroseptal",
      "mid inferoseptal",   "mid inferior",       "mid inferolateral",  "mid anterolateral",
      "apical anterior",    "apical septal",      "apical inferior",    "apical lateral",
      "apex"};
  return names;
}

std::vector<double> aha17_area_shares() {
  const Heights H = heights();
  const double basal = band_area(H.b_mid, H.base), mid = band_area(H.mid_ap, H.b_mid);
  const double apical = band_area(H.cap, H.mid_ap), cap = band_area(H.apex, H.cap);
  const double total = basal + mid + apical + cap;
  std::vector<double> w;
  for (int i = 0; i < 6; ++i) w.push_back(basal / 6.0 / total);
  for (int i = 0; i < 6; ++i) w.push_back(mid / 6.0 / total);
  for (int i = 0; i < 4; ++i) w.push_back(apical / 4.0 / total);
  w.push_back(cap / total);
  // Close the sum exactly (the compatibility condition is written with these shares).
  double sum = 0.0;
  for (int i = 0; i < 16; ++i) sum += w[static_cast<size_t>(i)];
  w[16] = 1.0 - sum;
  return w;
}

std::vector<double> aha17_activation_times(const RegionalOptions& options) {
  std::vector<double> t(17, 0.0);
  if (options.activation == ActivationPattern::kExplicit) return options.activation_times;
  if (options.activation == ActivationPattern::kSynchronous) return t;
  double z0 = 0.0, phi0 = 0.0;
  if (options.activation == ActivationPattern::kLbbb) {
    const Heights H = heights();
    z0 = 0.5 * (H.b_mid + H.mid_ap);  // mid ring, between anteroseptal (90) and inferoseptal (150)
    phi0 = 120.0 * std::numbers::pi / 180.0;
  } else {
    segment_centre(options.pacing_segment - 1, z0, phi0);
  }
  std::vector<double> path(17, 0.0);
  for (int k = 0; k < 17; ++k) {
    double z = 0.0, phi = 0.0;
    segment_centre(k, z, phi);
    // The apex and a source on the axis have no azimuth: measure along the meridian only.
    if (k == 16 || (options.activation == ActivationPattern::kPacing && options.pacing_segment == 17)) {
      phi = phi0;
    }
    path[static_cast<size_t>(k)] = wall_path(z0, phi0, z, phi);
  }
  const double shortest = *std::min_element(path.begin(), path.end());
  const double longest = *std::max_element(path.begin(), path.end());
  for (int k = 0; k < 17; ++k) {
    const double d = path[static_cast<size_t>(k)];
    t[static_cast<size_t>(k)] = options.activation == ActivationPattern::kLbbb
                                    ? options.lbbb_duration * (d - shortest) / (longest - shortest)
                                    : d / options.conduction_velocity;
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
ParameterSpace RegionalVentricle::default_parameters(const RegionalOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) {
    throw std::invalid_argument("RegionalOptions: " + e);
  }
  const ParameterSpace sphere = LumpedSphere::default_parameters();
  std::vector<Parameter> out;
  for (const Parameter& p : sphere.all()) {
    if (p.name == "sigma0") continue;
    out.push_back(p);
    // The patches' length-dependent activation (regional.h, docs/models.md s.3.2).
    if (p.name == "n0_slope") {
      out.back().nominal = kRegionalN0Slope;
      out.back().doc = "length-dependent activation gain dn0/de_c: Land et al. 2017 (beta0 2.3) on the sphere's "
                       "fibre stretch [docs/models.md s.3.2]; 0: classical n0 = 1";
    } else if (p.name == "n0_e_max") {
      out.back().nominal = kRegionalN0EMax;
      out.back().doc = "contractile strain where n0 reaches 1: stretch 1.2, the end of Land's ramp [docs/models.md s.3.2]";
    }
  }
  out.push_back({"K_patch", "Pa", kRegionalKPatch, 0.0, 1e8,
                 "mean-field tethering stiffness K (c_p - 1); 0: pure MultiPatch [docs/models.md s.3.2: the 3D LBBB's "
                 "septal and lateral excursions]",
                 "passive_stiffness", 0});
  set_physiological_ranges(out);
  Parameter s0 = sphere[sphere.index_or_throw("sigma0")];
  s0.nominal = kRegionalSigma0;
  const int N = options.patches();
  const bool aha = N == 17;
  std::vector<double> td(static_cast<size_t>(N), 0.0);
  if (options.activation == ActivationPattern::kExplicit) {
    td = options.activation_times;
  } else if (aha) {
    td = aha17_activation_times(options);
  }
  for (int p = 0; p < N; ++p) {
    const std::string xx = two_digits(p + 1);
    const std::string where = aha ? " of segment " + xx + " (" + aha17_segment_names()[static_cast<size_t>(p)] + ")"
                                  : " of patch " + xx;
    out.push_back({"sigma0_" + xx, s0.unit, s0.nominal, s0.lower, s0.upper,
                   "contractility" + where + " [EF ~63 % with the length-dependent activation, docs/models.md s.3.2]",
                   "contractility", p + 1});
    out.back().range_lower = s0.range_lower;
    out.back().range_upper = s0.range_upper;
    out.back().range_source = s0.range_source;
    out.push_back({"Td_" + xx, "s", td[static_cast<size_t>(p)], 0.0, 1.0,
                   "activation (depolarisation) time" + where + std::string(" [pattern '") +
                       to_string(options.activation) + "']",
                   "activation_time", p + 1});
    out.push_back({"stiff_" + xx, "1", 1.0, 0.05, 20.0, "passive stiffness scale" + where,
                   "stiffness_scale", p + 1});
    out.push_back({"scar_" + xx, "1", 0.0, 0.0, 1.0, "non-contractile (scar) fraction" + where,
                   "scar_fraction", p + 1});
  }
  return ParameterSpace(std::move(out));
}

RegionalVentricle::RegionalVentricle(RegionalOptions options)
    : RegionalVentricle(options, default_parameters(options)) {}

RegionalVentricle::RegionalVentricle(RegionalOptions options, ParameterSpace parameters)
    : options_(std::move(options)), parameters_(std::move(parameters)) {
  if (const std::string e = options_.validate(); !e.empty()) {
    throw std::invalid_argument("RegionalOptions: " + e);
  }
  n_ = options_.patches();
  shares_ = options_.area_shares.empty() ? aha17_area_shares() : options_.area_shares;
  global_ = shell::global_indices(parameters_);
  global_.push_back(parameters_.index_or_throw("K_patch"));
  for (int p = 0; p < n_; ++p) {
    const std::string xx = two_digits(p + 1);
    sigma0_.push_back(parameters_.index_or_throw("sigma0_" + xx));
    td_.push_back(parameters_.index_or_throw("Td_" + xx));
    stiff_.push_back(parameters_.index_or_throw("stiff_" + xx));
    scar_.push_back(parameters_.index_or_throw("scar_" + xx));
  }
}

std::unique_ptr<RegionalVentricle> RegionalVentricle::with_time_step(double dt) const {
  auto copy = std::make_unique<RegionalVentricle>(*this);
  copy->options_.numerics.dt = dt;
  return copy;
}

std::unique_ptr<Simulator> RegionalVentricle::clone() const {
  return std::make_unique<RegionalVentricle>(*this);
}

std::vector<Channel> RegionalVentricle::channels() const {
  std::vector<Channel> c = shell::circulation_channels();
  for (int p = 0; p < n_; ++p) {
    c.push_back({"V_seg" + two_digits(p + 1), "m^3",
                 "regional cavity volume V w_p c_p of " +
                     (n_ == 17 ? aha17_segment_names()[static_cast<size_t>(p)] : "patch " + two_digits(p + 1)),
                 "regional_volume", p + 1});
  }
  return c;
}

std::vector<Channel> RegionalVentricle::state_layout() const {
  std::vector<Channel> s = shell::state_head();
  for (int p = 0; p + 1 < n_; ++p) {
    s.push_back({"c_" + two_digits(p + 1), "1", "relative areal stretch C_p / s^2 of patch " + two_digits(p + 1)});
  }
  for (int p = 0; p < n_; ++p) {
    std::string suffix = "_";  // not "_" + std::string: GCC 12 -Wrestrict false positive at -O3
    suffix += two_digits(p + 1);
    const std::vector<Channel> active = shell::active_state_entries(suffix);
    s.insert(s.end(), active.begin(), active.end());
  }
  s.push_back(shell::last_open_valve_entry());
  return s;
}

namespace {
Model unpack_model(const Eigen::Ref<const Eigen::VectorXd>& theta, const std::vector<int>& g,
                   const std::vector<int>& sigma0, const std::vector<int>& td,
                   const std::vector<int>& stiff, const std::vector<int>& scar,
                   const std::vector<double>& shares, const bcs::ActivationInput& input) {
  Model m;
  static_cast<shell::Shell&>(m) = shell::unpack(theta, g);
  m.K_patch = theta(g.back());
  m.act.input = input;  // the shape of u(t) of every patch (numerics activation_shape, as the sphere's)
  const bcs::ActiveParameters act = m.act;
  m.patch.resize(shares.size());
  for (size_t p = 0; p < shares.size(); ++p) {
    m.patch[p].act = act;
    m.patch[p].act.sigma0 = theta(sigma0[p]);
    m.patch[p].Td = theta(td[p]);
    m.patch[p].stiff = theta(stiff[p]);
    m.patch[p].scar = theta(scar[p]);
    m.patch[p].w = shares[p];
  }
  return m;
}
}  // namespace

Status RegionalVentricle::check_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (theta.size() != parameters_.size()) {
    return shell::check_theta(parameters_, options_.numerics, theta, 0.0, 1.0);
  }
  return shell::check_theta(parameters_, options_.numerics, theta,
                            theta(global_[shell::kAPD]), theta(global_[shell::kPeriod]));
}

State RegionalVentricle::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  const Layout l{n_};
  State s;
  s.time = 0.0;
  s.x = Eigen::VectorXd::Zero(l.size() + 1);
  if (theta.size() != parameters_.size() || !theta.allFinite()) {
    s.x.setConstant(std::numeric_limits<double>::quiet_NaN());
    return s;
  }
  const Model m = unpack_model(theta, global_, sigma0_, td_, stiff_, scar_, shares_, options_.numerics.activation_input);
  // As the sphere: relaxed, in static passive equilibrium with the atrial pressure (every c_p = 1;
  // with unequal stiffness scales the first step re-balances the tensions), contractile elements
  // at rest, arteries at a typical diastolic pressure.
  const double e0 = shell::fill_relaxed_state(m, s.x);
  for (int p = 0; p + 1 < n_; ++p) s.x(l.c0() + p) = 1.0;
  for (int p = 0; p < n_; ++p) s.x(l.active(p)) = e0;
  s.x(l.size()) = static_cast<double>(circ::ValveRegime::kFilling);
  return s;
}

Status RegionalVentricle::step_to(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                                  double t_end, int* newton_iterations, int* step_cuts) const {
  const Layout l{n_};
  const Model m = unpack_model(theta, global_, sigma0_, td_, stiff_, scar_, shares_, options_.numerics.activation_input);
  auto step = [&](const Eigen::VectorXd& xo, double ta, double tb, Eigen::VectorXd& xn) {
    return newton_step(m, l, xo, ta, tb, options_.numerics, xn);
  };
  return shell::step_with_cuts<Eigen::VectorXd>(state, m, options_.numerics.dt, t_end, step,
                                                newton_iterations, step_cuts);
}

Status RegionalVentricle::advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                                  double t_end) {
  if (Status st = check_theta(theta); !st.ok()) return st;
  if (Status st = shell::check_advance(state, Layout{n_}.size() + 1, t_end); !st.ok()) return st;
  return step_to(state, theta, t_end, nullptr, nullptr);
}

Eigen::VectorXd RegionalVentricle::sample(const State& state,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  const Layout l{n_};
  const Model m = unpack_model(theta, global_, sigma0_, td_, stiff_, scar_, shares_, options_.numerics.activation_input);
  const double V = cavity_volume(m, state.x(kY));
  std::vector<double> c;
  relative_stretches(m, l, state.x, c);
  Eigen::VectorXd out(8 + n_);
  out.head(8) = shell::circulation_sample(m, state);
  for (int p = 0; p < n_; ++p) out(8 + p) = V * m.patch[static_cast<size_t>(p)].w * c[static_cast<size_t>(p)];
  return out;
}

RunResult RegionalVentricle::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  return run_warm(theta, Eigen::VectorXd(), nullptr);
}

int RegionalVentricle::warm_start_size() const { return ShootingWarmStart::packed_size(Layout{n_}.size()); }

RunResult RegionalVentricle::run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta, const Eigen::VectorXd& from,
                                      Eigen::VectorXd* produce) {
  if (Status st = check_theta(theta); !st.ok()) {
    if (produce) *produce = Eigen::VectorXd::Zero(warm_start_size());
    return shell::failed_run(channels(), st);
  }
  return shell::run_periodic(
      unpack_model(theta, global_, sigma0_, td_, stiff_, scar_, shares_, options_.numerics.activation_input), options_.numerics,
      channels(), initial_state(theta),
      [&](State& s, double t1, int* its, int* cuts) { return step_to(s, theta, t1, its, cuts); },
      [&](const State& s) { return sample(s, theta); }, from.size() > 0 ? &from : nullptr, produce);
}

}  // namespace sigmaheart::model::lumped
