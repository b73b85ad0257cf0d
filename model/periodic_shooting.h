// The periodic state of a forced system by Newton-Krylov shooting on its beat map
// (docs/models.md s.2, "The periodic beat"). Every model whose beat is a map x(0) -> x(T) of its
// state over one period uses it; the lumped sphere and the regional model through
// lumped/shell.cpp.
//
// Why not plain beat iteration: x_{k+1} = F(x_k) converges like rho^k, rho the largest eigenvalue
// of dF/dx. The two-stage Windkessel has a distal mode with time constant R_d (C_p + C_d), up to
// 1e5 s in the parameter box against a period of ~1 s, so rho ~ 1 - 1e-5 and thousands of beats do
// not settle; a beat-to-beat change test then stops early at a state that is still far from the
// periodic one, and the outputs step when the beat count changes with the parameters.
//
// Method: Newton's method on G(x) = F(x) - x (Aprille & Trick 1972, Proc IEEE 60:108, "steady-state
// analysis of nonlinear circuits with periodic inputs", the shooting method), the linear systems
// (I - dF/dx) dx = F(x) - x solved by GMRES (Saad & Schultz 1986, SIAM J Sci Stat Comput 7:856)
// with finite-difference directional derivatives of F, one beat each (Jacobian-free Newton-Krylov,
// Knoll & Keyes 2004, J Comput Phys 193:357, eq. 10), and a backtracking line search on |G|
// (Dennis & Schnabel 1996, Numerical Methods for Unconstrained Optimization and Nonlinear
// Equations, s.6.3, alg. A6.3.1). Fast modes (dF/dx eigenvalues near 0) make I - dF/dx close to
// the identity on most of the space, so GMRES needs about as many beats as there are slow modes.
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <functional>
#include <optional>

namespace sigmaheart::model {

struct ShootingOptions {
  int min_beats = 3;         // plain beats before the first Newton step (the fast modes decay)
  int max_beats = 200;       // every beat integrated counts (plain, Krylov, line search)
  double tolerance = 1e-6;   // converged when the Newton correction is below this (scaled, max)
  double fd_step = 1e-6;     // directional-derivative step in scaled units
  int max_krylov = 40;       // GMRES vectors per Newton step (one beat each)
  double krylov_tolerance = 1e-6;  // relative GMRES residual
  // After a converged solve, also measure J = I - dF/dx at the periodic state in scaled units by
  // forward differences (n more beats, not recorded), for a warm start of nearby solves.
  bool jacobian = false;
};

// A warm start (docs/models.md s.2.1, "Warm starts"): the periodic state of a solve at nearby
// parameters, its entry scales and J = I - dF/dx there in those scales. From it, a solve first
// takes chord steps, Newton steps with this fixed J (the chord method: Kelley 1995, Iterative
// Methods for Linear and Nonlinear Equations, SIAM, s.5.4.1): each costs one beat, and they
// converge linearly with a rate of the order of the distance between the two parameter points.
// A chord step that does not halve |G| hands over to the Newton-Krylov iteration of a cold solve.
struct ShootingWarmStart {
  Eigen::VectorXd start;   // the periodic state at t = 0
  Eigen::VectorXd scale;   // its entries' scales
  Eigen::MatrixXd jacobian;  // I - dF/dx at start, scaled (n x n)
  // Flat form [start, scale, J column-major], 2n + n^2 entries, as carried between runs.
  static int packed_size(int n) { return 2 * n + n * n; }
  Eigen::VectorXd pack() const;
  // nullopt when `flat` has the wrong size or is not finite (a failed run's NaN warm start).
  static std::optional<ShootingWarmStart> unpack(const Eigen::VectorXd& flat, int n);
};

// One beat from `start` (the state at t = 0). `record` asks the caller to keep the trajectory of
// this beat: the last recorded beat is always the one whose start find_periodic_state returns.
struct BeatOutcome {
  Status status;
  Eigen::VectorXd end;   // the state at t = T
  Eigen::VectorXd peak;  // max |x_i(t)| over the beat, the scale of entry i
};
using BeatMap = std::function<BeatOutcome(const Eigen::VectorXd& start, bool record)>;

struct ShootingResult {
  Status status;
  Eigen::VectorXd start;  // the periodic state at t = 0 (the last recorded beat starts here)
  int beats = 0;          // beats integrated in total
  int newton_steps = 0;
  double correction = 0.0;  // scaled size of the last Newton correction, or of F(x) - x [-]
  int chord_steps = 0;      // steps taken with a warm start's Jacobian
  // With ShootingOptions::jacobian, after a converged solve: the warm start it offers (else empty).
  std::optional<ShootingWarmStart> warm;
};

// Finds x with F(x) = x from x0. Entries are scaled by their peak over the current beat, so the
// tolerance (and the finite-difference step) is relative to each entry's size in that beat. Fails (kNotPeriodic) when max_beats is spent,
// or with the status of a recorded beat that failed (a failed Krylov or line-search beat only ends
// that Newton step: the method falls back to a plain beat).
// With `warm` (a warm start of the same model, the same n) the solve starts from warm->start with
// chord steps instead of from x0 with plain beats; it converges to the same tolerance.
ShootingResult find_periodic_state(const Eigen::VectorXd& x0, const BeatMap& beat,
                                   const ShootingOptions& options,
                                   const ShootingWarmStart* warm = nullptr);

}  // namespace sigmaheart::model
