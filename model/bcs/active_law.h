// The Bestel-Clement-Sorine (BCS) active law for one material point (docs/models.md section 1).
//
// Rheology (Chapelle et al. 2012, "An energy-preserving muscle tissue model", IJMCE 10:189,
// eqs. for the active branch; the finite-strain form of Bestel, Clement & Sorine 2001): a series
// element of stiffness Es in series with a contractile element (strain e_c, stress
// tau_c + mu de_c/dt, stiffness k_c). Multiplicative split 1 + 2e = (1 + 2e_c)(1 + 2e_s).
//
// This file is deliberately small and model-agnostic: the lumped sphere owns one ActiveState,
// the 17-patch model one per patch (each with its own sigma0 and T_d), the 3D model one per
// quadrature point. The caller owns time stepping and assembly; this file gives the discrete
// residual of one backward-Euler step and its exact derivatives, so that the caller can either
//   (a) solve the three active unknowns jointly with its own unknowns (what LumpedSphere does), or
//   (b) condense them locally with condense_step() and use the consistent tangent dS/de (3D).
//
// Time discretisation (backward Euler, first order): with v_c = (e_c - e_c^n)/h,
//   R_e   = (tau_c + mu v_c)(1 + 2e_c)^3 - Es (e - e_c)(1 + 2e)                        [Pa]
//   R_k   = (k_c - k_c^n)/h + (ubar + alpha |v_c|) k_c - n0 k0 ubar_plus               [Pa/s]
//   R_tau = (tau_c - tau_c^n)/h + (ubar + alpha |v_c|) tau_c - k_c v_c - n0 sigma0 ubar_plus
// all unknowns at t^{n+1}, e the fibre Green-Lagrange strain at t^{n+1}. The activation enters
// through its exact average over the step (ubar = mean of |u|, ubar_plus = mean of |u|_+), so
// a depolarisation or repolarisation falling inside a step is not rounded to the grid. The
// active 2nd Piola-Kirchhoff fibre stress is sigma_1D = Es (e - e_c)/(1 + 2e_c)^2.
// Backward Euler is unconditionally stable for the stiff e_c relaxation (time constant mu/Es,
// about 20 us for the default parameters) and dissipative; the 0D tests check its order (1).
// Length dependence n0(e_c): by default n0 = 1 (the classical law). The piecewise-linear n0 of
// Caruel et al. 2014 could not be verified here (abscissa and breakpoints), so it is not
// reproduced. Instead an optional ascending-limb ramp n0 = clamp(1 - n0_slope (n0_e_max - e_c),
// 0, 1) is offered (n0_slope = 0 switches it off): length-dependent activation is what gives a
// Frank-Starling response at the organ level (Kosta & Dauby 2021, PLoS Comput Biol
// 17:e1009469); its two constants are modelling choices, not published values.
#pragma once

#include <Eigen/Core>

#include <string>

