// The 3D electromechanical left ventricle: the BCS active law (model/bcs) at every quadrature
// point of the Taylor-Hood mechanics (mechanics.h), a parallel viscous stress, and the cavity
// pressure coupled monolithically to the valves and Windkessel of model/circulation
// (docs/models.md s.4.8). It uses the lumped sphere's laws and parameter names, so estimators
// treat the two alike.
//
// Per time step [t^n, t^{n+1}], h = t^{n+1} - t^n, quasi-static (wall inertia left out, as in the
// 3D BCS models of Chapelle et al. 2012 and the Land et al. 2015 benchmark; docs/models.md s.4.8
// says why), backward Euler in every rate:
//   R_u(u, p, P_v) = int (F S - p J F^-T) : grad(v) dV + P_v int v . n da       = 0  (balance)
//   R_p(u)         = - int (J - 1) q dV                                       = 0  (incompressible)
//   r_c            = (V(u) - V^n)/h + q(P_v, P_ar, P_at) + C_cav (P_v - P_v^n)/h = 0  (cavity)
//   r_ar           = the proximal Windkessel row, P_d eliminated exactly      = 0
// with S = S_passive(E) + sigma_1D(E_ff) f0 (x) f0 + eta (E - E^n)/h (or the tangent-isotropic
// active stress of ActiveStress::kTangentIsotropic). sigma_1D is the BCS stress
// of the point, condensed locally (bcs::condense_step: backward Euler on (e_c, k_c, tau_c) with its
// activation time T_d and APD) with its consistent tangent. Newton's method runs on (u, p, P_v,
// P_ar) together; the dense row dV/du and column dR_u/dP_v border the sparse tangent and are
// eliminated by a Schur complement on its LU factors (two solves per iteration), so the sparse
// solver keeps the mechanics pattern.
#pragma once

#include "model/activation/pacing.h"
#include "model/bcs/active_law.h"
#include "model/circulation/circulation.h"
#include "model/fem/cavity.h"
#include "model/fem/material.h"
#include "model/fem/mechanics.h"
#include "model/fem/mesh.h"
#include "model/fem/vtk_output.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// The passive law of the lumped sphere (docs/models.md s.2.1) written for 3D on the isochoric
// invariants (Ibar_1 = J^-2/3 I_1, Ibar_2 = J^-4/3 I_2; the sphere's J1, J2 are these invariants of
// its incompressible equibiaxial stretch):
//   W = c1 (Ibar_1 - 3) + c2 (Ibar_2 - 3) + c_exp (exp(b_exp (Ibar_1 - 3)^2) - 1)
// Incompressibility is the mechanics' mixed pressure, as for MooneyRivlin (material.h).
struct BcsPassiveParameters {
  double c1 = 100.0;    // [Pa]
  double c2 = 150.0;    // [Pa]
  double c_exp = 30.0;  // [Pa]
  double b_exp = 1.0;   // [-]
  std::string validate() const;
};

class BcsPassive final : public MaterialLaw<BcsPassive, BcsPassiveParameters> {
 public:
  using MaterialLaw::MaterialLaw;
  double energy(const Eigen::Matrix3d& E, const Frame& R) const override;
  void stress(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S, Matrix9d& D) const override;
  void stress_only(const Eigen::Matrix3d& E, const Frame& R, Eigen::Matrix3d& S) const override;
  std::string name() const override { return "bcs-passive"; }
};

// Where the activation times T_d of the quadrature points come from: every point at 0 (synchronous,
// as the lumped sphere), the wall distance from the endocardial apex over a conduction velocity,
// the healthy or LBBB eikonal pattern of docs/models.md s.4.6 (config `activation: healthy|lbbb`),
// or one time per mesh vertex given by the caller (set_activation_times); vertex times are
// interpolated to the quadrature points with the P1 shape functions.
enum class ActivationSource {
  kSynchronous,   // every point at 0 s
  kApexDistance,  // straight-line distance from the endocardial apex / conduction_velocity
  kHealthy,       // eikonal solve, healthy pattern (eikonal.h activation_pattern, docs/models.md s.4.6)
  kLbbb,          // eikonal solve, left bundle branch block pattern (same)
  kPrescribed,    // per-vertex times from set_activation_times
};

