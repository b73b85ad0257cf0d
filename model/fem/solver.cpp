#include "model/fem/solver.h"

#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
#include <umfpack.h>
#endif
#ifdef SIGMAHEART_FEM_HAVE_HYPRE
// MPI's C interface only (Open MPI and MPICH otherwise pull in their C++ bindings).
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
// hypre's public IJ/ParCSR/BoomerAMG interface; _hypre_parcsr_ls.h only for the data pointer of a
// ParVector and the operators of the AMG levels (factor_nonzeros).
#include <HYPRE.h>
#include <HYPRE_parcsr_ls.h>
#include <_hypre_parcsr_ls.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sigmaheart::model::fem {

using SparseMatrixInt = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

bool linear_solver_available(LinearSolver kind) {
  switch (kind) {
    case LinearSolver::kAuto:
    case LinearSolver::kSparseLU:
      return true;
    case LinearSolver::kUmfPack:
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
      return true;
#else
      return false;
#endif
    case LinearSolver::kAmg:
#ifdef SIGMAHEART_FEM_HAVE_HYPRE
      return true;
#else
      return false;
#endif
  }
  return false;
}

std::string IterativeOptions::validate() const {
  if (!(relative_tolerance > 0 && relative_tolerance < 1)) return "relative_tolerance must be in (0, 1)";
  if (max_iterations < 1) return "max_iterations must be >= 1";
  if (restart < 1) return "restart must be >= 1";
  if (!(strong_threshold > 0 && strong_threshold < 1)) return "strong_threshold must be in (0, 1)";
  if (!(augmentation >= 0) || !std::isfinite(augmentation)) return "augmentation must be finite and >= 0";
  if (schur_cycles < 1) return "schur_cycles must be >= 1";
  if (aggressive_levels < 0) return "aggressive_levels must be >= 0";
  return {};
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The pattern a direct solver analysed (compressed column storage): both direct paths analyse a
// pattern once and again only when the matrix's pattern differs from it.
class AnalysedPattern {
 public:
  bool matches(const SparseMatrixInt& A) const {
    return !ap_.empty() && ap_.size() == static_cast<size_t>(A.cols() + 1) &&
           ai_.size() == static_cast<size_t>(A.nonZeros()) && std::equal(ap_.begin(), ap_.end(), A.outerIndexPtr()) &&
           std::equal(ai_.begin(), ai_.end(), A.innerIndexPtr());
  }
  void store(const SparseMatrixInt& A) {
    ap_.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.cols() + 1);
    ai_.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
  }
  void clear() { ap_.clear(), ai_.clear(); }
  int* outer() { return ap_.data(); }
  int* inner() { return ai_.data(); }
  size_t columns() const { return ap_.empty() ? 0 : ap_.size() - 1; }

 private:
  std::vector<int> ap_, ai_;
};

#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
// UMFPACK (Davis 2004, ACM Trans. Math. Softw. 30:196) through its C interface. The symbolic
// analysis (fill-reducing ordering, frontal structure) is given the pattern only (Ax = NULL: every
// entry counts as nonzero), so it is a function of the pattern alone and one analysis serves every
// matrix of that pattern, as Eigen's SparseLU's does; Eigen's UmfPackLU passes the values and so
// tied each analysis to one matrix. The numeric factorisation still pivots on the values.
class Umfpack {
 public:
  Umfpack() {
    umfpack_di_defaults(control_);
    // The pattern is structurally symmetric: AMD/METIS on A + A^T and a preference for diagonal pivots.
    control_[UMFPACK_STRATEGY] = UMFPACK_STRATEGY_SYMMETRIC;
    // Nested dissection (METIS) fills much less than AMD on 3D quadratic meshes.
    control_[UMFPACK_ORDERING] = UMFPACK_ORDERING_METIS;
    // No iterative refinement (UMFPACK's default is up to 2 steps, each a residual and another pair
    // of triangular solves): the callers are Newton iterations whose own residual test decides, and
    // the refinement was the largest single cost of a heartbeat (experiments/lv3d-solver/NOTES.md,
    // 2026-11-26).
    control_[UMFPACK_IRSTEP] = 0;
  }
  ~Umfpack() {
    if (numeric_) umfpack_di_free_numeric(&numeric_);
    if (symbolic_) umfpack_di_free_symbolic(&symbolic_);
  }
  Umfpack(const Umfpack&) = delete;
  Umfpack& operator=(const Umfpack&) = delete;

  // Numeric factorisation of A; the symbolic analysis on A's pattern the first time, and again only
  // if the pattern changes.
  bool factorize(const SparseMatrixInt& A) {
    if (A.rows() != A.cols()) return false;
    if (!A.isCompressed()) {
      SparseMatrixInt compressed = A;
      compressed.makeCompressed();
      return factorize(compressed);
    }
    const int n = static_cast<int>(A.rows());
    if (numeric_) umfpack_di_free_numeric(&numeric_);
    if (!symbolic_ || !pattern_.matches(A)) {
      if (symbolic_) umfpack_di_free_symbolic(&symbolic_);
      pattern_.store(A);
      if (umfpack_di_symbolic(n, n, pattern_.outer(), pattern_.inner(), nullptr, &symbolic_, control_, info_) !=
          UMFPACK_OK) {
        symbolic_ = nullptr;
        pattern_.clear();
        return false;
      }
      wi_.resize(static_cast<size_t>(n));
      w_.resize(static_cast<size_t>(n));
    }
    const int st =
        umfpack_di_numeric(pattern_.outer(), pattern_.inner(), A.valuePtr(), symbolic_, &numeric_, control_, info_);
    if (st != UMFPACK_OK) {  // includes UMFPACK_WARNING_singular_matrix
      if (numeric_) umfpack_di_free_numeric(&numeric_);
      numeric_ = nullptr;
      return false;
    }
    return true;
  }

