// Quasi-static hyperelastic mechanics of the myocardium: total Lagrangian, mixed displacement-
// pressure (u-p) formulation, Newton's method with a sparse direct solver or AMG-preconditioned
// GMRES (solver.h).
//
// Discretisation: Taylor-Hood tetrahedra (quadratic displacement, linear pressure on the
// vertices) on a quadratic mesh; on a linear mesh P1-P1 is available but locks/is unstable for
// incompressible laws and is only meant for tests. The stored energy is
//   Pi(u, p) = int W(E) dV - int p (J - 1) dV - int p^2 / (2 kappa) dV + active + external,
// kappa = bulk_modulus (infinite: exactly incompressible, as in Land et al. 2015).
// Active stress (Land et al. 2015, problem 3): S_act = Ta f0 (x) f0, Ta in Pa, per element scale.
// Follower pressure on tagged surfaces: traction -P n da in the current configuration; its
// tangent is the non-symmetric load stiffness (e.g. Bonet & Wood, Nonlinear Continuum Mechanics,
// 2nd ed., chapter 8; checked against finite differences in the tests).
// Units: SI (m, Pa); the library is unit-consistent, any consistent set works.
#pragma once

#include "model/fem/material.h"
#include "model/fem/mesh.h"
#include "model/fem/solver.h"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

enum class BaseCondition { kFixed, kSliding };  // sliding: normal (z) fixed, 3 rigid in-plane modes removed

// Parse "fixed"/"sliding", "auto"/"sparselu"/"umfpack"/"amg"; std::invalid_argument otherwise.
BaseCondition parse_base_condition(const std::string& s);
LinearSolver parse_linear_solver(const std::string& s);

struct MechanicsOptions {
  double bulk_modulus = 0.0;        // [Pa]; 0 or +inf: incompressible (Lagrange multiplier)
  // Pure displacement formulation: the pressure unknowns are fixed at 0 (bulk_modulus is then
  // unused) and the compressibility must come from the material's own volumetric energy (e.g.
  // HolzapfelOgdenParameters::kappa).
  bool displacement_only = false;
  // Tetrahedron rule degree (1, 2 or 5); 5 is exact for P2 mass terms; 1 (one point) only suits
  // linear tetrahedra, whose strain is constant (the pressure mass is then integrated exactly).
  int quadrature_degree = 5;
  std::vector<int> pressure_surfaces = {kEndocardium};  // surface tags loaded by the pressure
  int load_steps = 10;              // uniform increments from the start to the target load
  int max_newton_iterations = 20;
  double residual_tolerance = 1e-9;  // relative to the first residual of each load step
  double volume_tolerance = 1e-10;   // |R_p| relative to the reference volume
  int max_step_cuts = 6;             // halvings of a load increment after a failed Newton solve
  LinearSolver linear_solver = LinearSolver::kAuto;
  // Pressure stabilisation alpha >= 0 (0: none), for equal-order P1-P1 elements, which are not
  // inf-sup stable: the pressure rows get -tau_e int grad p . grad q dV per element, the
  // Brezzi-Pitkaranta term with tau_e = alpha h_e^2 / (2 mu_e), h_e the edge of the regular
  // tetrahedron of the element's volume and mu_e the element's current shear stiffness read from
  // its tangent (update_stabilization; docs/models.md s.4.4, "Pressure stabilisation").
  double pressure_stabilization = 0.0;
  // Grad-div (augmented Lagrangian) term beta >= 0 (0: none): + gamma_e / 2 int (J - 1 + p /
  // kappa)^2 dV per element, gamma_e = 2 beta mu_e with mu_e the stabilisation's shear stiffness.
  // It vanishes with the constraint, so the continuous solution is unchanged (Olshanskii & Reusken
  // 2004, Math Comp 73:1699), and gives the displacement block the dilatational stiffness that an
  // isochoric law lacks; the iterative solver then takes the pressure mass over the stiffness as
  // its Schur complement approximation (schur_mass(); docs/models.md s.4.4, "Grad-div term"). The
  // discrete solution moves: the P1 constraint holds only against the vertex pressures.
  double grad_div = 0.0;
  std::string validate() const;
};