// How the active stress of a quadrature point acts in the tangent plane of the wall.
enum class ActiveStress {
  // Along the helix fibre f0: S_act = sigma_1D(e) f0 (x) f0, e = f0 . E f0.
  kFibre,
  // Fibres spread evenly in the tangent plane (the lumped sphere's assumption, docs/models.md
  // s.2.1; Caruel et al. 2014 s.2.2): the average of f (x) f over the directions f of the plane
  // spanned by f0 and s0 (the sheet direction, tangent to the wall: fibres.h) is
  // T = (f0 (x) f0 + s0 (x) s0)/2, their mean strain is e = T : E, and one BCS state driven by it
  // gives S_act = sigma_1D(e) T. Exact for an equibiaxial tangent strain (every direction has the
  // same strain, hence the same BCS state); independent of the helix angle.
  kTangentIsotropic,
};

struct LeftVentricle3DOptions {
  // Geometry of the truncated ellipsoid (docs/models.md s.4.1): the human-sized one by default;
  // equal short and long radii give a truncated spherical shell (docs/models.md s.4.8,
  // "Consistency with the lumped sphere").
  EllipsoidGeometry geometry = EllipsoidGeometry::human();
  // Mesh of the geometry: quadratic tetrahedra (element_order 2, P2-P1 Taylor-Hood, exactly
  // incompressible) or linear ones (element_order 1: P1 displacement and P1 pressure with the finite
  // bulk modulus below, the pressure a penalty on the volume change averaged over each vertex's
  // patch, as the average-nodal-pressure tetrahedron of Bonet & Burton 1998, Commun Numer Meth Eng
  // 14:437; docs/models.md s.4.8, "Linear tetrahedra").
  int element_order = 2;
  double bulk_modulus = 0.0;  // [Pa]; 0: incompressible (element_order 2 only)
  // Brezzi-Pitkaranta pressure stabilisation alpha of the linear tetrahedra (element_order 1 only;
  // MechanicsOptions::pressure_stabilization): 0 (default) none; with it the iterative solver's
  // GMRES iterations stop growing with the mesh (docs/models.md s.4.4, docs/solvers.md s.3).
  double pressure_stabilization = 0.0;
  // Grad-div term beta (MechanicsOptions::grad_div): 0 (default) none; with it the iterative
  // solver's Schur complement approximation is the pressure mass over the stiffness, which holds on
  // finer meshes, but it changes the discretisation (EF +0.1 to +0.4 points on the linear meshes;
  // docs/models.md s.4.4, "Grad-div term"; experiments/lv3d-solver/NOTES.md, "The grad-div term in
  // the beat").
  double grad_div = 0.0;
  int n_transmural = 1;
  int n_longitudinal = 6;      // a multiple of 3 puts node rings on the AHA levels
  int n_circumferential = 12;  // a multiple of 6 (nodes on the 60-degree AHA bounds), >= 12
  int quadrature_degree = 2;   // 2 (4 points) or 5 (14 points); 1 (one point) on linear tetrahedra
  double fibre_endo_deg = 60.0;   // helix angle at the endocardium [deg]
  double fibre_epi_deg = -60.0;   // at the epicardium [deg]
  ActiveStress active_stress = ActiveStress::kFibre;
  BaseCondition base = BaseCondition::kSliding;