  // Without iterative refinement (IRSTEP 0) the solve reads the factors only, not A (umfpack_solve.h).
  Eigen::VectorXd solve(const Eigen::VectorXd& b) {
    Eigen::VectorXd x(b.size());
    if (!numeric_ || static_cast<size_t>(b.size()) != pattern_.columns() ||
        umfpack_di_wsolve(UMFPACK_A, nullptr, nullptr, nullptr, x.data(), b.data(), numeric_, control_, info_,
                          wi_.data(), w_.data()) != UMFPACK_OK)
      x.setConstant(std::numeric_limits<double>::quiet_NaN());
    return x;
  }

  long long factor_nonzeros() const {
    if (!numeric_) return 0;
    int lnz = 0, unz = 0, n_row = 0, n_col = 0, nz_udiag = 0;
    umfpack_di_get_lunz(&lnz, &unz, &n_row, &n_col, &nz_udiag, numeric_);
    return static_cast<long long>(lnz) + unz;
  }

 private:
  double control_[UMFPACK_CONTROL];
  double info_[UMFPACK_INFO];
  void* symbolic_ = nullptr;
  void* numeric_ = nullptr;
  AnalysedPattern pattern_;
  std::vector<int> wi_;       // wsolve workspaces: no allocation per solve
  std::vector<double> w_;
};
#endif

#ifdef SIGMAHEART_FEM_HAVE_HYPRE
// hypre (Debian's libhypre is built with MPI) runs on MPI_COMM_SELF: every solver is serial and
// private to its simulator, so ensemble members on different ranks or threads never talk to each
// other. MPI must be initialised; a process that has no MpiSession (tests, benchmarks) gets it here,
// finalised at exit unless someone else finalised it first. hypre calls MPI (on MPI_COMM_SELF)
// inside its set-up; below MPI_THREAD_MULTIPLE two threads may not do that at the same time, so
// hypre calls are then serialised by a process-wide mutex (uncontended with one thread).
struct HypreRuntime {
  bool serialise = true;
  std::mutex mutex;
  HypreRuntime() {
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) {
      int provided = 0;
      MPI_Init_thread(nullptr, nullptr, MPI_THREAD_MULTIPLE, &provided);
      std::atexit([] {
        int finalised = 0;
        MPI_Finalized(&finalised);
        if (!finalised) MPI_Finalize();
      });
    }
    int level = MPI_THREAD_SINGLE;
    MPI_Query_thread(&level);
    serialise = level < MPI_THREAD_MULTIPLE;
    HYPRE_Init();
  }
};

HypreRuntime& hypre_runtime() {
  static HypreRuntime rt;  // thread-safe initialisation (C++11 magic statics)
  return rt;
}