// The iterative solver's options for these mechanics options (the Schur approximation follows
// the stabilisation: solver.h, docs/models.md s.4.4).
IterativeOptions iterative_options_for(const MechanicsOptions& o);

struct Load {
  double pressure = 0.0;        // [Pa] follower pressure on pressure_surfaces (cavity side)
  double active_tension = 0.0;  // [Pa] Ta along the fibres
};

// Discrete unknowns: nodal displacements (3 per node, node-major) and vertex pressures.
struct State {
  Eigen::VectorXd u;  // [m]
  Eigen::VectorXd p;  // [Pa], one per vertex
};

struct NewtonRecord {
  double lambda = 0.0;        // load fraction reached at the end of the step (0..1)
  int iterations = 0;
  double residual = 0.0;      // final |R_u| [N]
  bool converged = false;
  std::vector<double> history;  // |R_u| before each Newton update, then the final one
  std::string failure;          // empty, or why the step failed (inverted element, singular...)
};

struct Summary {
  bool converged = false;
  std::string message;                 // why it ended
  std::vector<NewtonRecord> steps;     // one per attempted load step (cuts included)
  int newton_iterations = 0;
  double assembly_seconds = 0.0;
  double solve_seconds = 0.0;
  long long factor_nonzeros = 0;       // fill of the last LU factorisation (UMFPACK/SparseLU)
  std::string brief_report() const;
};

// A stress added at every quadrature point to the material's: S += S_extra, D += D_extra (the
// active and viscous stresses of a time step, model/fem/electromechanics.h). Arguments: element,
// quadrature point (element-major index element * n_qp + qp), Green-Lagrange strain E, local frame
// R, and S, D to add to. Called concurrently for distinct (element, qp) pairs, each pair once per
// assembly: it may write per-point data of its own without locks. In a residual-only assembly
// (tangent == nullptr) D is zero on entry and not read afterwards: a hook may skip it.
using StressHook = std::function<void(int element, int qp, const Eigen::Matrix3d& E, const Frame& R,
                                      Eigen::Matrix3d& S, Matrix9d& D)>;

// Per-step progress: (load fraction, Newton iterations of the step, final residual).
using ProgressCallback = std::function<void(double lambda, int iterations, double residual)>;

class Mechanics {
 public:
  // frames: one Frame per tetrahedron quadrature point (n_tets * n_qp, element-major) or one per
  // tetrahedron. Throws std::invalid_argument on inconsistent inputs (message says what).
  Mechanics(const Mesh& mesh, std::vector<Frame> frames, std::unique_ptr<Material> material,
            MechanicsOptions options);

  // Dirichlet conditions (homogeneous): all components of the nodes on `tag`.
  void fix_surface(int tag);
  // Base condition on surface `tag` (kFixed: all components; kSliding: z plus rigid modes).
  void apply_base_condition(int tag, BaseCondition bc);
  void fix_dof(int node, int component);
  // Scale of Ta per tetrahedron (default 1), e.g. 0 in a scar.
  void set_active_scale(std::vector<double> scale);

  State initial_state() const;
  int n_quadrature_points() const { return nqp_; }
  int n_unknowns() const { return ndof_; }
  const MechanicsOptions& options() const { return opt_; }
  const Mesh& mesh() const { return mesh_; }

  // Residual and tangent in the full numbering (u then p), Dirichlet rows/columns replaced by
  // identity. Returns false when some J <= 0 or a value is not finite (then outputs are junk).
  // The element loop runs colour by colour (no two elements of a colour share a node), so the
  // sums are formed in the same order whatever the number of OpenMP threads: same bits.
  bool assemble(const State& s, const Load& load, Eigen::VectorXd* residual, SparseMatrix* tangent,
                const StressHook& hook = {}) const;
  // Follower-pressure load vector per unit pressure, int N_a n da over the pressure surfaces in
  // the current configuration (n leaving the solid): dR/dP of assemble(), 3 entries per node,
  // zero on Dirichlet dofs.
  Eigen::VectorXd pressure_load(const State& s) const;
  double reference_volume() const { return ref_volume_; }
  bool is_fixed(int dof) const { return fixed_[static_cast<size_t>(dof)] != 0; }