  double dt = 5e-3;            // time step [s] (cut in halves on a failed Newton solve)
  int max_step_cuts = 6;       // halvings of a step before the run fails (kDiverged)
  int inflation_steps = 4;     // load steps from the unloaded reference to the pressure at t = 0
  int min_beats = 1;           // beats before the periodicity test
  int max_beats = 20;          // beats before giving up (kNotPeriodic)
  double periodic_tolerance = 1e-3;  // beat-to-beat change of V, P_v, P_ar, P_d (relative)
  int output_every = 1;        // keep every k-th step in the returned trajectory
  double newton_tolerance = 1e-8;    // on the scaled residual rows (see electromechanics.cpp)
  int newton_max_iterations = 20;
  // Broyden updates of the chord iterations between factorisations (electromechanics.cpp, step;
  // docs/solvers.md s.1): false gives the plain chord iteration.
  bool broyden = true;
  // Within one run() the factors of the last step's tangent start the next step's chord
  // iterations (refactorised when they contract too slowly, as within a step), and the first
  // iterate is extrapolated from the last two steps (docs/solvers.md s.1). advance() always
  // starts from fresh factors, so it stays a pure function of (state, theta, t_end); run() is a
  // pure function of theta either way. false: a factorisation at every step's first iterate.
  bool carry_factors = true;

  ActivationSource activation = ActivationSource::kSynchronous;
  double conduction_velocity = 0.6;  // [m/s] for kApexDistance
  // Multiplies every conduction velocity of the eikonal patterns (healthy, lbbb) and of paced
  // activation (pace()): 0.8 lengthens the LBBB activation by a quarter (a slower-conducting,
  // fibrotic myocardium). (0.1, 10].
  double conduction_scale = 1.0;
  // Shape of the BCS activation input u(t) at every point (`activation_shape:`; docs/models.md s.1):
  // the square wave by default, or the ramped u(t) of Caruel et al. 2014.
  bcs::ActivationInput activation_input;
  // SparseLU by default: the same bits in every thread (electromechanics.cpp, step); UMFPACK
  // (kAuto, kUmfPack) rounds with the alignment of its workspace.
  LinearSolver linear_solver = LinearSolver::kSparseLU;
  // Relative tolerance of the iterative solver's GMRES (linear_solver kAmg; ignored by the direct
  // solvers): an inexact Newton method (Dembo, Eisenstat & Steihaug 1982) when it is above the
  // rounding level. Newton's own test (newton_tolerance on the scaled residual rows) still decides
  // convergence, so a looser linear tolerance costs iterations, not accuracy (docs/solvers.md s.3).
  double linear_tolerance = 1e-10;
  // Coarse correction of the iterative solver (needs linear_solver kAmg): hats in the ellipsoid's
  // coordinates (coarse_space.h; docs/solvers.md s.4). With grad_div > 0 the
  // grid follows the mesh (every other node along and around the wall; displacements only,
  // CoarseGrid::kHalfMesh): GMRES then takes 4.7-5.4 iterations per Newton iteration from 3 468
  // to 72 604 unknowns, and the beat grows as unknowns^1.26 from 10 384 to 72 604 (^1.36 without;
  // experiments/lv3d-solver/NOTES.md, "The coarse correction with the grad-div term"). Without the
  // term, the fixed 3 x 5 x 8 grid of the wall's shell modes (CoarseGrid::kWallModes), which gains
  // 6-12 % up to 23 060 unknowns and nothing at 43 224 (experiments/lv3d-solver/NOTES.md, "The
  // coarse correction in the beat"). Off by default here; a config that leaves the key out gets it
  // on with linear_solver amg, grad_div > 0 and
  // element_order 1 (read_lv3d_options, register.h).
  bool coarse_correction = false;
  // A diagnostic of the iterative solver (needs linear_solver kAmg): the displacement block solved
  // exactly (a sparse LU per set-up) instead of by a V-cycle (IterativeOptions::Displacement::kExact),
  // so that GMRES's iterations measure the Schur complement approximation alone (docs/solvers.md
  // s.3; experiments/lv3d-solver/NOTES.md, "Where the beat's iterations grow"). Slow on large
  // meshes; off by default. With UMFPACK (when built in) its runs on different thread counts may
  // differ in the last bits, as linear_solver umfpack's do (electromechanics.cpp, step).
  bool exact_displacement_solve = false;

  // Empty when valid, else a message starting with the offending field's name.
  std::string validate() const;
};

