// Sparse linear solvers for the Newton systems of the mechanics (docs/solvers.md):
//  - direct: UMFPACK (SuiteSparse) when sigmaheart was built with it, Eigen's SparseLU otherwise.
//    Symbolic analysis once per pattern, numeric factorisation per factorize() (the pattern of the
//    mechanics tangent never changes).
//  - iterative (kAmg, when built with hypre): restarted GMRES right-preconditioned by a block
//    upper-triangular preconditioner of the (u, p) saddle point, one BoomerAMG V-cycle on the
//    displacement block and a sparse Schur complement approximation on the pressure block, itself
//    applied by BoomerAMG (solver.cpp says which literature); optionally preceded by a Galerkin
//    coarse correction on a small coarse space (set_coarse_space). It needs the block layout
//    (set_saddle_point) and factorize() builds the preconditioner instead of factors; solve() then
//    solves with the matrix given to factorize().
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <memory>
#include <string>

namespace sigmaheart::model::fem {

enum class LinearSolver { kAuto, kSparseLU, kUmfPack, kAmg };

// Whether `kind` can be used in this build (kUmfPack needs SuiteSparse, kAmg needs hypre).
bool linear_solver_available(LinearSolver kind);

// Options of the iterative solver (kAmg).
struct IterativeOptions {
  double relative_tolerance = 1e-10;  // on the row-equilibrated residual, relative to the rhs
  int max_iterations = 1000;          // GMRES iterations (= preconditioner applications) per solve
  int restart = 60;                   // GMRES restart length (Krylov vectors kept)
  // BoomerAMG strength threshold; 0.25 took the fewest iterations on the lv-3d tangents (medium
  // mesh: 76 against 90 at 0.5) with the smallest hierarchy (1.3x the tangent's nonzeros).
  double strong_threshold = 0.25;
  double augmentation = 0.0;          // g >= 0 of the augmented Lagrangian block A + g B^T W^-1 B (solver.cpp)
  // Schur complement approximation of the pressure block (solver.cpp): kSparse the sparse
  // S^ = B |diag A|^-1 B^T - C, applied by `schur_cycles` BoomerAMG V-cycles; kDiagonal its
  // diagonal (SIMPLE), which misses the spurious pressure modes of P1-P1 elements (GMRES to 1e-8 then
  // takes 290-760 iterations on the linear lv-3d tangents against 80-150); kAuto (default) kSparse
  // for equal-order elements (n_u = 3 n_p: every node carries a pressure) and kDiagonal otherwise
  // (Taylor-Hood, where the sparse form costs more on the larger meshes; docs/solvers.md s.3).
  // kMass: S^ = M_w - C with M_w the pressure mass over the elements' stiffness that the caller
  // gives (set_schur_mass; Mechanics::schur_mass with the grad-div term), applied the same way;
  // with the grad-div term the true Schur complement is spectrally that matrix, whatever the mesh.
  enum class Schur { kAuto, kDiagonal, kSparse, kMass };
  Schur schur = Schur::kAuto;
  int schur_cycles = 2;
  // Levels of the displacement block's hierarchy coarsened aggressively (hypre's aggressive HMIS
  // with multipass interpolation, Yang 2010, "On long-range interpolation operators for aggressive
  // coarsening", Numer. Linear Algebra Appl. 17:453). 0 (default): none. 1 halves the hierarchy of
  // the stabilised linear lv-3d tangents and nearly stops it growing faster than the mesh, at the
  // same GMRES iterations on the unloaded tangent and 20-30 % more in the beat, each cheaper
  // (experiments/lv3d-solver/NOTES.md, "Where the time per iteration goes, and aggressive
  // coarsening"); iterative_options_for() sets it there.
  int aggressive_levels = 0;
  // The displacement block's solve inside the block preconditioner: kVCycle (default) one BoomerAMG
  // V-cycle on it; kExact a sparse LU of it (UMFPACK when built in, else SparseLU), refactorised at
  // every set-up. kExact is a diagnostic: GMRES's iterations then depend on the Schur complement
  // approximation alone (the block-triangular preconditioned saddle point has the eigenvalues of
  // Shat^-1 S besides ones; Elman, Silvester & Wathen 2014, s.9.2), so it tells the approximation's
  // growth with the mesh from the V-cycle's (experiments/lv3d-solver/NOTES.md, "Where the beat's
  // iterations grow"). It costs a factorisation per set-up and triangular solves per iteration.
  enum class Displacement { kVCycle, kExact };
  Displacement displacement = Displacement::kVCycle;
  std::string validate() const;       // empty when valid
};

// Statistics of the iterative solver since construction (zeros for the direct solvers).
struct IterativeStats {
  int setups = 0;                    // preconditioner set-ups (factorize() calls)
  long long solves = 0;              // solve() calls
  long long iterations = 0;          // GMRES iterations over all solves
  int last_iterations = 0;           // of the last solve
  double last_relative_residual = 0; // scaled residual / scaled rhs of the last solve
  int amg_levels = 0;                // of the last set-up (0 with an exact displacement solve)
  int coarse_size = 0;               // coarse unknowns of the last set-up (0: no coarse correction)
  bool coarse_symmetric = false;     // K_c of the last set-up factorised as symmetric positive definite (LDL^T)
  double setup_seconds = 0, solve_seconds = 0;
};

class SparseSolver {
 public:
  // Throws std::invalid_argument when kUmfPack or kAmg is requested but not built in, or when the
  // iterative options are invalid.
  explicit SparseSolver(LinearSolver kind = LinearSolver::kAuto, IterativeOptions iterative = {});
  ~SparseSolver();
  SparseSolver(const SparseSolver&) = delete;
  SparseSolver& operator=(const SparseSolver&) = delete;