  // Moves the load from `from` to `to` in options.load_steps increments, Newton at each, cutting
  // steps on failure. `state` holds the converged state at `from` on entry and the last
  // converged state on return.
  Summary solve(State& state, const Load& from, const Load& to, const ProgressCallback& progress = {});

  // Pressure stabilisation and grad-div term (MechanicsOptions::pressure_stabilization > 0 or
  // grad_div > 0; a no-op otherwise): recomputes tau_e = alpha h_e^2 / (2 mu_e) and gamma_e =
  // 2 beta mu_e from the element tangents at (s, load, hook), mu_e = sum of the element's
  // displacement diagonal / (4 sum_a int |grad N_a|^2 dV) (the shear modulus mu of an isotropic law
  // with no bulk part, whose diagonal is (4 mu) int |grad N_a|^2 dV per node), at least its value in
  // the unloaded reference (passive material alone). The constructor computes that reference value;
  // solve() updates tau and gamma at each load step's start and the heartbeat at each time step's
  // start, so they are functions of the step's start point. Returns false when the assembly at s
  // failed (tau and gamma unchanged).
  bool update_stabilization(const State& s, const Load& load, const StressHook& hook = {});
  // tau_e per tetrahedron [m^2/Pa] (empty without stabilisation).
  const std::vector<double>& stabilization_tau() const { return stab_tau_; }
  // With grad_div > 0: the pressure mass weighted by the elements' stiffness, sum_e M_e / (2 mu_e +
  // gamma_e) with M_e = int N_k N_l dV (P1, exact), n_vertices square, in the pressure numbering
  // (pressure unknown k is vertex k); rows of fixed pressures empty. The iterative solver's Schur
  // complement approximation is this minus the pressure block (IterativeOptions::Schur::kMass,
  // SparseSolver::set_schur_mass). Follows update_stabilization(). Empty without grad_div.
  SparseMatrix schur_mass() const;

  // Current position of node n.
  Eigen::Vector3d position(const State& s, int node) const;
  // Fibre frame at the centroid of each tetrahedron (first quadrature point's frame when given
  // per quadrature point: informative, for output).
  std::vector<Frame> element_frames() const;

 private:
  void build_pattern();
  // mu_e = max(mu, reference mu_e) per element, and from it tau_e = alpha h_e^2 / (2 mu_e) and the
  // grad-div gamma_e = 2 beta mu_e.
  void set_stabilization_tau(const std::vector<double>& mu);
  // assemble(); with element_mu, also each element's shear stiffness (update_stabilization).
  bool assemble_impl(const State& s, const Load& load, Eigen::VectorXd* residual, SparseMatrix* tangent,
                     const StressHook& hook, std::vector<double>* element_mu) const;

  Mesh mesh_;
  std::vector<Frame> frames_;
  bool frames_per_qp_ = false;
  std::unique_ptr<Material> material_;
  MechanicsOptions opt_;
  int npt_ = 0, nqp_ = 0, ndof_ = 0;
  std::vector<double> active_scale_;
  std::vector<char> fixed_;
  // Reference-configuration data per (element, qp): gradients (npt x 3), dV, linear N.
  std::vector<double> grad_;  // n_tets * nqp * npt * 3
  std::vector<double> dv_;
  std::vector<Eigen::Vector4d> np_;  // per qp, P1 shape values
  std::vector<Eigen::Matrix4d> pressure_mass_;  // per element, int N_k N_l dV (one-point rules only)
  // Pressure stabilisation: per element V_e G_e G_e^T (G_e the vertex P1 gradients, 4 x 3), h_e^2
  // [m^2], the reference shear stiffness mu_e [Pa] and tau_e [m^2/Pa].
  std::vector<Eigen::Matrix4d> stab_laplacian_;
  std::vector<double> stab_h2_, stab_mu_ref_, stab_tau_;
  std::vector<double> elem_mu_, grad_div_gamma_;  // mu_e [Pa] (stabilisation or grad-div) and gamma_e [Pa]
  std::vector<int> load_faces_;      // indices into mesh.faces
  SparseMatrix pattern_;
  std::vector<int> elem_pos_;  // value positions per element local (nloc x nloc)
  std::vector<int> face_pos_;
  std::vector<std::vector<int>> colours_;  // element colouring of build_pattern()
  double ref_volume_ = 0.0;
};

}  // namespace sigmaheart::model::fem
