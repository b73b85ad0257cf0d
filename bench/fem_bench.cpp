// FEM cost per Newton iteration vs problem size: assembly (residual + tangent) and the sparse
// direct factorisation + solve, on the Land problem 2 ventricle (quadratic tetrahedra, u-p) at
// refinements K = 1, 2, 3; BM_NewtonLinearAlgebra sets the direct solver against the iterative
// one (GMRES + BoomerAMG, model/fem/solver.h). Counters: unknowns, tangent nonzeros, LU factor nonzeros and peak
// resident memory (VmHWM); Complexity() fits the growth rate in the number of unknowns.
//   build-fem/bench/fem_bench --benchmark_counters_tabular=true
#include "model/fem/land_benchmark.h"
#include "model/fem/solver.h"

#include <benchmark/benchmark.h>

#include <fstream>
#include <string>

namespace {

using namespace sigmaheart::model::fem;

double peak_rss_mb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

// A representative Newton state: the inflated ventricle after one Newton step at 2 kPa.
struct Problem {
  std::unique_ptr<Mechanics> mech;
  State state;
  Load load{2e3, 0.0};
  explicit Problem(int k) {
    LandOptions o;
    o.problem = 2;
    o.refinement = k;
    mech = land_mechanics(o);
    state = mech->initial_state();
    Eigen::VectorXd R;
    SparseMatrix K;
    mech->assemble(state, load, &R, &K);
    SparseSolver s;
    s.factorize(K);
    const Eigen::VectorXd dx = s.solve(-R);
    state.u += dx.head(state.u.size());
    state.p += dx.tail(state.p.size());
  }
};

void BM_Assembly(benchmark::State& st) {
  Problem p(static_cast<int>(st.range(0)));
  Eigen::VectorXd R;
  SparseMatrix K;
  for (auto _ : st) {
    p.mech->assemble(p.state, p.load, &R, &K);
    benchmark::DoNotOptimize(R.data());
  }
  st.SetComplexityN(p.mech->n_unknowns());
  st.counters["unknowns"] = p.mech->n_unknowns();
  st.counters["tangent_nnz"] = static_cast<double>(K.nonZeros());
}

void BM_LinearSolve(benchmark::State& st) {
  Problem p(static_cast<int>(st.range(0)));
  Eigen::VectorXd R;
  SparseMatrix K;
  p.mech->assemble(p.state, p.load, &R, &K);
  SparseSolver solver;
  solver.factorize(K);  // symbolic analysis outside the timing, as in Newton
  for (auto _ : st) {
    solver.factorize(K);
    Eigen::VectorXd dx = solver.solve(-R);
    benchmark::DoNotOptimize(dx.data());
  }
  st.SetComplexityN(p.mech->n_unknowns());
  st.counters["unknowns"] = p.mech->n_unknowns();
  st.counters["factor_nnz"] = static_cast<double>(solver.factor_nonzeros());
  st.counters["peak_rss_MB"] = peak_rss_mb();
}

// One Newton iteration's linear algebra, direct against iterative: (re)factorisation or AMG set-up
// plus one solve, on the tangent of Land problem 2 inflated to 1 kPa (converged, two load steps).
// Arguments: refinement K; solver (0 UMFPACK or SparseLU when built without it, 1 GMRES + BoomerAMG).
// Counters: unknowns, GMRES iterations, factor or AMG-hierarchy nonzeros.
struct ConvergedProblem {
  std::unique_ptr<Mechanics> mech;
  SparseMatrix K;
  Eigen::VectorXd R;
  explicit ConvergedProblem(int k) {
    LandOptions o;
    o.problem = 2;
    o.refinement = k;
    o.load_steps = 2;
    mech = land_mechanics(o);
    State s = mech->initial_state();
    mech->solve(s, Load{}, Load{1e3, 0.0});
    // The tangent there and the residual of a 10 % larger load: a right-hand side of Newton's.
    mech->assemble(s, Load{1.1e3, 0.0}, &R, &K);
  }
};

void BM_NewtonLinearAlgebra(benchmark::State& st) {
  const LinearSolver kind = st.range(1) == 0 ? LinearSolver::kAuto : LinearSolver::kAmg;
  if (!linear_solver_available(kind)) {
    st.SkipWithError("linear solver not built in");
    return;
  }
  ConvergedProblem p(static_cast<int>(st.range(0)));
  SparseSolver solver(kind);
  solver.set_saddle_point(static_cast<int>(p.mech->mesh().n_nodes()) * 3);
  solver.factorize(p.K);  // symbolic analysis outside the timing, as in Newton
  for (auto _ : st) {
    solver.factorize(p.K);
    Eigen::VectorXd dx = solver.solve(-p.R);
    if (!dx.allFinite()) {
      st.SkipWithError("solve failed");
      break;
    }
    benchmark::DoNotOptimize(dx.data());
  }
  st.SetComplexityN(p.mech->n_unknowns());
  st.counters["unknowns"] = p.mech->n_unknowns();
  st.counters["gmres_its"] = solver.iterative_stats().last_iterations;
  st.counters["factor_nnz"] = static_cast<double>(solver.factor_nonzeros());
  st.counters["tangent_nnz"] = static_cast<double>(p.K.nonZeros());
}

BENCHMARK(BM_NewtonLinearAlgebra)
    ->ArgsProduct({{1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
BENCHMARK(BM_Assembly)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Iterations(3)->Complexity();
BENCHMARK(BM_LinearSolve)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Iterations(2)->Complexity();

}  // namespace

BENCHMARK_MAIN();
