// Sparse direct solver for the Newton systems: UMFPACK (SuiteSparse) when sigmaheart was built
// with it, Eigen's SparseLU otherwise. Symbolic analysis once per pattern, numeric factorisation
// per call (the pattern of the mechanics tangent never changes).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <memory>

namespace sigmaheart::model::fem {

enum class LinearSolver { kAuto, kSparseLU, kUmfPack };

class SparseDirectSolver {
 public:
  // Throws std::invalid_argument when kUmfPack is requested but not built in.
  explicit SparseDirectSolver(LinearSolver kind = LinearSolver::kAuto);
  ~SparseDirectSolver();
  SparseDirectSolver(const SparseDirectSolver&) = delete;
  SparseDirectSolver& operator=(const SparseDirectSolver&) = delete;

  // false when the matrix is (numerically) singular.
  bool factorize(const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& A);
  Eigen::VectorXd solve(const Eigen::VectorXd& b);
  // Nonzeros of the L and U factors of the last factorisation (memory indicator).
  long long factor_nonzeros();
  LinearSolver kind() const { return kind_; }

 private:
  struct Impl;
  LinearSolver kind_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sigmaheart::model::fem
