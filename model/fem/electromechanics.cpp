#include "model/fem/electromechanics.h"
#include "model/fem/pacing.h"

#include "model/fem/coarse_space.h"
#include "model/fem/element.h"
#include "model/fem/eikonal.h"
#include "model/fem/fibres.h"
#include "model/fem/solver.h"
#include "model/lumped/shell.h"
#include "model/lumped/sphere.h"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::fem {

namespace shell = lumped::shell;
namespace circ = circulation;

// ---------------------------------------------------------------------------------------------
// Passive law.

std::string BcsPassiveParameters::validate() const {
  auto bad = [](double v) { return !std::isfinite(v) || v < 0; };
  if (bad(c1)) return "c1 must be finite and >= 0";
  if (bad(c2)) return "c2 must be finite and >= 0";
  if (bad(c_exp)) return "c_exp must be finite and >= 0";
  if (bad(b_exp)) return "b_exp must be finite and >= 0";
  return {};
}

double BcsPassive::energy(const Eigen::Matrix3d& E, const Frame&) const {
  const Eigen::Matrix3d C = Eigen::Matrix3d::Identity() + 2.0 * E;
  const double I1 = C.trace(), I2 = 0.5 * (I1 * I1 - (C * C).trace()), I3 = C.determinant();
  const double a = std::pow(I3, -1.0 / 3.0);
  const double Q = a * I1 - 3.0;
  return p_.c1 * Q + p_.c2 * (a * a * I2 - 3.0) + p_.c_exp * (std::exp(p_.b_exp * Q * Q) - 1.0);
}

void BcsPassive::stress(const Eigen::Matrix3d& E, const Frame&, Eigen::Matrix3d& S, Matrix9d& D) const {
  // W(C) = c1 f1 + c2 f2 + g(f1), f1 = I3^-1/3 I1, f2 = I3^-2/3 I2, g(f) = c_exp (exp(b (f-3)^2) - 1);
  // S = 2 dW/dC, D = dS/dE = 4 d2W/dC2 (isochoric_invariants, material.h).
  const IsochoricInvariants f = isochoric_invariants(E);
  const double Q = f.f1 - 3.0;
  const double ex = p_.c_exp > 0 ? std::exp(p_.b_exp * Q * Q) : 0.0;
  const double g1 = 2.0 * p_.b_exp * p_.c_exp * Q * ex;                            // g'(f1)
  const double g2 = 2.0 * p_.b_exp * p_.c_exp * ex * (1.0 + 2.0 * p_.b_exp * Q * Q);  // g''(f1)
  const double w1 = p_.c1 + g1;
  S = 2.0 * (w1 * f.df1 + p_.c2 * f.df2);
  D = 4.0 * (w1 * f.d2f1 + p_.c2 * f.d2f2 + g2 * tensor_outer(f.df1, f.df1));
}

void BcsPassive::stress_only(const Eigen::Matrix3d& E, const Frame&, Eigen::Matrix3d& S) const {
  const IsochoricInvariants f = isochoric_invariants(E, false);
  const double Q = f.f1 - 3.0;
  const double ex = p_.c_exp > 0 ? std::exp(p_.b_exp * Q * Q) : 0.0;
  const double w1 = p_.c1 + 2.0 * p_.b_exp * p_.c_exp * Q * ex;  // c1 + g'(f1)
  S = 2.0 * (w1 * f.df1 + p_.c2 * f.df2);
}

// ---------------------------------------------------------------------------------------------
// Options.
std::string LeftVentricle3DOptions::validate() const {
  std::ostringstream s;
  if (n_transmural < 1 || n_transmural > 8) return "n_transmural must be in 1..8";
  if (n_longitudinal < 6 || n_longitudinal > 60) return "n_longitudinal must be in 6..60";
  // Below 12 elements around (and 6 along) the curved quadratic tetrahedra near the apex invert.
  if (n_circumferential < 12 || n_circumferential > 120 || n_circumferential % 6 != 0)
    return "n_circumferential must be a multiple of 6 in 12..120 (AHA 60-degree sectors)";
  if (const std::string g = geometry.validate(); !g.empty()) return "geometry: " + g;
  if (element_order != 1 && element_order != 2) return "element_order must be 1 (linear) or 2 (quadratic)";
  if (const std::string a = activation_input.validate(); !a.empty()) return "activation_shape: " + a;
  if (!(conduction_scale > 0.1 && conduction_scale <= 10.0)) return "conduction_scale must lie in (0.1, 10]";
  if (!(bulk_modulus >= 0) || std::isinf(bulk_modulus)) return "bulk_modulus must be finite and >= 0 [Pa]";
  if (element_order == 1 && !(bulk_modulus > 0))
    return "bulk_modulus must be > 0 with element_order 1 (P1-P1 is not inf-sup stable at exact incompressibility)";
  if (!(pressure_stabilization >= 0) || std::isinf(pressure_stabilization))
    return "pressure_stabilization must be finite and >= 0";
  if (!(grad_div >= 0) || std::isinf(grad_div)) return "grad_div must be finite and >= 0";
  if (pressure_stabilization > 0 && element_order != 1)
    return "pressure_stabilization needs element_order 1 (Taylor-Hood tetrahedra are inf-sup stable)";
  if (quadrature_degree != 1 && quadrature_degree != 2 && quadrature_degree != 5)
    return "quadrature_degree must be 1, 2 or 5";
  if (quadrature_degree == 1 && element_order != 1)
    return "quadrature_degree 1 needs element_order 1 (one point under-integrates quadratic tetrahedra)";
  if (!(std::abs(fibre_endo_deg) <= 90) || !(std::abs(fibre_epi_deg) <= 90))
    return "fibre angles must lie in [-90, 90] deg";
  if (!(dt >= 1e-5 && dt <= 0.05)) {
    s << "dt = " << dt << " s must lie in [1e-05, 0.05] s";
    return s.str();
  }
  if (max_step_cuts < 0 || max_step_cuts > 12) return "max_step_cuts must be in 0..12";
  if (inflation_steps < 1 || inflation_steps > 100) return "inflation_steps must be in 1..100";
  if (min_beats < 1) return "min_beats must be >= 1";
  if (max_beats < min_beats || max_beats > 1000) return "max_beats must be in [min_beats, 1000]";
  if (!(periodic_tolerance > 0 && periodic_tolerance < 10)) return "periodic_tolerance must lie in (0, 10)";
  if (output_every < 1) return "output_every must be >= 1";
  if (!(newton_tolerance > 1e-14 && newton_tolerance < 1e-2)) return "newton_tolerance must lie in (1e-14, 1e-2)";
  if (newton_max_iterations < 1 || newton_max_iterations > 200) return "newton_max_iterations must be in 1..200";
  if (!(linear_tolerance >= 1e-14 && linear_tolerance <= 0.1)) {
    s << "linear_tolerance = " << linear_tolerance << " must lie in [1e-14, 0.1]";
    return s.str();
  }
  if (coarse_correction && linear_solver != LinearSolver::kAmg)
    return "coarse_correction needs linear_solver amg (the direct solvers have no preconditioner to correct)";
  if (exact_displacement_solve && linear_solver != LinearSolver::kAmg)
    return "exact_displacement_solve needs linear_solver amg (it replaces the V-cycle of its preconditioner)";
  if (!(conduction_velocity > 0.01 && conduction_velocity < 100)) {
    s << "conduction_velocity = " << conduction_velocity << " m/s must lie in (0.01, 100) m/s";
    return s.str();
  }
  return {};
}

