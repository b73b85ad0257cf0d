#include "model/fem/land_benchmark.h"

#include "model/fem/fibres.h"

#include <chrono>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {
constexpr double kMm = 1e-3;
constexpr double kKPa = 1e3;

int nearest_node(const Mesh& mesh, const Eigen::Vector3d& x) {
  int best = 0;
  double d = 1e300;
  for (int n = 0; n < mesh.n_nodes(); ++n) {
    const double dn = (mesh.nodes.row(n).transpose() - x).squaredNorm();
    if (dn < d) {
      d = dn;
      best = n;
    }
  }
  return best;
}
}  // namespace

std::string LandOptions::validate() const {
  if (problem < 1 || problem > 3) return "problem must be 1, 2 or 3";
  if (refinement < 1 || refinement > 8) return "refinement must be in 1..8";
  if (load_steps < 0) return "load_steps must be >= 0";
  return {};
}

Mesh land_mesh(int problem, int K) {
  if (problem == 1) return box_mesh(10 * kMm, 1 * kMm, 1 * kMm, 8 * K, K, K, 2);
  EllipsoidMeshOptions mo;
  mo.n_transmural = K;
  mo.n_longitudinal = 6 * K;
  mo.n_circumferential = 12 * K;
  mo.order = 2;
  return ellipsoid_mesh(EllipsoidGeometry{}, mo);
}

std::unique_ptr<Mechanics> land_mechanics(const LandOptions& o) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("LandOptions: " + m);
  Mesh mesh = land_mesh(o.problem, o.refinement);
  MechanicsOptions mo;
  mo.quadrature_degree = o.quadrature_degree;
  mo.linear_solver = o.linear_solver;
  GuccioneParameters gp;  // problem 1 and 3 values by default
  std::vector<Frame> frames;
  const EllipsoidGeometry geo;
  if (o.problem == 1) {
    mo.pressure_surfaces = {kBottom};
    mo.load_steps = o.load_steps > 0 ? o.load_steps : 4;
    frames = uniform_fibres(mesh, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY());
  } else {
    if (o.problem == 2) gp = {10 * kKPa, 1.0, 1.0, 1.0};
    mo.load_steps = o.load_steps > 0 ? o.load_steps : 5;
    frames = ellipsoid_fibres(mesh, geo, FibreOptions{90.0, -90.0}, mo.quadrature_degree);
  }
  auto mech = std::make_unique<Mechanics>(mesh, std::move(frames), std::make_unique<Guccione>(gp), mo);
  // Dirichlet conditions of Land et al. 2015 s.2(c): problem 1 "the left face (x = 0) is fixed in
  // all directions"; problems 2 and 3 "the base plane (z = 5 mm) is fixed in all directions"
  // (o.base = kFixed, the default; kSliding is offered only to study the effect of the choice).
  if (o.problem == 1) mech->fix_surface(kClamped);
  else mech->apply_base_condition(kBase, o.base);
  return mech;
}

Load land_load(int problem) {
  if (problem == 1) return {0.004 * kKPa, 0.0};
  if (problem == 2) return {10 * kKPa, 0.0};
  return {15 * kKPa, 60 * kKPa};
}

LandResult run_land_problem(const LandOptions& o, const ProgressCallback& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  LandResult r;
  r.problem = o.problem;
  r.refinement = o.refinement;
  auto mech_ptr = land_mechanics(o);
  Mechanics& mech = *mech_ptr;
  const Mesh& mesh = mech.mesh();
  const EllipsoidGeometry geo;
  State s = mech.initial_state();
  if (o.problem == 1) {
    r.summary = mech.solve(s, Load{}, Load{0.004 * kKPa, 0.0}, progress);
  } else if (o.problem == 2) {
    r.summary = mech.solve(s, Load{}, Load{10 * kKPa, 0.0}, progress);
  } else {
    r.summary = mech.solve(s, Load{}, Load{15 * kKPa, 0.0}, progress);
    if (r.summary.converged) {
      Summary s2 = mech.solve(s, Load{15 * kKPa, 0.0}, Load{15 * kKPa, 60 * kKPa}, progress);
      s2.steps.insert(s2.steps.begin(), r.summary.steps.begin(), r.summary.steps.end());
      s2.newton_iterations += r.summary.newton_iterations;
      s2.assembly_seconds += r.summary.assembly_seconds;
      s2.solve_seconds += r.summary.solve_seconds;
      r.summary = s2;
    }
  }
  if (o.problem == 1) {
    const int n = nearest_node(mesh, Eigen::Vector3d(10 * kMm, 0.5 * kMm, 1 * kMm));
    r.primary = mech.position(s, n).z() / kMm;
  } else {
    const int endo = nearest_node(mesh, Eigen::Vector3d(0, 0, -geo.r_long_endo));
    const int epi = nearest_node(mesh, Eigen::Vector3d(0, 0, -geo.r_long_epi));
    r.primary = mech.position(s, endo).z() / kMm;
    r.secondary = mech.position(s, epi).z() / kMm;
  }
  r.n_tets = mesh.n_tets();
  r.n_nodes = mesh.n_nodes();
  r.n_unknowns = mech.n_unknowns();
  r.element_fibres = mech.element_frames();
  r.state = std::move(s);
  r.mesh = mesh;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace sigmaheart::model::fem
