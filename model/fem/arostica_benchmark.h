// The cardiac elastodynamics benchmark of Arostica et al. 2025 (R. Arostica et al., "A software
// benchmark for cardiac elastodynamics", Comput. Methods Appl. Mech. Engrg. 435 (2025) 117485,
// doi:10.1016/j.cma.2024.117485), Benchmark 1 / Step 1 ("case 1A"): the idealised left ventricle
// (truncated prolate ellipsoid, long axis x, base at +x) with the modified Holzapfel-Ogden law
// (material.h), viscosity, epicardial and basal spring-dashpots, and a time-dependent fibre active
// stress tau(t) and endocardial pressure p(t) over one beat, t in [0, 1] s. Outputs: the
// displacement of the material points p0 = (0.025, 0.03, 0) m and p1 = (0, 0.03, 0) m.
// Specification with sources: experiments/arostica-benchmark/specification.md; what our
// implementation does and measures: docs/models.md s.4.9. Units: SI.
#pragma once

#include "model/fem/elastodynamics.h"
#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// Active stress driver (note s.3; Bestel, Clement & Sorine 2001):
//   dtau/dt = -|a(t)| tau + sigma0 |a(t)|_+,  a = alpha_max f + alpha_min (1 - f),
//   f = S+(t - t_sys) S-(t - t_dias),  S+-(d) = (1 +- tanh(d / gamma)) / 2.
struct ActiveStressDriver {
  double sigma0 = 1.5e5;     // [Pa]
  double alpha_max = 5.0;    // [1/s]
  double alpha_min = -30.0;  // [1/s]
  double t_sys = 0.16;       // [s]
  double t_dias = 0.484;     // [s]
  double gamma = 0.005;      // [s]
  double rate(double t, double tau) const;  // dtau/dt [Pa/s]
};

// Endocardial pressure driver (note s.4):
//   dp/dt = -|b(t)| p + sigma_mid |b(t)|_+ + sigma_pre |g_pre(t)|_+,
//   b = a_pre + alpha_pre g_pre + alpha_mid,  a_pre = alpha_max f_pre + alpha_min (1 - f_pre),
//   f_pre = S+(t - t_sys_pre) S-(t - t_dias_pre),  g_pre = S-(t - t_dias_pre).
struct PressureDriver {
  double alpha_max = 5.0, alpha_min = -30.0;  // [1/s]
  double alpha_pre = 5.0, alpha_mid = 1.0;    // [1/s]
  double sigma_pre = 7000.0;                  // [Pa]
  double sigma_mid = 16000.0;                 // [Pa]
  double t_sys_pre = 0.17, t_dias_pre = 0.484;  // [s]
  double gamma = 0.005;                       // [s]
  double rate(double t, double p) const;      // dp/dt [Pa/s]
};

// tau and p at t_k = k h, k = 0..n_steps, from tau(0) = p(0) = 0 by the classical Runge-Kutta
// method with sub-steps of at most max_substep [s] (the default converges to ~1e-6 Pa).
struct DriverSeries {
  std::vector<double> time, tau, pressure;  // [s], [Pa], [Pa]
};
DriverSeries integrate_drivers(const ActiveStressDriver& active, const PressureDriver& pressure, double h, int n_steps,
                               double max_substep = 1e-5);

// Benchmark geometry in the generator's frame (long axis z, apex at -z; mesh.h): endocardium
// r_s 25, r_l 90 mm, epicardium 35 / 97 mm, base rings at z = 90 * 5/17 mm (endo) and 97/4 mm
// (epi) joined by a base whose height is linear in the layer t (note s.1.1).
EllipsoidGeometry arostica_geometry();
// Generator point (x, y, z) -> benchmark point (z, x, y): a proper (cyclic) rotation.
Eigen::Vector3d arostica_from_generator(const Eigen::Vector3d& x);
Eigen::Vector3d arostica_to_generator(const Eigen::Vector3d& x);

struct ArosticaMeshOptions {
  int n_transmural = 2;
  int n_longitudinal = 12;
  int n_circumferential = 24;
  int order = 2;
};
// The benchmark ventricle in the benchmark frame (long axis x, base at +x), tags endocardium,
// epicardium, base. Throws std::invalid_argument on invalid options.
Mesh arostica_mesh(const ArosticaMeshOptions& options);

