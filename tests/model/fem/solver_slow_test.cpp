// The iterative solver (GMRES + BoomerAMG block preconditioner, model/fem/solver.h) against the
// direct one on whole problems (slow tier): Land problem 2 at K = 2 and one beat of the 3D model on
// the coarse mesh. The fast checks are in solver_test.cpp.
#include "model/fem/electromechanics.h"
#include "model/fem/land_benchmark.h"
#include "model/fem/solver.h"

#include <gtest/gtest.h>

namespace sigmaheart::model::fem {
namespace {

TEST(SparseSolverSlow, LandProblem2AtK2PutsTheApexWithin1e6MmOfTheDirectSolution) {
  if (!linear_solver_available(LinearSolver::kAmg)) GTEST_SKIP() << "built without hypre";
  LandResult r[2];
  for (int k = 0; k < 2; ++k) {
    LandOptions o;
    o.problem = 2;
    o.refinement = 2;
    o.linear_solver = k == 0 ? LinearSolver::kAuto : LinearSolver::kAmg;
    r[k] = run_land_problem(o);
    ASSERT_TRUE(r[k].summary.converged) << r[k].summary.brief_report();
  }
  EXPECT_NEAR(r[1].primary, r[0].primary, 1e-6);      // endocardial apex z [mm]
  EXPECT_NEAR(r[1].secondary, r[0].secondary, 1e-6);  // epicardial apex z [mm]
}

// The iterative solver at its default GMRES tolerance (1e-10) and as an inexact Newton method
// (linear_tolerance 1e-2): Newton's own test on the scaled residual decides convergence in both, so
// the curves agree with the direct solver's alike.
TEST(SparseSolverSlow, Lv3dCoarseBeatCurvesAgreeWithTheDirectSolverTo1e6) {
  if (!linear_solver_available(LinearSolver::kAmg)) GTEST_SKIP() << "built without hypre";
  RunResult r[3];
  for (int k = 0; k < 3; ++k) {
    LeftVentricle3DOptions o;
    o.max_beats = 1;
    o.periodic_tolerance = 1.0;
    o.linear_solver = k == 0 ? LinearSolver::kSparseLU : LinearSolver::kAmg;
    if (k == 2) o.linear_tolerance = 1e-2;
    LeftVentricle3D lv(o);
    r[k] = lv.run(lv.parameters().nominal());
    ASSERT_TRUE(r[k].status.ok()) << r[k].status.message;
  }
  for (int k = 1; k < 3; ++k) {
    ASSERT_EQ(r[k].trajectory.times.size(), r[0].trajectory.times.size());
    for (const char* name : {"V_lv", "P_lv", "P_ar"}) {
      const Eigen::VectorXd a = r[0].trajectory.channel(name), b = r[k].trajectory.channel(name);
      EXPECT_LE((b - a).cwiseAbs().maxCoeff(), 1e-6 * a.cwiseAbs().maxCoeff()) << name << ", solver " << k;
    }
  }
}

}  // namespace
}  // namespace sigmaheart::model::fem
