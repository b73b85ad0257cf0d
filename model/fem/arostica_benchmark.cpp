#include "model/fem/arostica_benchmark.h"

#include "model/fem/element.h"
#include "model/fem/fibres.h"
#include "model/fem/material.h"

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {

double s_plus(double d, double gamma) { return 0.5 * (1.0 + std::tanh(d / gamma)); }
double s_minus(double d, double gamma) { return 0.5 * (1.0 - std::tanh(d / gamma)); }
double positive(double x) { return x > 0 ? x : 0.0; }

// Layer radii of the benchmark ellipsoid [m] (note s.1.1).
constexpr double kRsEndo = 0.025, kRsEpi = 0.035, kRlEndo = 0.090, kRlEpi = 0.097;

}  // namespace

double ActiveStressDriver::rate(double t, double tau) const {
  const double f = s_plus(t - t_sys, gamma) * s_minus(t - t_dias, gamma);
  const double a = alpha_max * f + alpha_min * (1.0 - f);
  return -std::abs(a) * tau + sigma0 * positive(a);
}

double PressureDriver::rate(double t, double p) const {
  const double f = s_plus(t - t_sys_pre, gamma) * s_minus(t - t_dias_pre, gamma);
  const double g = s_minus(t - t_dias_pre, gamma);
  const double a = alpha_max * f + alpha_min * (1.0 - f);
  const double b = a + alpha_pre * g + alpha_mid;
  return -std::abs(b) * p + sigma_mid * positive(b) + sigma_pre * positive(g);
}

DriverSeries integrate_drivers(const ActiveStressDriver& active, const PressureDriver& pressure, double h, int n_steps,
                               double max_substep) {
  if (!(h > 0) || n_steps < 0 || !(max_substep > 0))
    throw std::invalid_argument("integrate_drivers: need h > 0 [s], n_steps >= 0, max_substep > 0 [s]");
  const int m = std::max(1, static_cast<int>(std::ceil(h / max_substep - 1e-9)));
  const double k = h / m;
  DriverSeries out;
  double tau = 0.0, p = 0.0;
  out.time.push_back(0.0);
  out.tau.push_back(tau);
  out.pressure.push_back(p);
  for (int n = 0; n < n_steps; ++n) {
    for (int j = 0; j < m; ++j) {
      const double t = n * h + j * k;
      const double a1 = active.rate(t, tau), b1 = pressure.rate(t, p);
      const double a2 = active.rate(t + 0.5 * k, tau + 0.5 * k * a1), b2 = pressure.rate(t + 0.5 * k, p + 0.5 * k * b1);
      const double a3 = active.rate(t + 0.5 * k, tau + 0.5 * k * a2), b3 = pressure.rate(t + 0.5 * k, p + 0.5 * k * b2);
      const double a4 = active.rate(t + k, tau + k * a3), b4 = pressure.rate(t + k, p + k * b3);
      tau += k / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4);
      p += k / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4);
    }
    out.time.push_back((n + 1) * h);
    out.tau.push_back(tau);
    out.pressure.push_back(p);
  }
  return out;
}

EllipsoidGeometry arostica_geometry() {
  EllipsoidGeometry g;
  g.r_short_endo = kRsEndo;
  g.r_long_endo = kRlEndo;
  g.r_short_epi = kRsEpi;
  g.r_long_epi = kRlEpi;
  g.z_base = kRlEndo * 5.0 / 17.0;  // mu_base,endo = -acos(5/17): 0.0264706 m
  g.z_base_epi = kRlEpi * 5.0 / 20.0;  // mu_base,epi = -acos(5/20): 0.02425 m
  return g;
}

Eigen::Vector3d arostica_from_generator(const Eigen::Vector3d& x) { return {x.z(), x.x(), x.y()}; }
Eigen::Vector3d arostica_to_generator(const Eigen::Vector3d& x) { return {x.y(), x.z(), x.x()}; }

Mesh arostica_mesh(const ArosticaMeshOptions& o) {
  EllipsoidMeshOptions eo;
  eo.n_transmural = o.n_transmural;
  eo.n_longitudinal = o.n_longitudinal;
  eo.n_circumferential = o.n_circumferential;
  eo.order = o.order;
  eo.align_aha_levels = false;  // uniform in the angle from the apex
  Mesh mesh = ellipsoid_mesh(arostica_geometry(), eo);
  for (Eigen::Index i = 0; i < mesh.nodes.rows(); ++i)
    mesh.nodes.row(i) = arostica_from_generator(mesh.nodes.row(i).transpose()).transpose();
  return mesh;
}

