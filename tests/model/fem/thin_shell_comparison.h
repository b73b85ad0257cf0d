// The 3D heartbeat lv-3d on a thin truncated spherical shell against the lumped sphere
// (docs/models.md s.4.8, "Consistency with the lumped sphere"): shared by the fast test (d/R 0.4,
// coarse mesh, one beat) and the slow study (d/R 0.4, 0.2, 0.1 and two other meshes).
//
// The set-up, and why:
// - Geometry: endocardium a sphere of radius kEndoRadius, epicardium a concentric sphere of radius
//   kEndoRadius (1 + d/R), both cut by the base plane z = base_fraction kEndoRadius; sliding base.
// - Equivalent sphere: the lumped V = 4/3 pi R^3 with R = R0 + y (model/lumped/sphere.cpp), so
//   R0 = (3 V0 / 4 pi)^(1/3) with V0 the 3D unloaded cavity volume (closed by the base-ring lid,
//   model/fem/cavity.h), and d0 = W0 / (4 pi R0^2) with W0 the 3D wall volume. A truncated thin
//   shell that expands homothetically about the base-ring centre keeps its cavity and wall
//   fractions f, g of the full sphere, and its energy balance P dV = dE then gives
//   P = (g/f) (d/R) W'(s)/s^2, which is exactly the lumped sphere's law with this R0, d0: the
//   missing cap is accounted for by the equal volumes, not by a correction.
// - Parameters: the lumped sphere's healthy set, with every stress-like parameter (c1, c2, c_exp,
//   eta, Es, mu, k0, sigma0) multiplied by kappa = (d0/R0)_healthy / (d0/R0). The lumped balance
//   holds d0/R0 only in the product (d0/R0) Sigma (and in the wall inertia rho d0 y'', below
//   1 % of P here), so the lumped beat is the same at every thickness, and the 3D beats approach
//   one loop as the wall thins.
// - Active stress: ActiveStress::kTangentIsotropic (the sphere's fibres spread evenly in the
//   tangent plane); viscosity eta dE/dt is the 3D form of the sphere's eta dC/dt (1 + 2 C^-6).
// - The opening: a sliding base cannot hold the membrane tension at the ring in its plane, so the
//   3D wall is a few percent more compliant near it whatever the thickness (docs/models.md s.4.8).
// - Both from their relaxed initial states (passive equilibrium at P_at(0), arteries at 75/70
//   mmHg), the same backward-Euler time grid (dt), compared sample by sample over the last beat.
#pragma once

#include "model/fem/electromechanics.h"
#include "model/fem/element.h"
#include "model/lumped/shell.h"
#include "model/lumped/sphere.h"

#include <Eigen/Dense>

#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::model::fem::testing {

inline constexpr double kEndoRadius = 25e-3;    // [m]
inline constexpr double kMmHg = 133.322;        // [Pa]

struct ThinShellCase {
  double thickness_ratio = 0.4;   // d / R_endo (thinner walls need finer meshes: ThinShellSlow)
  double base_fraction = 0.9;     // base plane z_base / R_endo
  int n_longitudinal = 6;
  int n_circumferential = 12;
  BaseCondition base = BaseCondition::kSliding;
  double dt = 5e-3;  // [s], both models
  int beats = 1;     // the last one is compared; 0: the passive inflation only (V3(0), Vl(0))
  // SparseLU (the default) for the fast test's bits; UMFPACK for the thin walls' larger meshes, whose
  // SparseLU factorisation grows far faster (experiments/thin-shell/README.md).
  LinearSolver linear_solver = LinearSolver::kSparseLU;
};

struct ThinShellComparison {
  Status status;           // of the first failed run, else ok
  double R0 = 0, d0 = 0;   // equivalent sphere [m]
  double kappa = 0;        // stress scaling [-]
  Eigen::VectorXd t;       // [s] within the compared beat
  Eigen::VectorXd V3, P3, Vl, Pl;  // [m^3], [Pa]
  // Over the compared beat; SV and peak P are the lumped sphere's.
  double edv3 = 0, edvl = 0, esv3 = 0, esvl = 0, pmax3 = 0, pmaxl = 0;
  double max_dV_rel_sv = 0;  // max |V3 - Vl| / SV_l
  double max_dP_rel_pk = 0;  // max |P3 - Pl| / peak P_l
  double edv_rel() const { return std::abs(edv3 - edvl) / edvl; }
  double esv_rel() const { return std::abs(esv3 - esvl) / esvl; }
  double pmax_rel() const { return std::abs(pmax3 - pmaxl) / pmaxl; }
  double sv_rel() const { return std::abs((edv3 - esv3) - (edvl - esvl)) / (edvl - esvl); }
};

inline EllipsoidGeometry thin_sphere_geometry(double thickness_ratio, double base_fraction) {
  EllipsoidGeometry g;
  g.r_short_endo = g.r_long_endo = kEndoRadius;
  g.r_short_epi = g.r_long_epi = kEndoRadius * (1.0 + thickness_ratio);
  g.z_base = base_fraction * kEndoRadius;
  return g;
}

// Volume of the (curved, quadratic) mesh [m^3]: the sum of det J over the degree-2 rule.
inline double curved_mesh_volume(const Mesh& mesh) {
  double v = 0.0;
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Eigen::MatrixXd X(mesh.nodes_per_tet(), 3);
  for (int e = 0; e < mesh.n_tets(); ++e) {
    for (int a = 0; a < mesh.nodes_per_tet(); ++a) X.row(a) = mesh.nodes.row(mesh.tets(e, a));
    for (const auto& qp : tet_rule(2)) {
      tet_shape(mesh.order, qp.xi, N, dN);
      v += qp.weight * (X.transpose() * dN).determinant();
    }
  }
  return v;
}

