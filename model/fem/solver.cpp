#include "model/fem/solver.h"

#include <Eigen/SparseLU>
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
#include <Eigen/UmfPackSupport>
#endif

#include <stdexcept>

namespace sigmaheart::model::fem {

using SparseMatrixInt = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

struct SparseDirectSolver::Impl {
  bool analysed = false;
  Eigen::SparseLU<SparseMatrixInt, Eigen::COLAMDOrdering<int>> lu;
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  Eigen::UmfPackLU<SparseMatrixInt> umf;
#endif
};

SparseDirectSolver::SparseDirectSolver(LinearSolver kind) : kind_(kind), impl_(std::make_unique<Impl>()) {
#ifndef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack)
    throw std::invalid_argument("linear solver umfpack requested but sigmaheart was built without SuiteSparse");
  kind_ = LinearSolver::kSparseLU;
#else
  if (kind_ == LinearSolver::kAuto) kind_ = LinearSolver::kUmfPack;
  // The pattern is structurally symmetric: AMD on A + A^T and a preference for diagonal pivots.
  impl_->umf.umfpackControl()(UMFPACK_STRATEGY) = UMFPACK_STRATEGY_SYMMETRIC;
  // Nested dissection (METIS) fills much less than AMD on 3D quadratic meshes.
  impl_->umf.umfpackControl()(UMFPACK_ORDERING) = UMFPACK_ORDERING_METIS;
#endif
}

SparseDirectSolver::~SparseDirectSolver() = default;

bool SparseDirectSolver::factorize(const SparseMatrixInt& A) {
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack) {
    if (!impl_->analysed) {
      impl_->umf.analyzePattern(A);
      impl_->analysed = true;
    }
    impl_->umf.factorize(A);
    return impl_->umf.info() == Eigen::Success;
  }
#endif
  if (!impl_->analysed) {
    impl_->lu.analyzePattern(A);
    impl_->analysed = true;
  }
  impl_->lu.factorize(A);
  return impl_->lu.info() == Eigen::Success;
}

Eigen::VectorXd SparseDirectSolver::solve(const Eigen::VectorXd& b) {
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack) return impl_->umf.solve(b);
#endif
  return impl_->lu.solve(b);
}

long long SparseDirectSolver::factor_nonzeros() {
#ifdef SIGMAHEART_FEM_HAVE_UMFPACK
  if (kind_ == LinearSolver::kUmfPack)
    return static_cast<long long>(impl_->umf.matrixL().nonZeros() + impl_->umf.matrixU().nonZeros());
#endif
  return static_cast<long long>(impl_->lu.nnzL() + impl_->lu.nnzU());
}

}  // namespace sigmaheart::model::fem