Frame arostica_fibre_frame(const Eigen::Vector3d& X, double t) {
  if (!(t >= -1e-9 && t <= 1 + 1e-9) || !X.allFinite())
    throw std::invalid_argument("arostica_fibre_frame: need a finite point and t in [0, 1]");
  const double rs = kRsEndo + t * (kRsEpi - kRsEndo), rl = kRlEndo + t * (kRlEpi - kRlEndo);
  const double u = std::atan2(std::hypot(X.y(), X.z()) / rs, X.x() / rl);
  const double v = u < 1e-7 ? 0.0 : std::numbers::pi - std::atan2(X.z(), -X.y());
  const Eigen::Vector3d eu =
      Eigen::Vector3d(-rl * std::sin(u), rs * std::cos(u) * std::cos(v), rs * std::cos(u) * std::sin(v)).normalized();
  const Eigen::Vector3d ev(0.0, -std::sin(v), std::cos(v));  // (0, -rs sin u sin v, rs sin u cos v) normalised
  const double alpha = (-60.0 + 120.0 * t) * std::numbers::pi / 180.0;
  const Eigen::Vector3d f = (std::sin(alpha) * eu + std::cos(alpha) * ev).normalized();
  const Eigen::Vector3d n = eu.cross(ev).normalized();
  const Eigen::Vector3d s = f.cross(n).normalized();
  Frame R;
  R << f, s, n;
  return R;
}

std::vector<Frame> arostica_fibres(const Mesh& mesh, TransmuralSource source, int quadrature_degree) {
  const int npt = mesh.nodes_per_tet();
  Eigen::VectorXd tn;
  if (source == TransmuralSource::kLaplace) tn = transmural_coordinate(mesh, kEndocardium, kEpicardium);
  const EllipsoidGeometry g = arostica_geometry();
  return frames_at_quadrature_points(mesh, quadrature_degree, [&](Eigen::Index e, const Eigen::VectorXd& N) {
    Eigen::Vector3d X = Eigen::Vector3d::Zero();
    double t = 0.0;
    for (int a = 0; a < npt; ++a) {
      X += N[a] * mesh.nodes.row(mesh.tets(e, a)).transpose();
      if (source == TransmuralSource::kLaplace) t += N[a] * tn[mesh.tets(e, a)];
    }
    if (source == TransmuralSource::kParametric) t = g.coordinates(arostica_to_generator(X))[0];
    return arostica_fibre_frame(X, std::clamp(t, 0.0, 1.0));
  });
}

PointProbe locate_point(const Mesh& mesh, const Eigen::Vector3d& X) {
  const int npt = mesh.nodes_per_tet();
  PointProbe best;
  best.X = X;
  double best_margin = -1e300;
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Eigen::MatrixXd Xe(npt, 3);
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e) {
    for (int a = 0; a < npt; ++a) Xe.row(a) = mesh.nodes.row(mesh.tets(e, a));
    const Eigen::Vector3d lo = Xe.colwise().minCoeff().transpose(), hi = Xe.colwise().maxCoeff().transpose();
    const double pad = 0.1 * (hi - lo).maxCoeff();  // curved P2 faces bulge beyond the nodes
    if (((X.array() < lo.array() - pad) || (X.array() > hi.array() + pad)).any()) continue;
    Eigen::Vector3d xi(0.25, 0.25, 0.25);
    bool ok = false;
    for (int it = 0; it < 30; ++it) {
      tet_shape(mesh.order, xi, N, dN);
      const Eigen::Vector3d r = X - Xe.transpose() * N;
      const Eigen::Matrix3d J = Xe.transpose() * dN;
      const Eigen::Vector3d d = J.partialPivLu().solve(r);
      xi += d;
      if (!xi.allFinite() || xi.cwiseAbs().maxCoeff() > 10) break;
      if (d.norm() < 1e-14) {
        ok = true;
        break;
      }
    }
    if (!ok) continue;
    const double margin = std::min({xi[0], xi[1], xi[2], 1.0 - xi.sum()});
    if (margin > best_margin) {
      best_margin = margin;
      best.element = static_cast<int>(e);
      best.xi = xi;
    }
  }
  if (best.element < 0 || best_margin < -1e-9) {
    std::ostringstream os;
    os << "locate_point: (" << X.x() << ", " << X.y() << ", " << X.z() << ") m lies in no element of the mesh";
    throw std::invalid_argument(os.str());
  }
  tet_shape(mesh.order, best.xi, best.N, dN);
  return best;
}

Eigen::Vector3d probe_displacement(const Mesh& mesh, const PointProbe& probe, const Eigen::VectorXd& u) {
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (int a = 0; a < mesh.nodes_per_tet(); ++a) d += probe.N[a] * u.segment<3>(3 * mesh.tets(probe.element, a));
  return d;
}