// ---------------------------------------------------------------------------------------------
// Geometry (shared, immutable) and per-object caches.
namespace {

// Scales of the Newton rows (as the lumped models, model/lumped/shell.h).
constexpr double kPref = shell::kPref;  // [Pa]
constexpr double kVref = shell::kVref;  // [m^3]
constexpr double kLref = 1e-3;          // [m] displacement scale of the step test

struct Geometry {
  Mesh mesh;
  std::vector<Frame> frames;      // per quadrature point
  AhaLabels labels;
  std::vector<double> qp_np;      // P1 shape values at the rule's points, 4 per point
  int nqp = 0;                    // per element
  std::vector<double> td;         // activation time per quadrature point [s]
  std::vector<double> intrinsic_vt;  // the intrinsic activation time per vertex [s] (pace() starts from it)
  double force_ref = 1.0;         // [N] kPref times the mean endocardial nodal area
  double volume_ref = 1.0;        // [m^3] mean reference volume per vertex
};

std::string two_digits(int k) {
  std::ostringstream s;
  s << std::setw(2) << std::setfill('0') << k;
  return s.str();
}

// Activation times at the quadrature points from per-vertex times (P1 interpolation).
std::vector<double> interpolate_vertex_times(const Geometry& g, const std::vector<double>& vt) {
  std::vector<double> out(static_cast<size_t>(g.mesh.n_tets()) * static_cast<size_t>(g.nqp));
  for (int e = 0; e < g.mesh.n_tets(); ++e)
    for (int q = 0; q < g.nqp; ++q) {
      double t = 0.0;
      for (int k = 0; k < 4; ++k) t += g.qp_np[static_cast<size_t>(4 * q + k)] * vt[static_cast<size_t>(g.mesh.tets(e, k))];
      out[static_cast<size_t>(e * g.nqp + q)] = t;
    }
  return out;
}

// The eikonal patterns' velocities scaled by LeftVentricle3DOptions::conduction_scale.
ActivationPatternOptions pattern_options(const LeftVentricle3DOptions& o) {
  ActivationPatternOptions p;
  p.myocardium = {p.myocardium.fibre * o.conduction_scale, p.myocardium.sheet * o.conduction_scale,
                  p.myocardium.normal * o.conduction_scale};
  p.fast_endocardial_speed *= o.conduction_scale;
  return p;
}

std::shared_ptr<Geometry> build_geometry(const LeftVentricle3DOptions& o) {
  auto g = std::make_shared<Geometry>();
  const EllipsoidGeometry& shape = o.geometry;
  EllipsoidMeshOptions mo;
  mo.n_transmural = o.n_transmural;
  mo.n_longitudinal = o.n_longitudinal;
  mo.n_circumferential = o.n_circumferential;
  mo.order = o.element_order;
  mo.align_aha_levels = true;
  g->mesh = ellipsoid_mesh(shape, mo);
  FibreOptions fo;
  fo.alpha_endo_deg = o.fibre_endo_deg;
  fo.alpha_epi_deg = o.fibre_epi_deg;
  g->frames = ellipsoid_fibres(g->mesh, shape, fo, o.quadrature_degree);
  g->labels = aha_labels(g->mesh);
  const auto& rule = tet_rule(o.quadrature_degree);
  g->nqp = static_cast<int>(rule.size());
  for (const auto& qp : rule) {
    const auto& xi = qp.xi;
    for (double v : {1 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]}) g->qp_np.push_back(v);
  }
  // Reference scales of the Newton rows.
  double area = 0.0;
  for (Eigen::Index f = 0; f < g->mesh.faces.rows(); ++f) {
    if (g->mesh.face_tag[static_cast<size_t>(f)] != kEndocardium) continue;
    const Eigen::Vector3d p0 = g->mesh.nodes.row(g->mesh.faces(f, 0)), p1 = g->mesh.nodes.row(g->mesh.faces(f, 1)),
                          p2 = g->mesh.nodes.row(g->mesh.faces(f, 2));
    area += 0.5 * (p1 - p0).cross(p2 - p0).norm();
  }
  const auto endo_nodes = g->mesh.nodes_with_tag(kEndocardium);
  g->force_ref = kPref * area / static_cast<double>(std::max<size_t>(1, endo_nodes.size()));
  g->volume_ref = g->mesh.volume() / g->mesh.n_vertices;
  // Default activation times.
  std::vector<double> vt(static_cast<size_t>(g->mesh.n_vertices), 0.0);
  if (o.activation == ActivationSource::kApexDistance) {
    // Straight-line distance from the endocardial apex (a stand-in for the eikonal solve).
    for (int v = 0; v < g->mesh.n_vertices; ++v)
      vt[static_cast<size_t>(v)] = (g->mesh.nodes.row(v).transpose() - g->labels.frame.apex).norm() / o.conduction_velocity;
    const double t0 = *std::min_element(vt.begin(), vt.end());
    for (double& t : vt) t -= t0;
  } else if (o.activation == ActivationSource::kHealthy || o.activation == ActivationSource::kLbbb) {
    // The eikonal patterns of docs/models.md s.4.6 on the same mesh, with the fibre frame of each
    // tetrahedron at its centroid (rule of degree 1); the earliest onset is t = 0.
    const auto tet_frames = ellipsoid_fibres(g->mesh, shape, fo, 1);
    const EikonalResult r = solve_eikonal(
        g->mesh, activation_pattern(g->mesh, tet_frames,
                                    o.activation == ActivationSource::kHealthy ? ActivationPattern::kHealthy
                                                                               : ActivationPattern::kLbbb,
                                    pattern_options(o)));
    for (int v = 0; v < g->mesh.n_vertices; ++v) vt[static_cast<size_t>(v)] = r.times(v) - r.earliest;
  }
  g->td = interpolate_vertex_times(*g, vt);
  g->intrinsic_vt = vt;
  return g;
}

// Positions of the parameters in theta.
struct Index {
  int c1, c2, c_exp, b_exp, eta, Es, mu, alpha, k0, k_ATP, k_RS, APD, period, K_at, K_ar, K_p, R_p, R_d, C_p, C_d,
      P_sv, P_at0, P_at_kick, C_cav, n0_slope, n0_e_max;
  std::array<int, kAhaSegments> sigma0;
};

Index make_index(const ParameterSpace& s) {
  Index i{};
  auto at = [&](const char* n) { return s.index_or_throw(n); };
  i.c1 = at("c1"); i.c2 = at("c2"); i.c_exp = at("c_exp"); i.b_exp = at("b_exp"); i.eta = at("eta");
  i.Es = at("Es"); i.mu = at("mu"); i.alpha = at("alpha"); i.k0 = at("k0"); i.k_ATP = at("k_ATP");
  i.k_RS = at("k_RS"); i.APD = at("APD"); i.period = at("period"); i.K_at = at("K_at"); i.K_ar = at("K_ar");
  i.K_p = at("K_p"); i.R_p = at("R_p"); i.R_d = at("R_d"); i.C_p = at("C_p"); i.C_d = at("C_d");
  i.P_sv = at("P_sv"); i.P_at0 = at("P_at0"); i.P_at_kick = at("P_at_kick"); i.C_cav = at("C_cav");
  i.n0_slope = at("n0_slope"); i.n0_e_max = at("n0_e_max");
  for (int k = 0; k < kAhaSegments; ++k) i.sigma0[static_cast<size_t>(k)] = at(("sigma0_" + two_digits(k + 1)).c_str());
  return i;
}

// The model's values unpacked from theta.
struct Model {
  BcsPassiveParameters passive;
  double eta = 0.0, period = 0.0;
  bcs::ActiveParameters act;  // sigma0 per segment below
  std::array<double, kAhaSegments> sigma0{};
  circ::CirculationParameters circ;
  circ::AtrialPressure atrial;
};

Model unpack(const Eigen::Ref<const Eigen::VectorXd>& th, const Index& i, const bcs::ActivationInput& input) {
  Model m;
  m.act.input = input;  // the shape of u(t), LeftVentricle3DOptions::activation_input
  m.passive = {th(i.c1), th(i.c2), th(i.c_exp), th(i.b_exp)};
  m.eta = th(i.eta);
  m.period = th(i.period);
  m.act.Es = th(i.Es);
  m.act.mu = th(i.mu);
  m.act.alpha = th(i.alpha);
  m.act.k0 = th(i.k0);
  m.act.k_ATP = th(i.k_ATP);
  m.act.k_RS = th(i.k_RS);
  m.act.APD = th(i.APD);
  m.act.n0_slope = th(i.n0_slope);
  m.act.n0_e_max = th(i.n0_e_max);
  for (int k = 0; k < kAhaSegments; ++k) m.sigma0[static_cast<size_t>(k)] = th(i.sigma0[static_cast<size_t>(k)]);
  m.circ = {th(i.K_at), th(i.K_ar), th(i.K_p), th(i.R_p), th(i.R_d), th(i.C_p), th(i.C_d), th(i.P_sv), th(i.C_cav)};
  m.atrial.P_at0 = th(i.P_at0);
  m.atrial.P_at_kick = th(i.P_at_kick);
  m.atrial.period = m.period;
  return m;
}