  // Block layout of the matrices to come (kAmg only; ignored by the direct solvers): unknowns
  // [0, n_u) are displacements, 3 per node, node-major; [n_u, n) are pressures. Dirichlet rows and
  // columns are identity. std::invalid_argument when n_u is negative or not a multiple of 3.
  void set_saddle_point(int n_u);

  // Coarse space of a two-level preconditioner (kAmg only; ignored by the direct solvers): the
  // columns of P (n x n_c, n_c << n) span the modes the block preconditioner M approximates worst.
  // factorize() then also factorises K_c = P^T K P, and each application of the preconditioner is
  // z = P K_c^-1 P^T r followed by z += M (r - K z) (solver.cpp). Rows of P at the matrix's
  // Dirichlet unknowns (identity rows) are ignored, and so are its empty columns. An empty P (the
  // default) removes the correction. factorize() fails when P's row count is not the matrix's.
  // K_c is factorised sparse (SparseLU: the same bits with any thread count), so the coarse space
  // may grow with the mesh (docs/solvers.md s.4).
  void set_coarse_space(Eigen::SparseMatrix<double, Eigen::ColMajor, int> P);

  // The weighted pressure mass M_w (n_p x n_p, symmetric positive semi-definite) of the Schur
  // complement approximation S^ = M_w - C of IterativeOptions::Schur::kMass, used by the next
  // factorize() (kAmg only; ignored otherwise). factorize() fails with kMass when its size is not
  // the pressure block's.
  void set_schur_mass(Eigen::SparseMatrix<double, Eigen::ColMajor, int> Mw);

  // Direct: LU factorisation; kAmg: the preconditioner of A (kept with a copy of A). false when the
  // matrix is (numerically) singular or, for kAmg, set_saddle_point was not called or hypre failed.
  bool factorize(const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& A);
  // Solution of A x = b for the A of the last factorize(). kAmg: a vector of NaN when GMRES did not
  // reach the tolerance within max_iterations (callers treat a non-finite update as a failure).
  Eigen::VectorXd solve(const Eigen::VectorXd& b);
  // Nonzeros of the L and U factors of the last factorisation (memory indicator); for kAmg the
  // nonzeros of the operators of all AMG levels (with Displacement::kExact, the nonzeros of the
  // displacement block's factors).
  long long factor_nonzeros();
  LinearSolver kind() const { return kind_; }
  const IterativeStats& iterative_stats() const { return stats_; }

 private:
  struct Impl;
  LinearSolver kind_;
  IterativeOptions iterative_;
  IterativeStats stats_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sigmaheart::model::fem