class HypreLock {
 public:
  explicit HypreLock(HypreRuntime& rt) : lock_(rt.mutex, std::defer_lock) {
    if (rt.serialise) lock_.lock();
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

// A serial hypre ParCSR matrix built from a row-major Eigen matrix, and BoomerAMG on it.
class BoomerAmg {
 public:
  // `functions` unknowns per node (node-major), `cycles` V-cycles per apply(), the first
  // `aggressive_levels` levels coarsened aggressively.
  BoomerAmg(const RowMatrix& A, double strong_threshold, int functions, int cycles, int aggressive_levels = 0) {
    HypreRuntime& rt = hypre_runtime();
    HypreLock lock(rt);
    const HYPRE_BigInt n = static_cast<HYPRE_BigInt>(A.rows());
    HYPRE_IJMatrixCreate(MPI_COMM_SELF, 0, n - 1, 0, n - 1, &ij_);
    HYPRE_IJMatrixSetObjectType(ij_, HYPRE_PARCSR);
    std::vector<HYPRE_Int> ncols(static_cast<size_t>(A.rows()));
    std::vector<HYPRE_BigInt> rows(static_cast<size_t>(A.rows())), cols(static_cast<size_t>(A.nonZeros()));
    for (Eigen::Index r = 0; r < A.rows(); ++r) {
      rows[static_cast<size_t>(r)] = static_cast<HYPRE_BigInt>(r);
      ncols[static_cast<size_t>(r)] = A.outerIndexPtr()[r + 1] - A.outerIndexPtr()[r];
    }
    for (Eigen::Index k = 0; k < A.nonZeros(); ++k) cols[static_cast<size_t>(k)] = A.innerIndexPtr()[k];
    HYPRE_IJMatrixSetRowSizes(ij_, ncols.data());
    HYPRE_IJMatrixInitialize(ij_);
    HYPRE_IJMatrixSetValues(ij_, static_cast<HYPRE_Int>(A.rows()), ncols.data(), rows.data(), cols.data(),
                            A.valuePtr());
    HYPRE_IJMatrixAssemble(ij_);
    HYPRE_IJMatrixGetObject(ij_, reinterpret_cast<void**>(&par_));
    make_vector(n, &ijb_, &b_);
    make_vector(n, &ijx_, &x_);

    HYPRE_BoomerAMGCreate(&amg_);
    HYPRE_BoomerAMGSetPrintLevel(amg_, 0);
    HYPRE_BoomerAMGSetMaxIter(amg_, cycles);  // a fixed number of V-cycles: a preconditioner
    HYPRE_BoomerAMGSetTol(amg_, 0.0);
    // Systems AMG for elasticity, the "unknown approach" (Baker, Kolev & Yang 2010, "Improving
    // algebraic multigrid interpolation operators for linear elasticity problems", Numer. Linear
    // Algebra Appl. 17:495, s.2): 3 functions per node (node-major dofs, hypre's default dof_func),
    // each coarsened and interpolated on its own couplings. The nodal variant (Frobenius norms of
    // the node blocks) took as many iterations on the lv-3d tangents (84 against 90, medium mesh).
    HYPRE_BoomerAMGSetNumFunctions(amg_, functions);
    HYPRE_BoomerAMGSetNodal(amg_, 0);
    HYPRE_BoomerAMGSetStrongThreshold(amg_, strong_threshold);
    HYPRE_BoomerAMGSetCoarsenType(amg_, 10);  // HMIS
    HYPRE_BoomerAMGSetInterpType(amg_, 6);    // extended+i
    HYPRE_BoomerAMGSetPMaxElmts(amg_, 4);
    HYPRE_BoomerAMGSetRelaxType(amg_, 8);     // l1-scaled symmetric Gauss-Seidel: a fixed linear operator
    HYPRE_BoomerAMGSetRelaxOrder(amg_, 0);    // lexicographic order: deterministic
    if (aggressive_levels > 0) {
      // Aggressive coarsening (HMIS applied twice: C-points need strong paths of length two) with
      // multipass interpolation on those levels (Yang 2010, s.3; hypre's agg_interp_type 4).
      HYPRE_BoomerAMGSetAggNumLevels(amg_, aggressive_levels);
      HYPRE_BoomerAMGSetAggInterpType(amg_, 4);
    }
    ok_ = HYPRE_BoomerAMGSetup(amg_, par_, b_, x_) == 0;
    HYPRE_ClearAllErrors();
  }
  ~BoomerAmg() {
    HypreLock lock(hypre_runtime());
    HYPRE_BoomerAMGDestroy(amg_);
    HYPRE_IJVectorDestroy(ijb_);
    HYPRE_IJVectorDestroy(ijx_);
    HYPRE_IJMatrixDestroy(ij_);
  }
  BoomerAmg(const BoomerAmg&) = delete;
  BoomerAmg& operator=(const BoomerAmg&) = delete;

  bool ok() const { return ok_; }

  // z = one V-cycle applied to r (zero initial guess).
  void apply(const double* r, double* z) {
    HypreLock lock(hypre_runtime());
    const size_t n = size();
    std::memcpy(data(b_), r, n * sizeof(double));
    std::memset(data(x_), 0, n * sizeof(double));
    HYPRE_BoomerAMGSolve(amg_, par_, b_, x_);
    std::memcpy(z, data(x_), n * sizeof(double));
  }

  int levels() const { return hypre_ParAMGDataNumLevels(static_cast<hypre_ParAMGData*>(static_cast<void*>(amg_))); }
  long long operator_nonzeros() const {
    auto* data = static_cast<hypre_ParAMGData*>(static_cast<void*>(amg_));
    long long nnz = 0;
    for (int l = 0; l < hypre_ParAMGDataNumLevels(data); ++l) {
      hypre_ParCSRMatrix* Al = hypre_ParAMGDataAArray(data)[l];
      nnz += hypre_CSRMatrixNumNonzeros(hypre_ParCSRMatrixDiag(Al)) + hypre_CSRMatrixNumNonzeros(hypre_ParCSRMatrixOffd(Al));
    }
    return nnz;
  }

 private:
  static void make_vector(HYPRE_BigInt n, HYPRE_IJVector* ij, HYPRE_ParVector* par) {
    HYPRE_IJVectorCreate(MPI_COMM_SELF, 0, n - 1, ij);
    HYPRE_IJVectorSetObjectType(*ij, HYPRE_PARCSR);
    HYPRE_IJVectorInitialize(*ij);
    HYPRE_IJVectorAssemble(*ij);
    HYPRE_IJVectorGetObject(*ij, reinterpret_cast<void**>(par));
  }
  static double* data(HYPRE_ParVector v) {
    return hypre_VectorData(hypre_ParVectorLocalVector(reinterpret_cast<hypre_ParVector*>(v)));
  }
  size_t size() const {
    return static_cast<size_t>(hypre_VectorSize(hypre_ParVectorLocalVector(reinterpret_cast<hypre_ParVector*>(b_))));
  }

  HYPRE_IJMatrix ij_ = nullptr;
  HYPRE_ParCSRMatrix par_ = nullptr;
  HYPRE_IJVector ijb_ = nullptr, ijx_ = nullptr;
  HYPRE_ParVector b_ = nullptr, x_ = nullptr;
  HYPRE_Solver amg_ = nullptr;
  bool ok_ = false;
};

// The factors of the coarse matrix K_c = P^T K P (SparseSolver::set_coarse_space). On lv-3d's
// displacement-only grid (CoarseGrid::kHalfMesh) K_c is symmetric positive definite (measured
// through the beat, docs/solvers.md s.4). There a sparse LDL^T (Eigen's SimplicialLDLT, AMD on the
// symmetric pattern) halves the factors of SparseLU's LU (COLAMD) and their cost: on K_c of the
// (6, 36, 72) mesh (5 841 unknowns) 1.69 M nonzeros in L against 3.50 M in each of L and U,
// factorisation 0.33 s against 0.71 s, a solve 4.7 ms against 8.7 ms. Any other K_c goes to
// SparseLU: nonsymmetric (a tangent without a potential), or indefinite (the wall-mode grid's
// pressure columns; a displacement block under load, as Land's problem 2 at K = 2 and 3, where
// LDL^T without pivoting meets a negative pivot and is not used). Both are sequential, so the
// factors are the same bits with any thread count; each analyses a pattern once and again only
// when it changes.
class CoarseFactors {
 public:
  // False when K_c is singular (neither factorisation succeeded).
  bool factorize(const SparseMatrixInt& Kc) {
    symmetric_ = symmetric_positive_diagonal(Kc);
    if (symmetric_) {
      if (!ldlt_pattern_.matches(Kc)) {
        ldlt_.analyzePattern(Kc);
        ldlt_pattern_.store(Kc);
      }
      ldlt_.factorize(Kc);
      symmetric_ = ldlt_.info() == Eigen::Success && ldlt_.vectorD().allFinite() && ldlt_.vectorD().minCoeff() > 0;
      if (symmetric_) return true;
    }
    if (!lu_) lu_ = std::make_unique<SparseSolver>(LinearSolver::kSparseLU);
    return lu_->factorize(Kc);
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const { return symmetric_ ? Eigen::VectorXd(ldlt_.solve(b)) : lu_->solve(b); }
  // Whether the last factorize() used LDL^T (K_c symmetric positive definite).
  bool symmetric() const { return symmetric_; }

 private:
  // Symmetric to rounding (|K_ij - K_ji| <= 1e-12 max |K|: P^T (K P) sums in another order than
  // its transpose would) with a positive diagonal, as a positive definite matrix has.
  static bool symmetric_positive_diagonal(const SparseMatrixInt& A) {
    if (A.rows() != A.cols() || A.rows() == 0) return false;
    double largest = 0.0;
    for (Eigen::Index c = 0; c < A.outerSize(); ++c)
      for (SparseMatrixInt::InnerIterator it(A, c); it; ++it) largest = std::max(largest, std::abs(it.value()));
    const SparseMatrixInt T = A.transpose();
    const SparseMatrixInt D = A - T;
    for (Eigen::Index c = 0; c < D.outerSize(); ++c)
      for (SparseMatrixInt::InnerIterator it(D, c); it; ++it)
        if (!(std::abs(it.value()) <= 1e-12 * largest)) return false;
    for (Eigen::Index i = 0; i < A.rows(); ++i)
      if (!(A.coeff(i, i) > 0)) return false;
    return true;
  }

  Eigen::SimplicialLDLT<SparseMatrixInt, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
  AnalysedPattern ldlt_pattern_;
  std::unique_ptr<SparseSolver> lu_;
  bool symmetric_ = false;
};
#endif

}  // namespace

struct SparseSolver::Impl {
  AnalysedPattern analysed;  // SparseLU's
  Eigen::SparseLU<SparseMatrixInt, Eigen::COLAMDOrdering<int>> lu;
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  Umfpack umf;
#endif
  // What the setters give the iterative solver (kept, unused, without hypre): the displacement
  // unknowns n_u, the mass M_w of Schur::kMass and the coarse space P.
  int n_u = -1;
  SparseMatrixInt schur_mass;
  SparseMatrixInt coarse_given;
#ifdef SIGMAHEART_FEM_HAVE_HYPRE
  // The iterative solver: K = [A B^T; B C] with A the displacement block (n_u rows), preconditioned
  // through its augmented-Lagrangian form T K with T = [I g B^T W^-1; 0 I] (factorize()).
  // The matrix of the last factorize(), row-major: GMRES's products with it gather along rows
  // (a column-major product scatters, and was four fifths of GMRES's own work;
  // experiments/lv3d-solver/NOTES.md, 2026-11-29).
  RowMatrix K;
  RowMatrix Bt;               // K(0:n_u, n_u:n)
  // With augmentation g > 0 only (empty otherwise, where T = I and B_g^T = B^T):
  RowMatrix Bt_g;             // (T K)(0:n_u, n_u:n) = B^T + g B^T W^-1 C
  Eigen::VectorXd g_winv;     // g / W
  Eigen::VectorXd schur;      // diagonal Schur complement approximation (positive), n_p (kDiagonal)
  Eigen::VectorXd row_scale;  // 1 / max_j |K_ij|: the residual norm of GMRES is on S (b - K x)
  std::unique_ptr<BoomerAmg> amg;
  // The displacement block's exact solve (IterativeOptions::Displacement::kExact) instead of `amg`:
  // a direct solver of this class (UMFPACK when built in, else SparseLU; a pattern analysed once).
  // Kept across set-ups; exact_ok says whether it holds the factors of the last set-up's block.
  std::unique_ptr<SparseSolver> exact;
  bool exact_ok = false;
  std::unique_ptr<BoomerAmg> amg_schur;  // on the sparse Schur approximation (Schur::kSparse, kMass)
  // The coarse correction (set_coarse_space): P as used by the last set-up (coarse_given without
  // the Dirichlet rows and the empty columns; coarse false without a usable coarse space).
  SparseMatrixInt coarse_P;
  RowMatrix coarse_Pt;
  RowMatrix coarse_KP;  // K P: the coarse correction's residual r - K z_c = r - (K P) y without a product with K
  // K_c's factors (CoarseFactors). Dense factors were faster on the fixed 3 x 5 x 8 wall-mode grid
  // (876 unknowns: triangular solves 0.2 ms against SparseLU's 0.35), but a coarse grid that
  // follows the mesh (coarse_space.h, CoarseGrid::kHalfMesh) has 1 467-5 841 unknowns on the lv-3d
  // meshes of 10 384-72 604 unknowns, where dense factors would cost 17-270 MB and O(n_c^3) per set-up.
  CoarseFactors coarse_factors;
  bool coarse = false;

  // z = (the two-level preconditioner) r: with a coarse space, the coarse correction first and the
  // block preconditioner on the residual it leaves (a multiplicative two-level method, as the
  // deflation and balancing preconditioners of Tang, Nabben, Vuik & Erlangga 2009, J. Sci. Comput.
  // 39:340, s.2, here for a nonsymmetric K with the Galerkin coarse matrix P^T K P); without, the
  // block preconditioner alone.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
    if (!coarse) {
      block(r, z);
      return;
    }
    const Eigen::VectorXd y = coarse_factors.solve(coarse_Pt * r);
    block(r - coarse_KP * y, z);
    z += coarse_P * y;
  }

  // z = M r, M = P^-1 T ~ K^-1 with P = [A_g B_g^T; 0 -Shat] ~ T K (block upper triangular).
  void block(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
    const Eigen::Index np = r.size() - n_u;
    z.resize(r.size());
    if (amg_schur) {
      amg_schur->apply(r.data() + n_u, z.data() + n_u);
      z.tail(np) = -z.tail(np);
    } else {
      z.tail(np) = -r.tail(np).cwiseQuotient(schur);
    }
    // With g = 0 (the default) T = I: one product with B^T per application.
    Eigen::VectorXd ru = r.head(n_u);
    if (g_winv.size() > 0) {
      ru += Bt * g_winv.cwiseProduct(r.tail(np));
      ru -= Bt_g * z.tail(np);
    } else {
      ru -= Bt * z.tail(np);
    }
    displacement_solve(ru, z);
  }

  // z(0:n_u) = (the displacement block's preconditioner) ru: one V-cycle, or the exact solve.
  void displacement_solve(const Eigen::VectorXd& ru, Eigen::VectorXd& z) const {
    if (exact_ok)
      z.head(n_u) = exact->solve(ru);
    else
      amg->apply(ru.data(), z.data());
  }
#endif
};

SparseSolver::SparseSolver(LinearSolver kind, IterativeOptions iterative)
    : kind_(kind), iterative_(iterative), impl_(std::make_unique<Impl>()) {
  if (kind_ == LinearSolver::kAmg) {
#ifndef SIGMAHEART_FEM_HAVE_HYPRE
    throw std::invalid_argument("linear solver amg requested but sigmaheart was built without hypre (libhypre-dev)");
#else
    if (const std::string m = iterative_.validate(); !m.empty()) throw std::invalid_argument("IterativeOptions: " + m);
    return;
#endif
  }
#ifndef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack)
    throw std::invalid_argument("linear solver umfpack requested but sigmaheart was built without SuiteSparse");
  kind_ = LinearSolver::kSparseLU;
#else
  if (kind_ == LinearSolver::kAuto) kind_ = LinearSolver::kUmfPack;
#endif
}

SparseSolver::~SparseSolver() = default;

void SparseSolver::set_coarse_space(SparseMatrixInt P) { impl_->coarse_given = std::move(P); }

void SparseSolver::set_schur_mass(SparseMatrixInt Mw) { impl_->schur_mass = std::move(Mw); }

void SparseSolver::set_saddle_point(int n_u) {
  if (n_u < 0 || n_u % 3 != 0)
    throw std::invalid_argument("set_saddle_point: n_u must be a non-negative multiple of 3 (got " + std::to_string(n_u) + ")");
  impl_->n_u = n_u;
}

bool SparseSolver::factorize(const SparseMatrixInt& A) {
#ifdef SIGMAHEART_FEM_HAVE_HYPRE
  if (kind_ == LinearSolver::kAmg) {
    Impl& m = *impl_;
    if (m.n_u < 0 || m.n_u > A.rows() || A.rows() != A.cols()) return false;
    const auto t0 = Clock::now();
    const Eigen::Index n = A.rows(), nu = m.n_u, np = n - nu;
    m.amg.reset();
    m.amg_schur.reset();
    m.exact_ok = false;
    m.K = A;
    const RowMatrix Auu = A.topLeftCorner(nu, nu);
    m.Bt = A.topRightCorner(nu, np);
    const RowMatrix B = A.bottomLeftCorner(np, nu);
    const RowMatrix C = A.bottomRightCorner(np, np);
    const Eigen::VectorXd dA = Auu.diagonal();
    if (!dA.allFinite() || (dA.array() == 0.0).any()) return false;
    // W = diag(B |diag(A)|^-1 B^T): the diagonal Schur complement of SIMPLE (Elman, Howle, Shadid,
    // Shuttleworth & Tuminaro 2008, J. Comput. Phys. 227:1790, s.3), spectrally a lumped pressure
    // mass matrix over the local shear stiffness (the Schur complement approximation of Elman,
    // Silvester & Wathen 2014, Finite Elements and Fast Iterative Solvers, 2nd ed., s.9.2), here
    // without assembly information and following the active and viscous stiffening.
    auto simple_diagonal = [&](const Eigen::VectorXd& d) {
      Eigen::VectorXd w(np);
      const Eigen::VectorXd dinv = d.cwiseAbs().cwiseInverse();
      for (Eigen::Index i = 0; i < np; ++i) {
        double s = 0.0;
        for (RowMatrix::InnerIterator it(B, i); it; ++it) s += it.value() * it.value() * dinv[it.col()];
        w[i] = s > 0 ? s : 1.0;
      }
      return w;
    };
    // The displacement block alone can be indefinite: the pressure's geometric stiffness
    // -p J (F^-T (x) F^-T - ...) softens dilatations and local rotations (Land problem 2 after one
    // Newton step at 2 kPa, K = 1: 24 negative pivots of 2493), and AMG then converges slowly.
    // With augmentation g > 0 the preconditioner is built on the augmented Lagrangian form T K
    // (Benzi & Olshanskii 2006, SIAM J. Sci. Comput. 28:2095; Fortin & Glowinski 1983), whose block
    // A_g = A + g B^T W^-1 B stiffens the dilatations; M = P^-1 T with P ~ T K is then a right
    // preconditioner of K itself. Measured (docs/solvers.md s.3): g = 1 cuts GMRES iterations by
    // 2-5x, but B^T W^-1 B couples the second ring of P2 nodes and has ~7x the nonzeros of A (9.3M
    // against 1.3M on the medium lv-3d mesh), so each V-cycle costs more than it saves: default 0.
    const double gam = iterative_.augmentation;
    const Eigen::VectorXd W = simple_diagonal(dA);
    m.g_winv.resize(0);
    m.Bt_g = RowMatrix();
    if (gam > 0) {
      m.g_winv = gam * W.cwiseInverse();
      m.Bt_g = m.Bt + RowMatrix(m.Bt * m.g_winv.asDiagonal() * C);
    }
    // A_g; without augmentation A itself (a reference, not a copy of the block at every set-up).
    RowMatrix Ag_augmented;
    if (gam > 0) Ag_augmented = Auu + RowMatrix(m.Bt * m.g_winv.asDiagonal() * B);
    const RowMatrix& Ag = gam > 0 ? Ag_augmented : Auu;
    const bool mass_schur = iterative_.schur == IterativeOptions::Schur::kMass;
    const bool sparse_schur = iterative_.schur == IterativeOptions::Schur::kSparse ||
                              (iterative_.schur == IterativeOptions::Schur::kAuto && nu == 3 * np);
    if (!mass_schur && !sparse_schur) {
      // Shat = diag(B |diag(A_g)|^-1 B^T) - diag(C) ~ -(C - B A_g^-1 B_g^T), the SIMPLE diagonal of T K.
      m.schur = simple_diagonal(Ag.diagonal()) - C.diagonal();
      for (Eigen::Index i = 0; i < np; ++i)
        if (!(m.schur[i] > 0)) m.schur[i] = W[i];
    } else {
      RowMatrix Sh;
      if (mass_schur) {
        // S^ = M_w - C: with the grad-div term (Mechanics::schur_mass) the displacement block bounds
        // the divergence, as the Stokes operator does, so B A^-1 B^T is spectrally the pressure mass
        // over the stiffness (Elman, Silvester & Wathen 2014, s.9.2; Benzi & Olshanskii 2006), and
        // -C adds the stabilisation's Laplacian kept whole. Measured on the unloaded stabilised
        // lv-3d tangent (bench/fem_bench BM_Lv3dSchurSpectrum, docs/solvers.md s.3): the true Schur
        // complement against it has its eigenvalues in [0.69, 1.97] / [0.66, 1.98] on the medium /
        // fine mesh, against [0.27, 202] / [0.19, 367] for SIMPLE's diagonal without the term.
        if (m.schur_mass.rows() != np || m.schur_mass.cols() != np) return false;
        Sh = RowMatrix(m.schur_mass) - C;
      } else {
        // The sparse Schur approximation Shat = B |diag(A_g)|^-1 B^T - C, the matrix whose diagonal is
        // SIMPLE's (Elman et al. 2008, s.3). It matters for linear tetrahedra: P1-P1 is not inf-sup
        // stable, so pressure modes q with B^T q ~ 0 make the true Schur complement B A^-1 B^T - C
        // nearly as small as the penalty -C = M_p / kappa on them (ratio kappa / mu ~ 1e3-1e4),
        // which no diagonal represents; B D^-1 B^T vanishes on the same modes. Measured on tangents
        // of the linear lv-3d beat (docs/solvers.md s.3): GMRES to 1e-8 in 80-150 iterations
        // against 290-760 with the diagonal. On Taylor-Hood (P2-P1) its iterations grow faster and
        // its wider stencil costs more (Land problem 2 tangent, K = 1 / 2 / 3: 42 / 69 / 97
        // iterations against 51 / 69 / 76, 0.79 / 1.11 / 1.41x the time), so kAuto keeps the
        // diagonal there.
        const Eigen::VectorXd dinv = Ag.diagonal().cwiseAbs().cwiseInverse();
        Sh = RowMatrix(B * dinv.asDiagonal() * m.Bt) - C;
      }
      // Either matrix is applied by BoomerAMG V-cycles on it (one function per vertex). A row
      // without a positive diagonal (a pressure without volume coupling: empty rows of B and C)
      // gets W_i (1 for an empty row), so that the V-cycle's smoother has a diagonal to invert.
      for (Eigen::Index i = 0; i < np; ++i)
        if (!(Sh.coeff(i, i) > 0)) Sh.coeffRef(i, i) = W[i];
      Sh.makeCompressed();  // BoomerAmg reads the compressed row pointers
      m.amg_schur = std::make_unique<BoomerAmg>(Sh, iterative_.strong_threshold, 1, iterative_.schur_cycles);
      if (!m.amg_schur->ok()) {
        m.amg_schur.reset();
        return false;
      }
    }
    m.row_scale.resize(n);
    std::vector<char> dirichlet(static_cast<size_t>(n), 0);  // identity rows
    {
      const RowMatrix& Kr = m.K;
      for (Eigen::Index i = 0; i < n; ++i) {
        double mx = 0.0;
        int count = 0;
        bool diagonal = false;
        for (RowMatrix::InnerIterator it(Kr, i); it; ++it) {
          mx = std::max(mx, std::abs(it.value()));
          if (it.value() != 0.0) {
            ++count;
            diagonal = diagonal || it.col() == i;
          }
        }
        m.row_scale[i] = mx > 0 ? 1.0 / mx : 1.0;
        dirichlet[static_cast<size_t>(i)] = count == 1 && diagonal;
      }
    }
    m.coarse = false;
    stats_.coarse_size = 0;
    stats_.coarse_symmetric = false;
    if (m.coarse_given.cols() > 0) {
      if (m.coarse_given.rows() != n) return false;
      // P without the Dirichlet rows (the block preconditioner solves those exactly) and without
      // the columns that are then empty; K_c = P^T K P (Galerkin).
      std::vector<Eigen::Triplet<double, int>> trip;
      trip.reserve(static_cast<size_t>(m.coarse_given.nonZeros()));
      int nc = 0;
      for (Eigen::Index c = 0; c < m.coarse_given.cols(); ++c) {
        bool any = false;
        for (SparseMatrixInt::InnerIterator it(m.coarse_given, c); it; ++it)
          if (it.value() != 0.0 && !dirichlet[static_cast<size_t>(it.row())]) {
            trip.emplace_back(static_cast<int>(it.row()), nc, it.value());
            any = true;
          }
        nc += any ? 1 : 0;
      }
      m.coarse_P.resize(n, nc);
      m.coarse_P.setFromTriplets(trip.begin(), trip.end());
      m.coarse_Pt = m.coarse_P.transpose();
      m.coarse_KP = m.K * m.coarse_P;
      // A singular coarse matrix (dependent columns) leaves the block preconditioner alone.
      if (nc > 0) {
        m.coarse = m.coarse_factors.factorize(SparseMatrixInt(m.coarse_Pt * m.coarse_KP));
      }
      if (m.coarse) {
        stats_.coarse_size = nc;
        stats_.coarse_symmetric = m.coarse_factors.symmetric();
      }
    }
    if (iterative_.displacement == IterativeOptions::Displacement::kExact) {
      if (!m.exact) m.exact = std::make_unique<SparseSolver>(LinearSolver::kAuto);
      m.exact_ok = m.exact->factorize(SparseMatrixInt(Ag));
      ++stats_.setups;
      stats_.setup_seconds += seconds_since(t0);
      stats_.amg_levels = 0;
      return m.exact_ok;
    }
    m.amg = std::make_unique<BoomerAmg>(Ag, iterative_.strong_threshold, 3, 1, iterative_.aggressive_levels);
    ++stats_.setups;
    stats_.setup_seconds += seconds_since(t0);
    if (!m.amg->ok()) {
      m.amg.reset();
      return false;
    }
    stats_.amg_levels = m.amg->levels();
    return true;
  }
#endif
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack) return impl_->umf.factorize(A);
#endif
  if (!A.isCompressed()) return factorize(SparseMatrixInt(A));  // the copy comes out compressed
  if (!impl_->analysed.matches(A)) {
    impl_->lu.analyzePattern(A);
    impl_->analysed.store(A);
  }
  impl_->lu.factorize(A);
  return impl_->lu.info() == Eigen::Success;
}