// The unknowns of a step, unpacked from / packed into State::x.
struct Unknowns {
  fem::State ms;  // u, p
  double Pv = 0.0, Par = 0.0, Pd = 0.0;
  std::vector<bcs::ActiveState> act;
  double last_open = 0.0;
};

}  // namespace

struct LeftVentricle3D::Impl {
  std::shared_ptr<const Geometry> geo;
  Index index{};
  // Mechanics with the passive law of the last theta (rebuilt when c1, c2, c_exp, b_exp change).
  std::unique_ptr<Mechanics> mech;
  BcsPassiveParameters mech_passive{-1, -1, -1, -1};
  BaseCondition base = BaseCondition::kSliding;
  LeftVentricle3DOptions options;
  std::unique_ptr<SparseSolver> lu;  // the linear solver of step(): direct (pattern analysed once) or kAmg
  // Factors carried from one step to the next inside run() (LeftVentricle3DOptions::carry_factors):
  // `carry` is set by run() only; `carried` says lu holds the factors of an earlier step of this
  // run, of step length carried_h, with w1 = K^-1 b of that point.
  bool carry = false;
  bool carried = false;
  double carried_h = 0.0;
  Eigen::VectorXd carried_w1;
  // The previous step of this run (carry only): its start point and length, for the first
  // iterate's extrapolation, and the strains at its converged end point (= this step's E^n).
  bool have_history = false;
  Eigen::VectorXd hist_u, hist_p;
  double hist_Pv = 0.0, hist_Par = 0.0, hist_h = 0.0;
  std::vector<Eigen::Matrix3d> hist_E;
  int factorizations = 0;  // since the start of the run, for RunInfo::factorizations
  long long linear_iterations = 0;  // GMRES iterations since the start of the run (RunInfo)

  Mechanics& mechanics(const BcsPassiveParameters& p) {
    if (!mech || p.c1 != mech_passive.c1 || p.c2 != mech_passive.c2 || p.c_exp != mech_passive.c_exp ||
        p.b_exp != mech_passive.b_exp) {
      MechanicsOptions mo;
      mo.bulk_modulus = options.bulk_modulus;
      mo.pressure_stabilization = options.pressure_stabilization;
      mo.grad_div = options.grad_div;
      mo.quadrature_degree = options.quadrature_degree;
      mo.pressure_surfaces = {kEndocardium};
      mo.load_steps = options.inflation_steps;
      mo.max_newton_iterations = 30;
      mo.linear_solver = options.linear_solver;
      mech = std::make_unique<Mechanics>(geo->mesh, geo->frames, std::make_unique<BcsPassive>(p), mo);
      mech->apply_base_condition(kBase, base);
      mech_passive = p;
    }
    return *mech;
  }

  int nq() const { return geo->mesh.n_tets() * geo->nqp; }
  Eigen::Index nu() const { return 3 * static_cast<Eigen::Index>(geo->mesh.n_nodes()); }
  Eigen::Index np() const { return geo->mesh.n_vertices; }
  Eigen::Index state_size() const { return nu() + np() + 3 + 3 * static_cast<Eigen::Index>(nq()) + 1; }

  Unknowns unpack_state(const Eigen::VectorXd& x) const {
    Unknowns k;
    Eigen::Index o = 0;
    k.ms.u = x.segment(o, nu());
    o += nu();
    k.ms.p = x.segment(o, np());
    o += np();
    k.Pv = x(o++);
    k.Par = x(o++);
    k.Pd = x(o++);
    const int n = nq();
    k.act.resize(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) k.act[static_cast<size_t>(i)].e_c = x(o + i);
    for (int i = 0; i < n; ++i) k.act[static_cast<size_t>(i)].k_c = x(o + n + i);
    for (int i = 0; i < n; ++i) k.act[static_cast<size_t>(i)].tau_c = x(o + 2 * n + i);
    k.last_open = x(x.size() - 1);
    return k;
  }

  Eigen::VectorXd pack_state(const Unknowns& k) const {
    Eigen::VectorXd x(state_size());
    Eigen::Index o = 0;
    x.segment(o, nu()) = k.ms.u;
    o += nu();
    x.segment(o, np()) = k.ms.p;
    o += np();
    x(o++) = k.Pv;
    x(o++) = k.Par;
    x(o++) = k.Pd;
    const int n = nq();
    for (int i = 0; i < n; ++i) {
      x(o + i) = k.act[static_cast<size_t>(i)].e_c;
      x(o + n + i) = k.act[static_cast<size_t>(i)].k_c;
      x(o + 2 * n + i) = k.act[static_cast<size_t>(i)].tau_c;
    }
    x(x.size() - 1) = k.last_open;
    return x;
  }

  Eigen::MatrixX3d positions(const Eigen::VectorXd& u) const {
    Eigen::MatrixX3d x = geo->mesh.nodes;
    for (Eigen::Index n = 0; n < x.rows(); ++n) x.row(n) += u.segment<3>(3 * n).transpose();
    return x;
  }

  // Green-Lagrange strain at every quadrature point of (u, p) (one residual assembly).
  bool strains(Mechanics& mc, const fem::State& s, std::vector<Eigen::Matrix3d>& E) const {
    E.resize(static_cast<size_t>(nq()));
    const int nqp = geo->nqp;
    const StressHook record = [&](int e, int q, const Eigen::Matrix3d& Eq, const Frame&, Eigen::Matrix3d&, Matrix9d&) {
      E[static_cast<size_t>(e * nqp + q)] = Eq;
    };
    Eigen::VectorXd R;
    return mc.assemble(s, Load{}, &R, nullptr, record);
  }

  int step(const Model& m, const Unknowns& xo, double t0, double t1, Unknowns& xn);
};

namespace {

// The direction tensor T of the active stress S_act = sigma_1D T (ActiveStress): f0 (x) f0, or the
// average (f0 (x) f0 + s0 (x) s0)/2 of f (x) f over the tangent plane.
Eigen::Matrix3d active_direction(const Frame& R, ActiveStress a) {
  const Eigen::Vector3d f = R.col(0);
  if (a == ActiveStress::kFibre) return f * f.transpose();
  const Eigen::Vector3d s = R.col(1);
  return 0.5 * (f * f.transpose() + s * s.transpose());
}

// The strain e = T : E that drives the BCS law (kFibre: f0 . E f0, written as before for the same
// bits; kTangentIsotropic: the mean (f0 . E f0 + s0 . E s0)/2).
double active_strain(const Frame& R, const Eigen::Matrix3d& E, ActiveStress a) {
  const Eigen::Vector3d f = R.col(0);
  if (a == ActiveStress::kFibre) return f.dot(E * f);
  const Eigen::Vector3d s = R.col(1);
  return 0.5 * (f.dot(E * f) + s.dot(E * s));
}

// The symmetric identity on 3x3 tensors, (delta_ik delta_jl + delta_il delta_jk)/2: dS = eta/h dE
// for the viscous stress, in the minor-symmetric form the mechanics' tangent expects.
const Matrix9d& symmetric_identity() {
  static const Matrix9d I = tensor_sym_product(Eigen::Matrix3d::Identity());
  return I;
}

}  // namespace