std::string ArosticaOptions::validate() const {
  if (!(time_step > 0) || !(end_time > 0) || !(output_interval > 0))
    return "time_step, end_time and output_interval must be positive [s]";
  const double r = output_interval / time_step;
  if (std::abs(r - std::round(r)) > 1e-9 * r) return "output_interval must be a multiple of time_step";
  const double n = end_time / time_step;
  if (std::abs(n - std::round(n)) > 1e-9 * n) return "end_time must be a multiple of time_step";
  return {};
}

ArosticaResult run_arostica_step1(const ArosticaOptions& o, const ArosticaProgress& progress) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("ArosticaOptions: " + m);
  return run_arostica_step1(arostica_mesh(o.mesh), o, progress);
}

ArosticaResult run_arostica_step1(const Mesh& mesh, const ArosticaOptions& o, const ArosticaProgress& progress) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("ArosticaOptions: " + m);
  if (mesh.order == 1 && o.penalty == PenaltyForm::kMixed)
    throw std::invalid_argument("linear (P1) meshes need the st91 penalty: P1-P1 u-p is not inf-sup stable");
  for (const int tag : {kEndocardium, kEpicardium, kBase})
    if (std::find(mesh.face_tag.begin(), mesh.face_tag.end(), tag) == mesh.face_tag.end())
      throw std::invalid_argument("the mesh has no boundary face tagged " + std::to_string(tag) +
                                  " (1 endocardium, 2 epicardium, 3 base)");
  // Material and compressibility (note s.2).
  HolzapfelOgdenParameters hp;
  MechanicsOptions mo;
  mo.quadrature_degree = o.quadrature_degree;
  mo.pressure_surfaces = {kEndocardium};
  mo.linear_solver = o.linear_solver;
  if (o.penalty == PenaltyForm::kSimoTaylor) {
    hp.kappa = 1.0e6;
    mo.displacement_only = true;
  } else {
    hp.kappa = 0.0;
    mo.bulk_modulus = 1.0e6;
  }
  Mechanics mech(mesh, arostica_fibres(mesh, o.transmural, o.quadrature_degree), std::make_unique<HolzapfelOgden>(hp),
                 mo);
  ElastodynamicsOptions eo;
  eo.density = 1000.0;
  eo.viscosity = 100.0;
  eo.time_step = o.time_step;
  eo.linear_solver = o.linear_solver;
  eo.chord = o.chord;
  eo.robin = {RobinCondition{kEpicardium, 1.0e8, 5.0e3, true}, RobinCondition{kBase, 1.0e5, 5.0e3, false}};
  Elastodynamics dyn(mech, eo);

  const int n_steps = static_cast<int>(std::lround(o.end_time / o.time_step));
  const int every = static_cast<int>(std::lround(o.output_interval / o.time_step));
  const DriverSeries drv = integrate_drivers(ActiveStressDriver{}, PressureDriver{}, o.time_step, n_steps);
  const PointProbe q0 = locate_point(mesh, kArosticaP0), q1 = locate_point(mesh, kArosticaP1);

  ArosticaResult res;
  res.n_tets = mesh.n_tets();
  res.n_unknowns = o.penalty == PenaltyForm::kSimoTaylor ? 3 * mesh.n_nodes() : mech.n_unknowns();
  DynamicState x = dyn.initial_state(Load{drv.pressure[0], drv.tau[0]}, 0.0);
  auto record = [&](int k) {
    res.time.push_back(drv.time[static_cast<size_t>(k)]);
    res.p0.push_back(probe_displacement(mesh, q0, x.s.u));
    res.p1.push_back(probe_displacement(mesh, q1, x.s.u));
    res.tau.push_back(drv.tau[static_cast<size_t>(k)]);
    res.pressure.push_back(drv.pressure[static_cast<size_t>(k)]);
    if (progress) progress(res.time.back(), static_cast<int>(res.time.size()) - 1, res.newton_iterations);
  };
  const auto t0 = std::chrono::steady_clock::now();
  record(0);
  for (int k = 1; k <= n_steps; ++k) {
    const StepRecord rec = dyn.step(x, Load{drv.pressure[static_cast<size_t>(k)], drv.tau[static_cast<size_t>(k)]});
    res.newton_iterations += rec.iterations;
    res.factorizations += rec.factorizations;
    res.max_newton_iterations = std::max(res.max_newton_iterations, rec.iterations);
    if (!rec.converged) {
      std::ostringstream os;
      os << "step " << k << " (t = " << k * o.time_step << " s) failed: " << rec.failure;
      res.message = os.str();
      res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return res;
    }
    ++res.steps;
    if (k % every == 0) record(k);
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.completed = true;
  res.message = "reached t = " + std::to_string(o.end_time) + " s";
  return res;
}

}  // namespace sigmaheart::model::fem