namespace sigmaheart::model::bcs {

// The shape of the activation input u(t) in the time since depolarisation s = (t - T_d) mod period
// (docs/models.md s.1, "Activation input").
enum class ActivationShape {
  // Two levels (the default): u = +k_ATP for s < APD, -k_RS otherwise (Bestel et al. 2001).
  kSquare,
  // Piecewise linear, after the u(t) of Caruel et al. 2014 (Biomech Model Mechanobiol 13:897, s.2.1,
  // the "reaction rate" input of the sarcomere model; its values as tabulated for an 0.8 s cycle in
  // svZeroDSolver's test case chamber_sphere_straindependent_Caruel.json: u = -3.2, 35, 35, 0, -12,
  // -12, -3.2 1/s at t = 0.10, 0.27, 0.32, 0.34, 0.46, 0.59, 0.60 s). In our parameters (k_ATP = 35,
  // k_RS = 12, APD = 0.24 s reproduce that table exactly) the knots are, in s:
  //   0: -rest k_RS -> rise APD: k_ATP -> (1 - fall) APD: k_ATP -> APD: 0
  //   -> APD + relax_ramp: -k_RS -> + relax_hold: -k_RS -> + rest_ramp: -rest k_RS, held to the period.
  // Knots past the period are cut there (the next depolarisation starts the profile again). The
  // contraction rate builds up over most of the action potential instead of jumping to k_ATP, so
  // the isovolumic contraction lasts longer and dP/dt max is lower (docs/models.md s.1).
  kRamped,
};
const char* to_string(ActivationShape shape);

// The knots of ActivationShape::kRamped; defaults from Caruel et al. 2014 as above.
struct RampedActivation {
  double rise = 0.17 / 0.24;   // fraction of APD over which u climbs to k_ATP [-]
  double fall = 0.02 / 0.24;   // fraction of APD over which u falls from k_ATP to 0 [-]
  double relax_ramp = 0.12;    // [s] from 0 (at APD) to -k_RS
  double relax_hold = 0.13;    // [s] at -k_RS
  double rest_ramp = 0.01;     // [s] from -k_RS to the diastolic rate
  double rest = 3.2 / 12.0;    // diastolic rate as a fraction of k_RS [-]
};

struct ActivationInput {
  ActivationShape shape = ActivationShape::kSquare;
  RampedActivation ramp;  // used by kRamped
  // Empty when valid, else a message naming the field.
  std::string validate() const;
};

// Parameters of the active law, SI. Defaults: the CCMLC2014-like working set of docs/models.md s.2
// (after Caruel et al. 2014 Table 1 / Chapelle et al. 2012), to be tuned per model.
struct ActiveParameters {
  double Es = 3e6;        // series-element stiffness [Pa]
  double mu = 70.0;       // contractile-element viscosity [Pa s]
  double alpha = 1.5;     // cross-bridge destruction by fast sliding [-]
  double k0 = 1e5;        // maximal active stiffness [Pa]
  double sigma0 = 1.25e5; // contractility: maximal active stress [Pa]
  double k_ATP = 35.0;    // activation rate during the action potential [1/s]
  double k_RS = 20.0;     // relaxation rate after repolarisation [1/s]
  double APD = 0.3;       // action-potential duration [s]
  double n0_slope = 0.0;  // length-dependence gain dn0/de_c on the ramp [-]; 0: n0 = 1
  double n0_e_max = 0.0;  // contractile strain where n0 reaches 1 [-]
  ActivationInput input;  // shape of u(t); a numerics choice of the model, not a parameter
  // Empty when valid, else a message naming the first bad field.
  std::string validate() const;
};

// The internal variables of the contractile element at one material point.
struct ActiveState {
  double e_c = 0.0;    // contractile-element strain [-]
  double k_c = 0.0;    // active stiffness [Pa]
  double tau_c = 0.0;  // active stress of the contractile element [Pa]
};

// Step averages of the activation input u over [t0, t1] (docs/models.md s.1: u = +k_ATP while
// T_d <= t mod period < T_d + APD, -k_RS otherwise; or the ramped profile of ActivationShape).
struct StepActivation {
  double u_abs = 0.0;   // mean of |u| over the step [1/s]
  double u_plus = 0.0;  // mean of max(u, 0) over the step [1/s]
};

// Fraction of [t0, t1] (t1 > t0) spent inside the windows [T_d + m period, T_d + APD + m period)
// for every integer m. Works for any T_d (also T_d + APD > period) and any step position.
double active_fraction(double t0, double t1, double T_d, double APD, double period);

// u at the instant t (square: k_ATP inside the window, -k_RS outside; ramped: the profile).
double activation(double t, double T_d, double period, const ActiveParameters& p);

// The exact step averages of any shape: for kSquare from active_fraction, for kRamped the integrals
// of |u| and max(u, 0) of the piecewise-linear profile over [t0, t1] (split at its knots and at its
// zeros), so a knot inside a step is not rounded to the grid either.

StepActivation step_activation(double t0, double t1, double T_d, double period,
                               const ActiveParameters& p);

// The Frank-Starling factor n0(e_c) in [0, 1] and its derivative (see the file comment).
double length_factor(double e_c, const ActiveParameters& p, double* derivative = nullptr);

// sigma_1D = Es (e - e_c)/(1 + 2e_c)^2 [Pa] (2nd Piola-Kirchhoff, along the fibre).
double active_stress(double e, double e_c, double Es);

// The residual of one backward-Euler step and its derivatives. Unknown order: (e_c, k_c, tau_c).
struct ActiveStep {
  Eigen::Vector3d residual;        // (R_e [Pa], R_k [Pa/s], R_tau [Pa/s])
  Eigen::Matrix3d d_state;         // dR/d(e_c, k_c, tau_c)
  Eigen::Vector3d d_strain;        // dR/de (fibre strain at t^{n+1})
  double stress = 0.0;             // sigma_1D at t^{n+1} [Pa]
  double dstress_dstrain = 0.0;    // d sigma_1D / de
  Eigen::RowVector3d dstress_dstate;  // d sigma_1D / d(e_c, k_c, tau_c)
};

ActiveStep step_residual(const ActiveParameters& p, const ActiveState& previous,
                         const ActiveState& trial, double e, const StepActivation& act,
                         double h);

// The rate equations R_k = R_tau = 0 are linear in (k_c, tau_c) once e_c is known, so a step can
// be reduced to the single unknown e_c: k_c(e_c), tau_c(e_c) in closed form and their derivatives.
// The remaining residual is R_e(e_c, tau_c(e_c), e). Used by the lumped sphere (a 4x4 Newton
// system instead of 8x8) and by condense_step().
struct ReducedStep {
  ActiveState state;          // (e_c, k_c(e_c), tau_c(e_c))
  double dk_dec = 0.0;        // d k_c / d e_c
  double dtau_dec = 0.0;      // d tau_c / d e_c
  double residual = 0.0;      // R_e [Pa]
  double dres_dec = 0.0;      // total d R_e / d e_c (through tau_c too)
  double dres_de = 0.0;       // d R_e / d e
  double stress = 0.0;        // sigma_1D [Pa]
  double dstress_dec = 0.0;   // d sigma_1D / d e_c
  double dstress_de = 0.0;    // d sigma_1D / d e
};
ReducedStep reduced_step(const ActiveParameters& p, const ActiveState& previous, double e_c,
                         double e, const StepActivation& act, double h);

// Local (condensed) solve: finds the active state at t^{n+1} for a given fibre strain e (a scalar
// Newton on R_e through reduced_step) and returns the stress and the consistent tangent
// d sigma_1D/de (for 3D assembly per quadrature point). Returns false when the local Newton did
// not converge in max_iterations (state then holds the last iterate).
struct CondensedStep {
  ActiveState state;
  double stress = 0.0;
  double tangent = 0.0;  // total derivative d sigma_1D / de [Pa]
  int iterations = 0;
};
bool condense_step(const ActiveParameters& p, const ActiveState& previous, double e,
                   const StepActivation& act, double h, CondensedStep& out,
                   int max_iterations = 30, double tolerance = 1e-12);

// Power density dissipated by the contractile-element viscosity, mu v_c^2 >= 0 [W/m^3].
inline double contractile_dissipation(double mu, double v_c) { return mu * v_c * v_c; }

}  // namespace sigmaheart::model::bcs