// One backward-Euler step from xo at t0 to t1 (module comment). Returns the Newton iterations, or
// -1 when Newton failed (the caller cuts the step).
int LeftVentricle3D::Impl::step(const Model& m, const Unknowns& xo, double t0, double t1, Unknowns& xn) {
  const Geometry& g = *geo;
  Mechanics& mc = mechanics(m.passive);
  const double h = t1 - t0;
  const int n = nq();
  const int nqp = g.nqp;
  const Eigen::Index nu_ = nu(), np_ = np(), nx = nu_ + np_;

  // E^n: the strains of the first evaluation below, which is at u^n (no viscous stress there);
  // within a run, those of the previous step's converged point, which is u^n, and the first
  // iterate is extrapolated from the last two steps' start points.
  const bool predict = carry && have_history && hist_h > 0.0 && static_cast<int>(hist_E.size()) == n;
  have_history = false;
  std::vector<Eigen::Matrix3d> En = predict ? std::move(hist_E) : std::vector<Eigen::Matrix3d>(static_cast<size_t>(n));
  std::vector<Eigen::Matrix3d> Elast;  // the strains of the latest evaluation (carry only)
  if (carry) Elast.resize(static_cast<size_t>(n));
  bool first_evaluation = !predict;
  std::vector<bcs::StepActivation> acts(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) acts[static_cast<size_t>(i)] = bcs::step_activation(t0, t1, g.td[static_cast<size_t>(i)], m.period, m.act);
  std::vector<bcs::ActiveState> trial(static_cast<size_t>(n));
  std::atomic<bool> local_failed{false};
  const double eta_h = m.eta / h;
  bool want_tangent = true;  // of the current evaluation (D is not read in residual-only assemblies)
  const StressHook hook = [&](int e, int q, const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) {
    const size_t i = static_cast<size_t>(e * nqp + q);
    if (first_evaluation) En[i] = E;
    if (carry) Elast[i] = E;
    const Eigen::Matrix3d ff = active_direction(R, options.active_stress);
    const double eff = active_strain(R, E, options.active_stress);
    bcs::ActiveParameters ap = m.act;
    ap.sigma0 = m.sigma0[static_cast<size_t>(g.labels.element_segment[static_cast<size_t>(e)] - 1)];
    bcs::CondensedStep cs;
    if (!bcs::condense_step(ap, xo.act[i], eff, acts[i], h, cs)) local_failed.store(true, std::memory_order_relaxed);
    trial[i] = cs.state;
    S += cs.stress * ff + eta_h * (E - En[i]);
    if (!want_tangent) return;
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vff(ff.data());  // symmetric: any vec order
    D.noalias() += cs.tangent * (vff * vff.transpose());
    D += eta_h * symmetric_identity();
  };

  const double P_at = m.atrial(t1);
  // Distal Windkessel solved exactly for P_d given P_ar (as the lumped models, shell.h).
  const double Pd_den = m.circ.C_d / h + 1.0 / m.circ.R_p + 1.0 / m.circ.R_d;
  const double Pd_rhs = m.circ.C_d / h * xo.Pd + m.circ.P_sv / m.circ.R_d;
  const double dPd_dPar = 1.0 / (m.circ.R_p * Pd_den);
  const double V_old = cavity_volumes(g.mesh, positions(xo.ms.u), g.labels).cavity;

  // Evaluation at a trial point: residuals, tangent and the bordering terms.
  struct Eval {
    fem::State ms;
    double Pv = 0, Par = 0, Pd = 0;
    Eigen::VectorXd R;
    SparseMatrix K;
    bool has_K = false;  // K assembled (the line search's candidates skip it until a factorisation needs it)
    Eigen::VectorXd b;  // dR_x/dP_v (pressure rows zero)
    Eigen::VectorXd gV; // dr_c/dx = dV/du / h (fixed dofs and pressure rows zero)
    double rc = 0, rar = 0, c11 = 0, c12 = 0, c21 = 0, c22 = 0;
    double merit = 0, scaled_max = 0;
    std::vector<bcs::ActiveState> act;
  };
  const double fv = h / kVref;  // cavity and Windkessel rows scaled to volumes over the step
  auto evaluate = [&](Eval& ev, bool with_tangent) -> bool {
    local_failed = false;
    ev.has_K = with_tangent;
    want_tangent = with_tangent;
    if (!mc.assemble(ev.ms, Load{ev.Pv, 0.0}, &ev.R, with_tangent ? &ev.K : nullptr, hook)) return false;
    if (local_failed) return false;
    ev.act = trial;
    const CavityVolumes cv = cavity_volumes(g.mesh, positions(ev.ms.u), g.labels, true);
    ev.b = Eigen::VectorXd::Zero(nx);
    ev.b.head(nu_) = mc.pressure_load(ev.ms);
    ev.gV = Eigen::VectorXd::Zero(nx);
    for (Eigen::Index k = 0; k < nu_; ++k)
      if (!mc.is_fixed(static_cast<int>(k))) ev.gV(k) = cv.gradient(k) / h;
    const circ::ValveFlow q = circ::valve_flow(ev.Pv, ev.Par, P_at, m.circ);
    ev.Pd = (Pd_rhs + ev.Par / m.circ.R_p) / Pd_den;
    const circ::WindkesselResidual w = circ::windkessel_residual(ev.Par, ev.Pd, xo.Par, xo.Pd, q.q_ar, h, m.circ);
    ev.rc = m.circ.C_cav * (ev.Pv - xo.Pv) / h + q.q + (cv.cavity - V_old) / h;
    ev.c11 = m.circ.C_cav / h + q.dq_dPv;
    ev.c12 = q.dq_dPar;
    ev.rar = w.r_ar;
    ev.c21 = -q.dqar_dPv;
    ev.c22 = w.dar_dPar + w.dar_dPd * dPd_dPar - q.dqar_dPar;
    const double ru = ev.R.head(nu_).cwiseAbs().maxCoeff() / g.force_ref;
    const double rp = ev.R.tail(np_).cwiseAbs().maxCoeff() / g.volume_ref;
    const double rc = std::abs(ev.rc) * fv, rar = std::abs(ev.rar) * fv;
    ev.scaled_max = std::max({ru, rp, rc, rar});
    ev.merit = (ev.R.head(nu_) / g.force_ref).squaredNorm() + (ev.R.tail(np_) / g.volume_ref).squaredNorm() +
               rc * rc + rar * rar;
    return std::isfinite(ev.merit);
  };

  // Factors carried from the previous step of this run (same step length): the step starts
  // with them as stale chord factors, and its first iterate is assembled without the tangent.
  const bool use_carried = carry && carried && carried_h == h;
  carried = false;
  Eval cur;
  cur.ms = xo.ms;
  cur.Pv = xo.Pv;
  cur.Par = xo.Par;
  if (predict) {
    const double r = h / hist_h;
    cur.ms.u += r * (xo.ms.u - hist_u);
    cur.ms.p += r * (xo.ms.p - hist_p);
    cur.Pv += r * (xo.Pv - hist_Pv);
    cur.Par += r * (xo.Par - hist_Par);
  }
  if (options.pressure_stabilization > 0 || options.grad_div > 0) {
    // tau of the stabilisation and gamma of the grad-div term from the step's start point u^n with
    // this step's active and viscous stiffness (Mechanics::update_stabilization): a function of the
    // step's inputs, the same in run() and advance(). The hook's side effects are harmless here: E^n
    // is u^n's strain either way, and the evaluations below overwrite the trial states. u^n is a
    // converged point (every J > 0), so the assembly succeeds; a BCS state the hook rejects is the
    // evaluations' to report.
    want_tangent = true;
    mc.update_stabilization(xo.ms, Load{xo.Pv, 0.0}, hook);
  }
  if (!evaluate(cur, !use_carried)) {
    if (!predict) return -1;
    cur.ms = xo.ms;  // an extrapolation too far (e.g. an inverted element): start from u^n
    cur.Pv = xo.Pv;
    cur.Par = xo.Par;
    if (!evaluate(cur, !use_carried)) return -1;
  }
  first_evaluation = false;
  // Newton's method with the factors of the tangent kept while they still contract the residual
  // fast (a chord iteration, Kelley 2003, Solving Nonlinear Equations with Newton's Method, s.2.3):
  // the LU factorisation costs ~20 assemblies on the quadratic meshes, so the tangent is
  // refactorised only when an update reduced the merit (squared scaled residual) by less than 100
  // or failed. On linear tetrahedra the factorisation weighs more against the cheap one-point
  // assembly, and a reduction by less than 10 is the threshold (fine mesh, one beat: 80.6 s and
  // 1275 Newton iterations against 90.8 s and 860 at 100; 2 gave 131 s with 36 step cuts). The
  // factorisation is redone at every step's first iteration of advance(), so a step there is a
  // pure function of its inputs (replay lands on the same bits); run() carries the factors from
  // step to step (carry_factors; deterministic in theta).
  const double refactor_ratio = g.mesh.order == 1 ? 0.1 : 0.01;
  // The direct solvers analyse the pattern only (the same for every step; solver.h), so one
  // analysis serves the object's life and every factorisation is a function of the tangent alone.
  // UMFPACK's BLAS kernels round differently with the alignment of its workspace, so its runs in
  // different threads differ by about 1e-6 relative: SparseLU is the default for bitwise
  // reproducible runs. The iterative solver (kAmg, solver.h) is carried the same way: its "factors"
  // are the frozen tangent and the preconditioner set up on it (the AMG hierarchy and the Schur
  // approximation), which depend on the tangent alone (hypre serial, no OpenMP), so it gives the
  // same bits in every thread.
  if (!lu) {
    IterativeOptions io = iterative_options_for(mc.options());
    io.relative_tolerance = options.linear_tolerance;
    if (options.exact_displacement_solve) io.displacement = IterativeOptions::Displacement::kExact;
    lu = std::make_unique<SparseSolver>(options.linear_solver, io);
    lu->set_saddle_point(static_cast<int>(nu_));
    if (options.coarse_correction)
      lu->set_coarse_space(ellipsoid_coarse_space(
          g.mesh, options.geometry,
          ellipsoid_coarse_options(options.n_transmural, options.n_longitudinal, options.n_circumferential,
                                   options.grad_div > 0 ? CoarseGrid::kHalfMesh : CoarseGrid::kWallModes)));
  }
  SparseSolver& solver = *lu;
  bool factors_fresh = false;  // the factors belong to the current point
  bool have_factors = use_carried;
  Eigen::VectorXd w1;  // K^-1 b at the point of the factorisation
  if (use_carried) w1 = std::move(carried_w1);
  // Broyden's method on the chord directions (below): the full steps taken since the last
  // factorisation, and the scaled inner product of the unknowns (u / 1 mm, pressures / 1 kPa).
  std::vector<Eigen::VectorXd> steps;
  std::vector<double> steps_n2;
  auto wdot = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return a.head(nu_).dot(b.head(nu_)) / (kLref * kLref) + a.tail(np_ + 2).dot(b.tail(np_ + 2)) / (kPref * kPref);
  };
  const double tol = options.newton_tolerance;
  int iterations = 0;
  while (iterations <= options.newton_max_iterations) {
    if (cur.scaled_max <= tol) {
      xn = xo;
      xn.ms = cur.ms;
      xn.Pv = cur.Pv;
      xn.Par = cur.Par;
      xn.Pd = cur.Pd;
      xn.act = std::move(cur.act);
      if (carry) {
        // The last evaluation was at cur (accepted candidates end the line search; a refactorisation
        // re-evaluates cur), so Elast holds the strains of the converged point.
        have_history = true;
        hist_u = xo.ms.u;
        hist_p = xo.ms.p;
        hist_Pv = xo.Pv;
        hist_Par = xo.Par;
        hist_h = h;
        hist_E = std::move(Elast);
      }
      if (carry && have_factors) {
        carried = true;
        carried_h = h;
        carried_w1 = std::move(w1);
      }
      return iterations;
    }
    if (iterations == options.newton_max_iterations) break;
    ++iterations;
    if (!have_factors) {
      // The same point again, now with its tangent: the residual and the trial states come out
      // bit for bit as before (the assembly is a pure function of the point).
      if (!cur.has_K && !evaluate(cur, true)) return -1;
      ++factorizations;
      if (options.grad_div > 0) solver.set_schur_mass(mc.schur_mass());
      if (!solver.factorize(cur.K)) return -1;
      have_factors = factors_fresh = true;
      steps.clear();
      steps_n2.clear();
    }
    // Bordered system [K b 0; g^T c11 c12; 0 c21 c22] (dx, dPv, dPar) = -(R, rc, rar), by the Schur
    // complement on K's factors: dx = w0 - w1 dPv. The chord iteration freezes the column b with K
    // (w1 = K^-1 b solved once per factorisation: one triangular solve pair per iteration instead
    // of two); the cavity and Windkessel rows stay current, so the valves' switching is followed.
    if (factors_fresh) {
      w1 = solver.solve(cur.b);
      linear_iterations += solver.iterative_stats().last_iterations;
      if (!w1.allFinite()) return -1;
    }
    const Eigen::VectorXd w0 = solver.solve(-cur.R);
    linear_iterations += solver.iterative_stats().last_iterations;
    if (!w0.allFinite()) return -1;
    Eigen::Matrix2d A;
    A << cur.c11 - cur.gV.dot(w1), cur.c12, cur.c21, cur.c22;
    const Eigen::Vector2d rhs(-cur.rc - cur.gV.dot(w0), -cur.rar);
    const Eigen::Vector2d dP = A.fullPivLu().solve(rhs);
    if (!dP.allFinite()) return -1;
    // d = (du, dp, dP_v, dP_ar): the Newton direction with fresh factors, the chord direction
    // -J0^-1 F(x) with stale ones (K and b frozen, the cavity and Windkessel rows current).
    Eigen::VectorXd d(nx + 2);
    d << w0 - w1 * dP(0), dP;
    // With stale factors, Broyden's ("good") method on G(x) = J0^-1 F(x), whose Jacobian the chord
    // takes to be the identity: the inverse of each rank-one update is applied to the chord
    // direction through the steps taken since the factorisation (Kelley 1995, Iterative Methods
    // for Linear and Nonlinear Equations, SIAM, s.7.3, alg. brsol; Sherman-Morrison form), in
    // the scaled inner product above. The chord's linear contraction becomes superlinear: fewer
    // residual assemblies and solves per step (docs/solvers.md s.1). A denominator near
    // zero drops the history (plain chord direction).
    if (!factors_fresh && options.broyden && !steps.empty()) {
      Eigen::VectorXd z = d;
      for (size_t j = 0; j + 1 < steps.size(); ++j) z += steps[j + 1] * (wdot(steps[j], z) / steps_n2[j]);
      const double den = 1.0 - wdot(steps.back(), z) / steps_n2.back();
      if (std::abs(den) > 1e-2 && z.allFinite()) {
        d = z / den;
      } else {
        steps.clear();
        steps_n2.clear();
      }
    }
    // Backtracking on the scaled residual (Dennis & Schnabel 1996, alg. A6.3.1); with stale factors
    // a failed full step refactorises instead.
    bool accepted = false;
    double lambda = 1.0;
    const int max_halvings = factors_fresh ? 10 : 1;
    for (int ls = 0; ls < max_halvings && !accepted; ++ls, lambda *= 0.5) {
      Eval cand;
      cand.ms.u = cur.ms.u + lambda * d.head(nu_);
      cand.ms.p = cur.ms.p + lambda * d.segment(nu_, np_);
      cand.Pv = cur.Pv + lambda * d(nx);
      cand.Par = cur.Par + lambda * d(nx + 1);
      if (!evaluate(cand, false)) continue;
      if (cand.merit <= (1.0 - 1e-4 * lambda) * cur.merit) {
        accepted = true;
        // Slow contraction: refactorise at the new point.
        if (cand.merit > refactor_ratio * cur.merit) have_factors = false;
      } else if (factors_fresh) {
        // Relative step test (Dennis & Schnabel 1996, s.7.2): an update lost in the rounding of
        // the unknowns ends the solve even when rounding keeps the residual above tol.
        const double step = std::max({lambda * d.head(nu_).cwiseAbs().maxCoeff() / kLref,
                                      lambda * d.segment(nu_, np_).cwiseAbs().maxCoeff() / kPref,
                                      lambda * std::abs(d(nx)) / kPref, lambda * std::abs(d(nx + 1)) / kPref});
        if (step <= 1e-3 * tol && cand.scaled_max <= 1e3 * tol) {
          cand.scaled_max = 0.0;  // converged by the step test
          accepted = true;
        }
      }
      if (accepted) {
        cur = std::move(cand);
        factors_fresh = false;
        // Broyden's recursion holds for full steps only: a shortened one starts a new history.
        if (lambda == 1.0) {
          steps.push_back(d);
          steps_n2.push_back(wdot(d, d));
        } else {
          steps.clear();
          steps_n2.clear();
        }
      }
    }
    if (!accepted) {
      if (factors_fresh) return -1;
      have_factors = false;  // stale factors: refactorise at the current point and retry
    }
  }
  return -1;
}