// Fibre frame (f0, s0, n0) of the benchmark at a point X (benchmark frame) on layer t in [0, 1]
// (note s.1.3, toolkit ellipsoid_fiber_generation.py): u = atan2(sqrt(y^2+z^2)/r_s(t), x/r_l(t)),
// v = pi - atan2(z, -y), e_u, e_v the normalised tangents, helix angle alpha = -60 + 120 t deg,
// f0 = sin(alpha) e_u + cos(alpha) e_v, n0 = e_u x e_v, s0 = f0 x n0.
Frame arostica_fibre_frame(const Eigen::Vector3d& X, double t);

// Where the layer t comes from: the benchmark's Laplace solution (t = 0 endo, 1 epi; P1 on the
// vertices, interpolated) or the generator's parametric layer coordinate.
enum class TransmuralSource { kLaplace, kParametric };
// Frames at the quadrature points (degree as MechanicsOptions::quadrature_degree), element-major,
// evaluated exactly there (unit vectors; no interpolation of nodal fibres).
std::vector<Frame> arostica_fibres(const Mesh& mesh, TransmuralSource source, int quadrature_degree);

// A material point of the reference mesh: its element and shape-function values there, from the
// inverse isoparametric map (curved P2 elements included).
struct PointProbe {
  Eigen::Vector3d X;      // [m]
  int element = -1;
  Eigen::VectorXd N;      // shape values (4 or 10)
  Eigen::Vector3d xi;     // reference coordinates
};
// Throws std::invalid_argument when X lies in no element (within 1e-9 in reference coordinates).
PointProbe locate_point(const Mesh& mesh, const Eigen::Vector3d& X);
Eigen::Vector3d probe_displacement(const Mesh& mesh, const PointProbe& probe, const Eigen::VectorXd& u);

// The compressibility treatment.
enum class PenaltyForm {
  kSimoTaylor,  // the benchmark's kappa/4 (J^2 - 1 - 2 ln J) in the material, displacement-only
  kMixed,       // our mixed u-p with -p^2/(2 kappa), i.e. kappa/2 (J - 1)^2 after eliminating p
};

struct ArosticaOptions {
  ArosticaMeshOptions mesh;
  double time_step = 1e-3;      // [s]
  double end_time = 1.0;        // [s]
  double output_interval = 0.01;  // [s] (the teams' sampling); a multiple of time_step
  TransmuralSource transmural = TransmuralSource::kLaplace;
  // Mixed by default: displacement-only P2 with the ST91 penalty locks the radial motion
  // (docs/models.md s.4.9).
  PenaltyForm penalty = PenaltyForm::kMixed;
  int quadrature_degree = 5;
  LinearSolver linear_solver = LinearSolver::kAuto;
  bool chord = true;  // ElastodynamicsOptions::chord; false: a factorisation per Newton iteration
  std::string validate() const;
};

struct ArosticaResult {
  bool completed = false;
  std::string message;
  std::vector<double> time;                 // [s] output times
  std::vector<Eigen::Vector3d> p0, p1;      // displacement [m] at the output times
  std::vector<double> tau, pressure;        // [Pa] at the output times
  int n_tets = 0, n_unknowns = 0, steps = 0, newton_iterations = 0, max_newton_iterations = 0;
  int factorizations = 0;                   // of the step tangent, over the run
  double seconds = 0.0;                     // wall time of the time loop
};

// The benchmark's points [m].
inline const Eigen::Vector3d kArosticaP0{0.025, 0.03, 0.0};
inline const Eigen::Vector3d kArosticaP1{0.0, 0.03, 0.0};

// Called after each output sample: (time [s], index of the sample, Newton iterations so far).
using ArosticaProgress = std::function<void(double t, int sample, int newton_iterations)>;

// Runs Benchmark 1 / Step 1 (nominal parameters, note s.2-s.4) from rest to end_time.
// Throws std::invalid_argument on invalid options; a Newton failure ends the run early with
// completed = false and the message saying where.
ArosticaResult run_arostica_step1(const ArosticaOptions& options, const ArosticaProgress& progress = {});

// The same on a given mesh in the benchmark frame (tags 1 endocardium, 2 epicardium, 3 base), e.g.
// the organisers' ellipsoid_0.005 read by app/io (options.mesh is then unused). Linear meshes need
// PenaltyForm::kSimoTaylor (P1-P1 u-p is not inf-sup stable). Throws std::invalid_argument when the
// mesh lacks a tagged surface or a probe point.
ArosticaResult run_arostica_step1(const Mesh& mesh, const ArosticaOptions& options,
                                  const ArosticaProgress& progress = {});

}  // namespace sigmaheart::model::fem