inline ThinShellComparison compare_thin_shell(const ThinShellCase& c) {
  ThinShellComparison out;
  LeftVentricle3DOptions o;
  o.geometry = thin_sphere_geometry(c.thickness_ratio, c.base_fraction);
  o.n_transmural = 1;
  o.n_longitudinal = c.n_longitudinal;
  o.n_circumferential = c.n_circumferential;
  o.base = c.base;
  o.active_stress = ActiveStress::kTangentIsotropic;
  o.activation = ActivationSource::kSynchronous;
  o.dt = c.dt;
  o.linear_solver = c.linear_solver;
  LeftVentricle3D lv(o);

  // The equivalent sphere: equal unloaded cavity and wall volumes.
  const double V0 = cavity_volumes(lv.mesh(), lv.mesh().nodes, lv.labels()).cavity;
  const double W0 = curved_mesh_volume(lv.mesh());
  out.R0 = std::cbrt(3.0 * V0 / (4.0 * std::numbers::pi));
  out.d0 = W0 / (4.0 * std::numbers::pi * out.R0 * out.R0);

  lumped::SphereOptions so;
  so.dt = c.dt;
  // The sphere's d0 >= 2 mm is a physiological range, not a limit of its equations: thinner walls
  // are allowed here.
  std::vector<Parameter> table = lumped::LumpedSphere::default_parameters().all();
  for (Parameter& p : table)
    if (p.name == "d0") p.lower = 1e-4;
  lumped::LumpedSphere sphere(so, ParameterSpace(std::move(table)));
  const ParameterSpace& ls = sphere.parameters();
  Eigen::VectorXd thl = ls.nominal();
  const double healthy_ratio = thl(ls.index_or_throw("d0")) / thl(ls.index_or_throw("R0"));
  out.kappa = healthy_ratio / (out.d0 / out.R0);
  thl(ls.index_or_throw("R0")) = out.R0;
  thl(ls.index_or_throw("d0")) = out.d0;
  for (const char* name : {"c1", "c2", "c_exp", "eta", "Es", "mu", "k0", "sigma0"})
    thl(ls.index_or_throw(name)) *= out.kappa;

  // The 3D parameters by name from the lumped ones; sigma0_XX from sigma0.
  const ParameterSpace& ps = lv.parameters();
  Eigen::VectorXd th3 = ps.nominal();
  for (Eigen::Index i = 0; i < ps.size(); ++i) {
    const std::string& n = ps[i].name;
    th3(i) = thl(ls.index_or_throw(n.rfind("sigma0_", 0) == 0 ? std::string("sigma0") : n));
  }

  const double T = thl(ls.index_or_throw("period"));
  model::State s3 = lv.initial_state(th3);
  model::State sl = sphere.initial_state(thl);
  if (!s3.x.allFinite()) {
    out.status = Status::Error(StatusCode::kDiverged, "lv-3d: the passive inflation did not converge");
    return out;
  }
  if (c.beats == 0) {  // the passive inflation only
    out.V3 = Eigen::VectorXd::Constant(1, lv.sample(s3, th3)(0));
    out.Vl = Eigen::VectorXd::Constant(1, sphere.sample(sl, thl)(0));
    return out;
  }
  const double t_begin = (c.beats - 1) * T;
  std::vector<double> t, V3, P3, Vl, Pl;
  auto record = [&]() {
    const Eigen::VectorXd a = lv.sample(s3, th3), b = sphere.sample(sl, thl);
    t.push_back(s3.time - t_begin);
    V3.push_back(a(0));
    P3.push_back(a(1));
    Vl.push_back(b(0));
    Pl.push_back(b(1));
  };
  for (int beat = 1; beat <= c.beats; ++beat) {
    const double tb = (beat - 1) * T;
    s3.time = sl.time = tb;  // the beat grid starts exactly at (b - 1) T, as run() does
    if (beat == c.beats) record();
    while (s3.time < beat * T) {
      const double t1 = lumped::shell::next_time(s3.time, beat * T, c.dt, T);
      if (Status st = lv.advance(s3, th3, t1); !st.ok()) {
        out.status = st;
        return out;
      }
      if (Status st = sphere.advance(sl, thl, t1); !st.ok()) {
        out.status = st;
        return out;
      }
      if (beat == c.beats) record();
    }
  }
  auto vec = [](const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())).eval();
  };
  out.t = vec(t);
  out.V3 = vec(V3);
  out.P3 = vec(P3);
  out.Vl = vec(Vl);
  out.Pl = vec(Pl);
  out.edv3 = out.V3.maxCoeff();
  out.edvl = out.Vl.maxCoeff();
  out.esv3 = out.V3.minCoeff();
  out.esvl = out.Vl.minCoeff();
  out.pmax3 = out.P3.maxCoeff();
  out.pmaxl = out.Pl.maxCoeff();
  out.max_dV_rel_sv = (out.V3 - out.Vl).cwiseAbs().maxCoeff() / (out.edvl - out.esvl);
  out.max_dP_rel_pk = (out.P3 - out.Pl).cwiseAbs().maxCoeff() / out.pmaxl;
  return out;
}

}  // namespace sigmaheart::model::fem::testing