// ---------------------------------------------------------------------------------------------
// Parameters and channels.

ParameterSpace LeftVentricle3D::default_parameters() {
  const ParameterSpace sphere = lumped::LumpedSphere::default_parameters();
  std::vector<Parameter> out;
  // The sphere's parameters by name, minus its geometry (rho, R0, d0) and its single sigma0.
  for (const Parameter& p : sphere.all()) {
    if (p.name == "rho" || p.name == "R0" || p.name == "d0" || p.name == "sigma0") continue;
    out.push_back(p);
  }
  auto set = [&](const std::string& name, double value, const std::string& doc) {
    for (Parameter& p : out)
      if (p.name == name) {
        p.nominal = value;
        p.doc = doc;
        return;
      }
    throw std::logic_error("LeftVentricle3D::default_parameters: no parameter " + name);
  };
  // 3D values where the sphere's tuning does not carry over (docs/models.md s.4.8).
  set("c1", 600.0, "passive Mooney-Rivlin c1 on the isochoric invariants [T3D: EDV ~150 mL at P_at0 on the coarse mesh]");
  set("c2", 900.0, "passive Mooney-Rivlin c2 [T3D: with c1, c_exp]");
  set("c_exp", 600.0, "exponential passive stiffening c_exp (exp(b_exp (Ibar1 - 3)^2) - 1) [T3D]");
  set("eta", 70.0, "parallel viscosity of S_visc = eta dE/dt [C14 working set value, 3D form of Chapelle 2012]");
  const Parameter s0 = sphere[sphere.index_or_throw("sigma0")];
  for (int k = 1; k <= kAhaSegments; ++k) {
    Parameter p = s0;
    p.name = "sigma0_" + two_digits(k);
    p.nominal = 8.0e4;
    p.doc = "contractility (maximal active stress) of the wall in AHA segment " + std::to_string(k) +
            " [T3D: EF ~47 % on the coarse mesh, periodic beat]";
    p.family = "contractility";
    p.segment = k;
    out.push_back(p);
  }
  return ParameterSpace(std::move(out));
}