Eigen::VectorXd SparseSolver::solve(const Eigen::VectorXd& b) {
#ifdef SIGMAHEART_FEM_HAVE_HYPRE
  if (kind_ == LinearSolver::kAmg) {
    const Impl& m = *impl_;
    const Eigen::Index n = b.size();
    if (!(m.amg || m.exact_ok) || n != m.K.rows()) return Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
    const auto t0 = Clock::now();
    // Restarted GMRES with right preconditioning (Saad 2003, Iterative Methods for Sparse Linear
    // Systems, 2nd ed., alg. 9.5) on the row-scaled system S K x = S b (S = row_scale): the
    // minimised residual is S (b - K x), in which force and volume rows weigh alike.
    const Eigen::VectorXd& S = m.row_scale;
    const Eigen::VectorXd sb = S.cwiseProduct(b);
    const double bnorm = sb.norm();
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    ++stats_.solves;
    stats_.last_iterations = 0;
    stats_.last_relative_residual = 0.0;
    if (bnorm == 0.0) return x;
    if (!std::isfinite(bnorm)) return Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
    const double target = iterative_.relative_tolerance * bnorm;
    const int mr = iterative_.restart;
    Eigen::MatrixXd V(n, mr + 1), Z(n, mr);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(mr + 1, mr);
    Eigen::VectorXd cs(mr), sn(mr), g(mr + 1), z, w;
    Eigen::VectorXd r = sb;  // S (b - K x) at x = 0
    double beta = bnorm;
    int total = 0;
    bool converged = false;
    while (!converged && total < iterative_.max_iterations) {
      V.col(0) = r / beta;
      g.setZero();
      g(0) = beta;
      H.setZero();
      int j = 0;
      for (; j < mr && total < iterative_.max_iterations; ++j) {
        // w = S K P^-1 v with v = V_j (right preconditioning of the scaled operator S K is
        // P^-1 applied to S^-1 v).
        m.precondition(V.col(j).cwiseQuotient(S), z);
        Z.col(j) = z;
        w = S.cwiseProduct(m.K * z);
        for (int i = 0; i <= j; ++i) {  // modified Gram-Schmidt
          H(i, j) = V.col(i).dot(w);
          w -= H(i, j) * V.col(i);
        }
        H(j + 1, j) = w.norm();
        if (H(j + 1, j) > 0) V.col(j + 1) = w / H(j + 1, j);
        for (int i = 0; i < j; ++i) {  // earlier Givens rotations
          const double t = cs(i) * H(i, j) + sn(i) * H(i + 1, j);
          H(i + 1, j) = -sn(i) * H(i, j) + cs(i) * H(i + 1, j);
          H(i, j) = t;
        }
        const double d = std::hypot(H(j, j), H(j + 1, j));
        cs(j) = d > 0 ? H(j, j) / d : 1.0;
        sn(j) = d > 0 ? H(j + 1, j) / d : 0.0;
        H(j, j) = d;
        H(j + 1, j) = 0.0;
        g(j + 1) = -sn(j) * g(j);
        g(j) = cs(j) * g(j);
        ++total;
        if (std::abs(g(j + 1)) <= target || !(H(j, j) > 0)) {
          ++j;
          break;
        }
      }
      // x += Z y, H(0:j, 0:j) y = g(0:j).
      const Eigen::VectorXd y =
          H.topLeftCorner(j, j).triangularView<Eigen::Upper>().solve(g.head(j));
      x += Z.leftCols(j) * y;
      r = S.cwiseProduct(b - m.K * x);
      beta = r.norm();
      if (!std::isfinite(beta)) break;
      converged = beta <= target;
      if (!converged && j > 0 && !(H(j - 1, j - 1) > 0)) break;  // breakdown without convergence
    }
    stats_.last_iterations = total;
    stats_.iterations += total;
    stats_.last_relative_residual = beta / bnorm;
    stats_.solve_seconds += seconds_since(t0);
    if (!converged) return Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
    return x;
  }
#endif
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack) return impl_->umf.solve(b);
#endif
  return impl_->lu.solve(b);
}

long long SparseSolver::factor_nonzeros() {
#ifdef SIGMAHEART_FEM_HAVE_HYPRE
  if (kind_ == LinearSolver::kAmg) {
    if (impl_->exact_ok) return impl_->exact->factor_nonzeros();
    return impl_->amg ? impl_->amg->operator_nonzeros() : 0;
  }
#endif
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack) return impl_->umf.factor_nonzeros();
#endif
  return static_cast<long long>(impl_->lu.nnzL() + impl_->lu.nnzU());
}

}  // namespace sigmaheart::model::fem
