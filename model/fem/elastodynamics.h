// Nonlinear elastodynamics on top of the total-Lagrangian mechanics (mechanics.h): inertia with a
// consistent mass matrix, a viscous pseudo-potential, Robin spring-dashpot boundaries and
// time-dependent loads (follower pressure, fibre active stress), as in the cardiac elastodynamics
// benchmark of Arostica et al. 2025 (CMAME 435:117485, doi:10.1016/j.cma.2024.117485;
// experiments/arostica-benchmark/specification.md s.2, docs/models.md s.4.9):
//
//   rho u'' - Div(F (S(E) + S_visc + tau f0 (x) f0)) = 0 in the reference domain,
//   S_visc = eta dE/dt (the pseudo-potential eta/2 tr(dE/dt^2)),
//   P N = -p J F^-T N on the pressure surfaces (follower load),
//   P N + alpha u + beta u' = 0 on a full-vector Robin surface,
//   P N . N + alpha u.N + beta u'.N = 0, (P N) x N = 0 on a normal-only Robin surface
//   (N the reference unit normal, integrated on the reference area).
//
// Time integration: Newmark's average-acceleration rule (beta 1/4, gamma 1/2; second order,
// unconditionally stable, no numerical dissipation) with all terms at t_{n+1}, Newton's method per
// step on the displacement (and, in the mixed formulation, pressure) unknowns. The strain rate
// is integrated consistently per quadrature point by the trapezoidal rule,
//   dE/dt_{n+1} = 2 (E_{n+1} - E_n) / h - dE/dt_n,
// which is what Newmark's velocity update does to u for gamma = 1/2.
// Units: SI (m, s, kg, Pa).
#pragma once

#include "model/fem/mechanics.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// A spring-dashpot on the faces carrying `tag`: traction -(stiffness u + damping u') on the
// reference area, the full vector or its reference-normal component only.
struct RobinCondition {
  int tag = kBase;
  double stiffness = 0.0;  // alpha [Pa/m]
  double damping = 0.0;    // beta [Pa s/m]
  bool normal_only = false;
};

struct ElastodynamicsOptions {
  double density = 1000.0;   // rho [kg/m^3]
  double viscosity = 100.0;  // eta [Pa s] of S_visc = eta dE/dt
  double time_step = 1e-3;   // h [s]
  std::vector<RobinCondition> robin;
  int max_newton_iterations = 25;
  // Newton stops when the update's largest displacement component is below this [m] (and,
  // in the mixed formulation, the pressure update below pressure_tolerance [Pa]).
  double displacement_tolerance = 1e-10;
  double pressure_tolerance = 1e-4;
  LinearSolver linear_solver = LinearSolver::kAuto;
  // Chord iterations: the tangent is factorised at a step's first iterate and reused while the
  // updates contract by at least `chord_contraction` per iteration; a slower or failed
  // contraction refactorises at the current iterate. false: a factorisation per iteration
  // (Newton's method). Either way a step depends only on its inputs.
  bool chord = true;
  double chord_contraction = 0.25;
  std::string validate() const;  // empty when valid
};

// State at one time level: displacement (and pressure) unknowns, velocity and acceleration of
// the displacement unknowns (3 per node), and per-quadrature-point strain and strain rate.
struct DynamicState {
  double time = 0.0;  // [s]
  State s;
  Eigen::VectorXd v;  // [m/s]
  Eigen::VectorXd a;  // [m/s^2]
  std::vector<Eigen::Matrix3d> E, Edot;  // per (element, qp), element-major [-], [1/s]
};

struct StepRecord {
  bool converged = false;
  int iterations = 0;
  int factorizations = 0;                // of the tangent (= iterations without `chord`)
  std::vector<double> update_norms;  // max |du| [m] after each Newton update
  std::string failure;               // empty, or why Newton failed
};

class Elastodynamics {
 public:
  // `mechanics` gives the static part (material, active stress, follower pressure, u-p or
  // displacement-only formulation); it must outlive this object and must have no Dirichlet
  // condition on displacements that conflicts with the Robin surfaces (none is needed).
  // Throws std::invalid_argument on invalid options or a Robin tag no face carries.
  Elastodynamics(const Mechanics& mechanics, ElastodynamicsOptions options);

  // u = 0, v = 0 at `time`; the acceleration from M a = -R(u, v) with `load` (zero for a
  // stress-free start with zero loads).
  DynamicState initial_state(const Load& load, double time = 0.0) const;

  // Advances `x` from t_n to t_n + h with the loads at t_n + h. On failure `x` is unchanged.
  // Not thread-safe (one linear solver is reused across steps).
  StepRecord step(DynamicState& x, const Load& load_next) const;

  // The Newton residual of the step from `xn` with unknowns `trial` at t_n + h (loads `load`):
  // G = R_static(trial) + M a_{n+1} + K_r u_{n+1} + C_r v_{n+1} (+ the viscous stress inside
  // R_static), and its exact Jacobian in `tangent`; `strains` (if given) receives E at every
  // quadrature point. false when an element inverts or a value is not finite.
  bool residual(const DynamicState& xn, const State& trial, const Load& load, Eigen::VectorXd* residual,
                SparseMatrix* tangent, std::vector<Eigen::Matrix3d>* strains = nullptr) const;

  // Constant matrices in the full numbering (u then p; zero outside the displacement block).
  const SparseMatrix& mass() const { return mass_; }                 // int rho N_a N_b dV I [kg]
  const SparseMatrix& robin_stiffness() const { return k_robin_; }   // [N/m]
  const SparseMatrix& robin_damping() const { return c_robin_; }     // [N s/m]

  // Kinetic energy 1/2 v.M v [J].
  double kinetic_energy(const DynamicState& x) const;
  const ElastodynamicsOptions& options() const { return opt_; }

 private:
  const Mechanics& mech_;
  ElastodynamicsOptions opt_;
  SparseMatrix mass_, k_robin_, c_robin_;
  SparseMatrix step_tangent_;  // c0 M + K_robin + (c1/2) C_robin: the fixed part of every Newton tangent
  // One solver for all steps: the effective tangent's pattern never changes, so the symbolic
  // analysis is done once (step() is therefore not safe to call concurrently).
  std::unique_ptr<SparseSolver> solver_;
};

}  // namespace sigmaheart::model::fem