std::vector<Channel> LeftVentricle3D::channels() const {
  std::vector<Channel> c = shell::circulation_channels();
  c[0].doc = "left-ventricular cavity volume (endocardium closed by the base-ring lid)";
  for (int k = 1; k <= kAhaSegments; ++k)
    c.push_back({"V_seg" + two_digits(k), "m^3", "cavity volume of AHA segment " + std::to_string(k) + " (docs/models.md s.5)",
                 "regional_volume", k});
  return c;
}

std::vector<Channel> LeftVentricle3D::state_layout() const {
  std::vector<Channel> s;
  const Geometry& g = *impl_->geo;
  s.reserve(static_cast<size_t>(impl_->state_size()));
  const char* xyz[] = {"x", "y", "z"};
  for (int n = 0; n < g.mesh.n_nodes(); ++n)
    for (int d = 0; d < 3; ++d) s.push_back({"u" + std::string(xyz[d]) + "_" + std::to_string(n), "m", "displacement"});
  for (int v = 0; v < g.mesh.n_vertices; ++v) s.push_back({"p_" + std::to_string(v), "Pa", "hydrostatic pressure"});
  s.push_back({"P_v", "Pa", "cavity pressure"});
  s.push_back({"P_ar", "Pa", "proximal arterial pressure"});
  s.push_back({"P_d", "Pa", "distal arterial pressure"});
  const int n = impl_->nq();
  for (int i = 0; i < n; ++i) s.push_back({"e_c_" + std::to_string(i), "1", "contractile strain"});
  for (int i = 0; i < n; ++i) s.push_back({"k_c_" + std::to_string(i), "Pa", "active stiffness"});
  for (int i = 0; i < n; ++i) s.push_back({"tau_c_" + std::to_string(i), "Pa", "active stress"});
  s.push_back(shell::last_open_valve_entry());
  return s;
}

// ---------------------------------------------------------------------------------------------
LeftVentricle3D::LeftVentricle3D(LeftVentricle3DOptions options, ParameterSpace parameters)
    : options_(std::move(options)), parameters_(std::move(parameters)), impl_(std::make_unique<Impl>()) {
  if (auto msg = options_.validate(); !msg.empty()) throw std::invalid_argument("LeftVentricle3DOptions: " + msg);
  impl_->options = options_;
  impl_->base = options_.base;
  impl_->geo = build_geometry(options_);
  impl_->index = make_index(parameters_);
  // Builds the mechanics once: a mesh with an inverted element is refused here, not in run().
  impl_->mechanics(unpack(parameters_.nominal(), impl_->index, options_.activation_input).passive);
}

LeftVentricle3D::LeftVentricle3D(LeftVentricle3DOptions options)
    : LeftVentricle3D(std::move(options), default_parameters()) {}

LeftVentricle3D::~LeftVentricle3D() = default;

LeftVentricle3D::LeftVentricle3D(const LeftVentricle3D& other, int)
    : options_(other.options_), parameters_(other.parameters_), impl_(std::make_unique<Impl>()) {
  impl_->options = other.impl_->options;
  impl_->base = other.impl_->base;
  impl_->geo = other.impl_->geo;  // immutable, shared
  impl_->index = other.impl_->index;
}

std::unique_ptr<Simulator> LeftVentricle3D::clone() const {
  auto c = std::unique_ptr<LeftVentricle3D>(new LeftVentricle3D(*this, 0));
  return c;
}

const Mesh& LeftVentricle3D::mesh() const { return impl_->geo->mesh; }
const AhaLabels& LeftVentricle3D::labels() const { return impl_->geo->labels; }
int LeftVentricle3D::n_quadrature_points() const { return impl_->nq(); }
const std::vector<double>& LeftVentricle3D::activation_times() const { return impl_->geo->td; }

void LeftVentricle3D::set_activation_times(const std::vector<double>& vertex_times) {
  const Geometry& g = *impl_->geo;
  if (vertex_times.size() != static_cast<size_t>(g.mesh.n_vertices))
    throw std::invalid_argument("set_activation_times: need one time per mesh vertex (" +
                                std::to_string(g.mesh.n_vertices) + "), got " + std::to_string(vertex_times.size()));
  for (double t : vertex_times)
    if (!std::isfinite(t) || t < 0) throw std::invalid_argument("set_activation_times: times must be finite and >= 0 s");
  auto geo = std::make_shared<Geometry>(g);
  geo->td = interpolate_vertex_times(*geo, vertex_times);
  geo->intrinsic_vt = vertex_times;
  impl_->geo = std::move(geo);
  options_.activation = ActivationSource::kPrescribed;
  impl_->options.activation = ActivationSource::kPrescribed;
}

