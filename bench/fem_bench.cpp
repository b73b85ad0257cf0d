// FEM cost per Newton iteration vs problem size: assembly (residual + tangent) and the sparse
// direct factorisation + solve, on the Land problem 2 ventricle (quadratic tetrahedra, u-p) at
// refinements K = 1, 2, 3; BM_NewtonLinearAlgebra sets the direct solver against the iterative
// one (GMRES + BoomerAMG, model/fem/solver.h). Counters: unknowns, tangent nonzeros, LU factor nonzeros and peak
// resident memory (VmHWM); Complexity() fits the growth rate in the number of unknowns.
// BM_Lv3dGmresIterationBySize: the time of one GMRES iteration per unknown on the stabilised linear
// lv-3d tangent, coarse mesh to 166 000 unknowns (docs/models.md s.4.8, "Cost").
//   build/bench/fem_bench --benchmark_counters_tabular=true
#include "model/fem/fibres.h"
#include "model/fem/land_benchmark.h"
#include "model/fem/material.h"
#include "model/fem/mesh.h"
#include "model/fem/solver.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
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

// The cost of one GMRES iteration of the iterative solver against mesh size, on the tangent of
// the stabilised linear lv-3d discretisation (the human ellipsoid of LeftVentricle3DOptions,
// element_order 1, one quadrature point, 10 MPa bulk modulus, pressure_stabilization 0.1, base
// fixed, Guccione's law, unloaded: the pattern of a beat's tangents). An iteration is a fixed number of passes over arrays that grow
// with the mesh: a BoomerAMG V-cycle on the displacement block, SIMPLE's diagonal on the
// pressures, a product with the tangent and a Gram-Schmidt step. GMRES runs 20 iterations (its
// tolerance set out of reach). Arguments (n_transmural, n_longitudinal, n_circumferential,
// aggressive_levels: 0 or 1, the latter iterative_options_for()'s choice).
// Counters: unknowns, nonzeros of the tangent and of the AMG hierarchy (all levels), GMRES
// iterations to 1e-2 and 1e-8 on the tangent (its_1e-2, its_1e-8), ns per GMRES
// iteration and unknown, and ns per nonzero of one product K x with the tangent alone (Eigen,
// column-major: the GMRES product).
void BM_Lv3dGmresIterationBySize(benchmark::State& st) {
  if (!linear_solver_available(LinearSolver::kAmg)) {
    st.SkipWithError("linear solver amg not built in");
    return;
  }
  const EllipsoidGeometry geometry = EllipsoidGeometry::human();
  EllipsoidMeshOptions mo;
  mo.n_transmural = static_cast<int>(st.range(0));
  mo.n_longitudinal = static_cast<int>(st.range(1));
  mo.n_circumferential = static_cast<int>(st.range(2));
  mo.order = 1;
  const Mesh mesh = ellipsoid_mesh(geometry, mo);
  MechanicsOptions opt;
  opt.bulk_modulus = 1e7;
  opt.quadrature_degree = 1;
  opt.pressure_stabilization = 0.1;
  Mechanics mech(mesh, ellipsoid_fibres(mesh, geometry, FibreOptions{}, 1),
                 std::make_unique<Guccione>(GuccioneParameters{}), opt);
  mech.fix_surface(kBase);
  // The tangent of the unloaded reference, and as right-hand side the load vector of 1 kPa on the
  // endocardium there (at this softness, 10 kPa of follower pressure on the unstrained wall makes
  // the displacement block indefinite, which no beat's equilibrium tangent is).
  const State s = mech.initial_state();
  Eigen::VectorXd R;
  SparseMatrix K;
  if (!mech.assemble(s, Load{1e3, 0.0}, &R, nullptr) || !mech.assemble(s, Load{}, nullptr, &K)) {
    st.SkipWithError("assembly failed");
    return;
  }
  IterativeOptions io = iterative_options_for(opt);
  io.aggressive_levels = static_cast<int>(st.range(3));
  io.relative_tolerance = 1e-15;  // not reached: every solve runs max_iterations
  io.max_iterations = 20;
  SparseSolver solver(LinearSolver::kAmg, io);
  solver.set_saddle_point(3 * mesh.n_nodes());
  if (!solver.factorize(K)) {
    st.SkipWithError("AMG set-up failed");
    return;
  }
  for (auto _ : st) {
    Eigen::VectorXd dx = solver.solve(-R);
    benchmark::DoNotOptimize(dx.data());
  }
  const IterativeStats& is = solver.iterative_stats();
  const double n = static_cast<double>(K.rows());
  // The product alone, timed over enough repetitions for ~0.2 s.
  Eigen::VectorXd x = Eigen::VectorXd::Ones(K.rows()), y(K.rows());
  const int reps = std::max(20, static_cast<int>(2e8 / static_cast<double>(K.nonZeros())));
  const auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < reps; ++r) {
    y.noalias() = K * x;
    benchmark::DoNotOptimize(y.data());
  }
  const double matvec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
  // GMRES iterations to 1e-2 (the beats' inexact Newton) and to 1e-8 on the same tangent.
  for (const double tol : {1e-2, 1e-8}) {
    IterativeOptions to = io;
    to.relative_tolerance = tol;
    to.max_iterations = 1000;
    SparseSolver s2(LinearSolver::kAmg, to);
    s2.set_saddle_point(3 * mesh.n_nodes());
    const bool ok = s2.factorize(K) && s2.solve(-R).allFinite();
    st.counters[tol > 1e-3 ? "its_1e-2" : "its_1e-8"] = ok ? s2.iterative_stats().last_iterations : -1.0;
  }
  st.counters["unknowns"] = n;
  st.counters["tangent_nnz"] = static_cast<double>(K.nonZeros());
  st.counters["amg_nnz"] = static_cast<double>(solver.factor_nonzeros());
  st.counters["ns_per_it_unknown"] = 1e9 * is.solve_seconds / static_cast<double>(is.iterations) / n;
  st.counters["matvec_ns_per_nnz"] = 1e9 * matvec / static_cast<double>(K.nonZeros());
}

BENCHMARK(BM_Lv3dGmresIterationBySize)
    ->ArgsProduct({{1}, {6}, {12}, {0, 1}})->ArgsProduct({{2}, {12}, {24}, {0, 1}})
    ->ArgsProduct({{3}, {18}, {36}, {0, 1}})->ArgsProduct({{4}, {24}, {48}, {0, 1}})
    ->ArgsProduct({{5}, {30}, {60}, {0, 1}})->ArgsProduct({{6}, {36}, {72}, {0, 1}})
    ->ArgsProduct({{8}, {48}, {96}, {0, 1}})
    // One direction refined at a time from the fine mesh (3, 18, 36): around, rings, layers
    // (docs/models.md s.4.8, "Where the iterations grow").
    ->Args({3, 18, 72, 1})->Args({3, 36, 36, 1})->Args({6, 18, 36, 1})
    ->Args({3, 18, 18, 1})->Args({5, 30, 30, 1})->Args({5, 30, 36, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(10);

BENCHMARK(BM_NewtonLinearAlgebra)
    ->ArgsProduct({{1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
BENCHMARK(BM_Assembly)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Iterations(3)->Complexity();
BENCHMARK(BM_LinearSolve)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Iterations(2)->Complexity();

}  // namespace

BENCHMARK_MAIN();