// The steppable simulator "lv-3d". Parameters: those of the lumped sphere except its geometry
// (rho, R0, d0: the mesh is the geometry) and sigma0, which is regional: sigma0_01..17, one per
// AHA segment (family contractility). Channels: V_lv, P_lv, P_ar, P_at, q_ar, q_at, phase, P_d as
// the lumped models, then V_seg01..V_seg17 (docs/models.md s.5). State: u (3 per node), p (per
// vertex), P_v, P_ar, P_d, then e_c, k_c, tau_c per quadrature point, then last_open_valve.
// t = 0 of every beat is the earliest depolarisation; run() starts from the unloaded mesh,
// inflates it to the atrial pressure of t = 0 and repeats beats until the beat-start state repeats.
class LeftVentricle3D final : public SteppableSimulator, public FieldOutput, public activation::Pacing {
 public:
  // Throws std::invalid_argument for invalid options or parameter names (message says which).
  LeftVentricle3D(LeftVentricle3DOptions options, ParameterSpace parameters);
  explicit LeftVentricle3D(LeftVentricle3DOptions options = {});
  ~LeftVentricle3D() override;

  static ParameterSpace default_parameters();

  std::string name() const override { return "lv-3d"; }
  const ParameterSpace& parameters() const override { return parameters_; }
  std::vector<Channel> channels() const override;
  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<Simulator> clone() const override;

  std::vector<Channel> state_layout() const override;
  SIGMAHEART_STEPPING_OVERRIDES;
  std::unique_ptr<SteppableSimulator> with_time_step_factor(double factor) const override;

  // Activation times [s] at the mesh vertices (ActivationSource::kPrescribed), e.g. from an
  // eikonal solve; std::invalid_argument when the size is not mesh().n_vertices or a value is
  // negative or not finite.
  void set_activation_times(const std::vector<double>& vertex_times);
  // Activation time of every quadrature point (element-major) [s].
  const std::vector<double>& activation_times() const;

  // Pacing (model/activation/pacing.h; docs/models.md s.4.10): the activation of the runs that
  // follow from an eikonal solve with the intrinsic onsets of the configured activation (its
  // pattern, or its vertex times) and the plan's leads, scar blocking (fem/pacing.h). Times stay on
  // the intrinsic clock (a lead firing before the intrinsic onset gives negative times, allowed
  // down to -period). Each call starts again from the intrinsic activation.
  activation::Pacing* pacing() override { return this; }
  activation::PacingOutcome pace(const activation::PacingPlan& plan) override;

  // Fields (model/simulator.h, FieldOutput): `sigmaheart simulate --vtu` keeps the states of the
  // last beat through observe_steps() and writes each with write_fields() (field_document below).
  FieldOutput* fields() override { return this; }
  void observe_steps(StepObserver observer) override { observer_ = std::move(observer); }
  void write_fields(const model::State& state, std::ostream& os) override;

  // ParaView document of a state (docs/models.md s.4.7-4.8): the deformed nodes, point data
  // `displacement` [m] and `hydrostatic_pressure` [Pa] (P1, mid-edge nodes the mean of their
  // edge ends), cell data (means over the quadrature points of each tetrahedron)
  // `activation_time` [s], `active_stress` (BCS tau_c along the fibre) [Pa], `fibre_strain`
  // (Green-Lagrange E_ff) [-], `fibre` (unit vector, reference configuration) and the labels
  // `aha_segment`. Throws std::invalid_argument when the state does not have state_layout()'s size.
  VtuDocument field_document(const model::State& state);

  const Mesh& mesh() const;
  const AhaLabels& labels() const;
  const LeftVentricle3DOptions& options() const { return options_; }
  int n_quadrature_points() const;  // in total

  struct Impl;  // geometry shared by clones (immutable) and per-object caches

 private:
  LeftVentricle3D(const LeftVentricle3D& other, int);  // clone(): shares the geometry only
  Status check_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const;
  RunResult run_checked(const Eigen::Ref<const Eigen::VectorXd>& theta);
  Status advance_checked(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end);
  Status step_to(model::State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end,
                 int* newton_iterations, int* step_cuts);

  LeftVentricle3DOptions options_;
  ParameterSpace parameters_;
  std::unique_ptr<Impl> impl_;
  StepObserver observer_;
};

}  // namespace sigmaheart::model::fem