activation::PacingOutcome LeftVentricle3D::pace(const activation::PacingPlan& plan) {
  const Geometry& g = *impl_->geo;
  // The intrinsic onsets: the eikonal pattern itself (so that scar changes its course too), or one
  // onset per vertex at the intrinsic times (synchronous, apex distance, prescribed times) with the
  // myocardial velocities of the patterns for the paced wave.
  FibreOptions fo;
  fo.alpha_endo_deg = options_.fibre_endo_deg;
  fo.alpha_epi_deg = options_.fibre_epi_deg;
  const auto tet_frames = ellipsoid_fibres(g.mesh, options_.geometry, fo, 1);
  EikonalOptions intrinsic;
  if (options_.activation == ActivationSource::kHealthy || options_.activation == ActivationSource::kLbbb) {
    intrinsic = activation_pattern(g.mesh, tet_frames,
                                   options_.activation == ActivationSource::kHealthy ? ActivationPattern::kHealthy
                                                                                     : ActivationPattern::kLbbb,
                                   pattern_options(options_));
  } else {
    intrinsic.frames = tet_frames;
    intrinsic.velocities = {pattern_options(options_).myocardium};
    for (int v = 0; v < g.mesh.n_vertices; ++v) intrinsic.vertex_onsets.push_back({v, g.intrinsic_vt[static_cast<size_t>(v)]});
  }
  const PacedActivation paced = paced_activation(g.mesh, g.labels, intrinsic, plan);
  std::vector<double> vt(paced.vertex_times.data(), paced.vertex_times.data() + paced.vertex_times.size());
  auto geo = std::make_shared<Geometry>(g);
  geo->td = interpolate_vertex_times(*geo, vt);  // on the intrinsic clock: may be negative (check_theta)
  impl_->geo = std::move(geo);
  return paced.outcome;
}

Status LeftVentricle3D::check_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (theta.size() != parameters_.size()) {
    std::ostringstream s;
    s << "theta has " << theta.size() << " entries, expected " << parameters_.size();
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  if (const std::string msg = parameters_.check(theta); !msg.empty()) return Status::Error(StatusCode::kOutOfBounds, msg);
  const Model m = unpack(theta, impl_->index, options_.activation_input);
  if (m.act.APD >= m.period) return Status::Error(StatusCode::kOutOfBounds, "APD must be shorter than the period");
  if (options_.dt > m.period / 20) {
    std::ostringstream s;
    s << "dt = " << options_.dt << " s must be <= period / 20 = " << m.period / 20 << " s";
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  const auto [td_min, td_max] = std::minmax_element(impl_->geo->td.begin(), impl_->geo->td.end());
  // Paced activation (pace()) may start before the intrinsic onset: times down to -period are the
  // same periodic windows (bcs::step_activation works for any T_d).
  if (*td_max >= m.period || *td_min <= -m.period) {
    std::ostringstream s;
    s << "the activation times " << *td_min << " .. " << *td_max << " s are not inside one period (" << m.period
      << " s) of the onset";
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  return Status::Ok();
}

void LeftVentricle3D::write_fields(const model::State& state, std::ostream& os) { field_document(state).write(os); }

VtuDocument LeftVentricle3D::field_document(const model::State& state) {
  if (state.x.size() != impl_->state_size())
    throw std::invalid_argument("field_document: the state has " + std::to_string(state.x.size()) +
                                " entries, expected " + std::to_string(impl_->state_size()));
  const Geometry& g = *impl_->geo;
  const Unknowns k = impl_->unpack_state(state.x);
  VtuDocument doc(g.mesh);
  doc.set_points(impl_->positions(k.ms.u));
  doc.add_point_data("displacement", k.ms.u, 3);
  doc.add_vertex_data("hydrostatic_pressure", k.ms.p);
  // The strain is kinematic: any passive law of the mechanics gives the same E.
  std::vector<Eigen::Matrix3d> E;
  const bool have_strain = impl_->mech && impl_->strains(*impl_->mech, k.ms, E);
  const int n_tets = g.mesh.n_tets(), nqp = g.nqp;
  Eigen::VectorXd td(n_tets), tau(n_tets), eff(n_tets), fibre(3 * static_cast<Eigen::Index>(n_tets));
  for (int e = 0; e < n_tets; ++e) {
    double t_sum = 0.0, tau_sum = 0.0, e_sum = 0.0;
    Eigen::Vector3d f_sum = Eigen::Vector3d::Zero();
    for (int q = 0; q < nqp; ++q) {
      const size_t i = static_cast<size_t>(e * nqp + q);
      const Eigen::Vector3d f = g.frames[i].col(0);
      t_sum += g.td[i];
      tau_sum += k.act[i].tau_c;
      if (have_strain) e_sum += f.dot(E[i] * f);
      f_sum += f;
    }
    td(e) = t_sum / nqp;
    tau(e) = tau_sum / nqp;
    eff(e) = have_strain ? e_sum / nqp : std::numeric_limits<double>::quiet_NaN();
    fibre.segment<3>(3 * e) = f_sum.normalized();
  }
  doc.add_cell_data("activation_time", td);
  doc.add_cell_data("active_stress", tau);
  doc.add_cell_data("fibre_strain", eff);
  doc.add_cell_data("fibre", fibre, 3);
  doc.add_cell_labels("aha_segment", g.labels.element_segment);
  // The boundary surfaces as point labels (1 on the surface's nodes): `sigmaheart observe` finds the
  // endocardium of these files with endocardium: {point_label: endocardium} (docs/models.md s.5.1).
  for (const auto& [name, tag] : {std::pair<const char*, int>{"endocardium", kEndocardium}, {"base", kBase}}) {
    Eigen::VectorXd on = Eigen::VectorXd::Zero(g.mesh.n_nodes());
    for (int n : g.mesh.nodes_with_tag(tag)) on(n) = 1.0;
    doc.add_point_data(name, on);
  }
  return doc;
}

model::State LeftVentricle3D::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  model::State st;
  st.time = 0.0;
  if (!check_theta(theta).ok()) {
    st.x = Eigen::VectorXd::Constant(impl_->state_size(), std::numeric_limits<double>::quiet_NaN());
    return st;
  }
  const Model m = unpack(theta, impl_->index, options_.activation_input);
  Mechanics& mech = impl_->mechanics(m.passive);
  Unknowns k;
  k.ms = mech.initial_state();
  const double P0 = m.atrial(0.0);
  const Summary sum = mech.solve(k.ms, Load{}, Load{P0, 0.0});
  k.Pv = P0;
  // Arteries at typical diastolic pressures; the beats settle from there (as the lumped models).
  k.Par = std::max(P0, 75.0 * 133.322);
  k.Pd = std::max(P0, 70.0 * 133.322);
  k.last_open = static_cast<double>(circ::ValveRegime::kFilling);
  std::vector<Eigen::Matrix3d> E;
  const bool ok = sum.converged && impl_->strains(mech, k.ms, E);
  // Relaxed contractile elements: e_c equals the fibre strain, so the active stress is zero.
  k.act.assign(static_cast<size_t>(impl_->nq()), bcs::ActiveState{});
  const auto& frames = impl_->geo->frames;
  for (size_t i = 0; ok && i < k.act.size(); ++i) k.act[i].e_c = active_strain(frames[i], E[i], options_.active_stress);
  st.x = impl_->pack_state(k);
  if (!ok) st.x.setConstant(std::numeric_limits<double>::quiet_NaN());
  return st;
}

Status LeftVentricle3D::step_to(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end,
                                int* newton_iterations, int* step_cuts) {
  const Model m = unpack(theta, impl_->index, options_.activation_input);
  Unknowns x = impl_->unpack_state(state.x);
  double t = state.time;
  while (t < t_end) {
    const double t1 = shell::next_time(t, t_end, options_.dt, m.period);
    if (!(t1 > t)) {
      std::ostringstream s;
      s << "time step " << options_.dt << " s is below the resolution of t = " << t << " s";
      return Status::Error(StatusCode::kInvalidArgument, s.str());
    }
    Unknowns xn;
    bool done = false;
    for (int cut = 0; cut <= options_.max_step_cuts && !done; ++cut) {
      const int nsub = 1 << cut;
      Unknowns xs = x;
      bool ok = true;
      for (int k = 0; k < nsub && ok; ++k) {
        const double ta = t + (t1 - t) * k / nsub;
        const double tb = (k + 1 == nsub) ? t1 : t + (t1 - t) * (k + 1) / nsub;
        Unknowns xk;
        const int its = impl_->step(m, xs, ta, tb, xk);
        if (its < 0) {
          ok = false;
        } else {
          xs = std::move(xk);
          if (newton_iterations) *newton_iterations += its;
        }
      }
      if (ok) {
        xn = std::move(xs);
        done = true;
        if (cut > 0 && step_cuts) *step_cuts += cut;
      }
    }
    if (!done) {
      state.x = impl_->pack_state(x);
      state.time = t;
      const double V = cavity_volumes(impl_->geo->mesh, impl_->positions(x.ms.u), impl_->geo->labels).cavity;
      std::ostringstream s;
      s << "Newton did not converge at t = " << t1 << " s after " << options_.max_step_cuts
        << " step halvings (V = " << V * 1e6 << " mL, P_v = " << x.Pv / 133.322 << " mmHg)";
      return Status::Error(StatusCode::kDiverged, s.str());
    }
    const auto regime = circ::valve_flow(xn.Pv, xn.Par, m.atrial(t1), m.circ).regime;
    if (regime != circ::ValveRegime::kClosed) xn.last_open = static_cast<double>(regime);
    x = std::move(xn);
    t = t1;
  }
  state.x = impl_->pack_state(x);
  state.time = t_end;
  return Status::Ok();
}

Status LeftVentricle3D::advance(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end) {
  try {
    return advance_checked(state, theta, t_end);
  } catch (const std::exception& e) {  // never thrown for a valid set-up; a Status, not a crash
    return Status::Error(StatusCode::kInvalidArgument, std::string("lv-3d: ") + e.what());
  }
}

Status LeftVentricle3D::advance_checked(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                                        double t_end) {
  if (Status s = check_theta(theta); !s.ok()) return s;
  if (state.x.size() != impl_->state_size()) {
    std::ostringstream s;
    s << "state has " << state.x.size() << " entries, expected " << impl_->state_size();
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  if (!state.x.allFinite()) return Status::Error(StatusCode::kNonFinite, "the state holds NaN or Inf");
  if (!(t_end >= state.time)) {
    std::ostringstream s;
    s << "t_end = " << t_end << " s lies before the state's time " << state.time << " s";
    return Status::Error(StatusCode::kInvalidArgument, s.str());
  }
  return step_to(state, theta, t_end, nullptr, nullptr);
}

Eigen::VectorXd LeftVentricle3D::sample(const model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  const Model m = unpack(theta, impl_->index, options_.activation_input);
  const Geometry& g = *impl_->geo;
  const Eigen::Index nu_ = impl_->nu(), np_ = impl_->np();
  const Eigen::VectorXd u = state.x.head(nu_);
  const double Pv = state.x(nu_ + np_), Par = state.x(nu_ + np_ + 1), Pd = state.x(nu_ + np_ + 2);
  const CavityVolumes cv = cavity_volumes(g.mesh, impl_->positions(u), g.labels);
  const double P_at = m.atrial(state.time);
  const auto q = circ::valve_flow(Pv, Par, P_at, m.circ);
  const auto last = state.x(state.x.size() - 1) > 1.0 ? circ::ValveRegime::kEjection : circ::ValveRegime::kFilling;
  Eigen::VectorXd out(8 + kAhaSegments);
  out << cv.cavity, Pv, Par, P_at, q.q_ar, q.q_at, static_cast<double>(circ::phase(q.regime, last)), Pd,
      Eigen::Map<const Eigen::VectorXd>(cv.regional.data(), kAhaSegments);
  return out;
}

std::unique_ptr<SteppableSimulator> LeftVentricle3D::with_time_step_factor(double factor) const {
  if (!(factor > 0) || !std::isfinite(factor)) return nullptr;
  LeftVentricle3DOptions o = options_;
  o.dt *= factor;
  if (!o.validate().empty()) return nullptr;
  auto c = std::unique_ptr<LeftVentricle3D>(new LeftVentricle3D(*this, 0));
  c->options_ = o;
  c->impl_->options = o;
  c->impl_->mech.reset();
  return c;
}

RunResult LeftVentricle3D::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  try {
    return run_checked(theta);
  } catch (const std::exception& e) {  // never thrown for a valid set-up; a Status, not a crash
    RunResult r;
    r.trajectory.channels = channels();
    r.status = Status::Error(StatusCode::kInvalidArgument, std::string("lv-3d: ") + e.what());
    return r;
  }
}

RunResult LeftVentricle3D::run_checked(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  RunResult result;
  result.trajectory.channels = channels();
  if (Status s = check_theta(theta); !s.ok()) {
    result.status = s;
    return result;
  }
  const Model m = unpack(theta, impl_->index, options_.activation_input);
  const double T = m.period;
  result.info.period = T;
  model::State s = initial_state(theta);
  if (!s.x.allFinite()) {
    result.status = Status::Error(StatusCode::kDiverged,
                                  "the passive inflation to the atrial pressure of t = 0 did not converge");
    return result;
  }
  const Eigen::Index nu_ = impl_->nu(), np_ = impl_->np();
  // Factors carry from step to step within this run only (LeftVentricle3DOptions::carry_factors).
  struct CarryScope {
    Impl& impl;
    CarryScope(Impl& i, bool on) : impl(i) {
      impl.carry = on;
      impl.carried = impl.have_history = false;
    }
    ~CarryScope() { impl.carry = impl.carried = impl.have_history = false; }
  } carry_scope(*impl_, options_.carry_factors);
  impl_->factorizations = 0;
  impl_->linear_iterations = 0;
  for (int beat = 1; beat <= options_.max_beats; ++beat) {
    const double t_begin = (beat - 1) * T, t_beat_end = beat * T;
    s.time = t_begin;  // the grid of beat b starts exactly at (b - 1) T
    const model::State start = s;
    std::vector<double> times{0.0};
    std::vector<Eigen::VectorXd> rows{sample(s, theta)};
    if (observer_) observer_(beat, 0.0, s);
    int k = 0;
    while (s.time < t_beat_end) {
      const double t1 = shell::next_time(s.time, t_beat_end, options_.dt, T);
      result.status = step_to(s, theta, t1, &result.info.newton_iterations, &result.info.step_cuts);
      if (!result.status.ok()) break;
      ++k;
      if (k % options_.output_every == 0 || t1 >= t_beat_end) {
        times.push_back(std::min(t1 - t_begin, T));
        rows.push_back(sample(s, theta));
        if (observer_) observer_(beat, times.back(), s);
      }
    }
    result.info.beats = beat;
    result.info.factorizations = impl_->factorizations;
    result.info.linear_iterations = impl_->linear_iterations;
    auto& tr = result.trajectory;
    tr.times = Eigen::Map<const Eigen::VectorXd>(times.data(), static_cast<Eigen::Index>(times.size()));
    tr.values.resize(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(tr.channels.size()));
    for (size_t r = 0; r < rows.size(); ++r) tr.values.row(static_cast<Eigen::Index>(r)) = rows[r].transpose();
    if (!result.status.ok()) return result;
    // Beat-to-beat change of the beat-start state: V relative to the start volume, pressures
    // relative to the peak ventricular pressure of the beat.
    const double V0 = tr.values(0, 0), V1 = tr.values(tr.values.rows() - 1, 0);
    const double Ppk = std::max(tr.values.col(1).maxCoeff(), kPref);
    const Eigen::Index o = nu_ + np_;
    const double change = std::max({std::abs(V1 - V0) / V0, std::abs(s.x(o) - start.x(o)) / Ppk,
                                    std::abs(s.x(o + 1) - start.x(o + 1)) / Ppk,
                                    std::abs(s.x(o + 2) - start.x(o + 2)) / Ppk});
    result.info.periodicity_change = change;
    if (!tr.values.allFinite()) {
      result.status = Status::Error(StatusCode::kNonFinite, "non-finite channel values in the beat");
      return result;
    }
    if (beat >= options_.min_beats && change <= options_.periodic_tolerance) return result;
  }
  std::ostringstream msg;
  msg << "not periodic after " << options_.max_beats << " beats: beat-to-beat change "
      << result.info.periodicity_change << " > periodic_tolerance " << options_.periodic_tolerance;
  result.status = Status::Error(StatusCode::kNotPeriodic, msg.str());
  return result;
}

}  // namespace sigmaheart::model::fem
