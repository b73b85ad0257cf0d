// FEM cost per Newton iteration vs problem size: assembly (residual + tangent) and the sparse
// direct factorisation + solve, on the Land problem 2 ventricle (quadratic tetrahedra, u-p) at
// refinements K = 1, 2, 3; BM_NewtonLinearAlgebra sets the direct solver against the iterative
// one (GMRES + BoomerAMG, model/fem/solver.h). Counters: unknowns, tangent nonzeros, LU factor nonzeros and peak
// resident memory (VmHWM); Complexity() fits the growth rate in the number of unknowns.
// BM_Lv3dGmresIterationBySize: the time of one GMRES iteration per unknown on the stabilised linear
// lv-3d tangent, coarse mesh to 166 000 unknowns (docs/solvers.md s.5;
// experiments/lv3d-solver/NOTES.md).
//   build/bench/fem_bench --benchmark_counters_tabular=true
// BM_Lv3dSchurSpectrum: the eigenvalues of the pressure Schur complement against its approximation
// on the same tangent, and the GMRES iterations they imply (experiments/lv3d-solver/NOTES.md, "The
// spectrum of the Schur approximation"; about 10 minutes):
//   build/bench/fem_bench --benchmark_filter=SchurSpectrum --benchmark_counters_tabular=true
#include "model/fem/fibres.h"
#include "model/fem/land_benchmark.h"
#include "model/fem/material.h"
#include "model/fem/mesh.h"
#include "model/fem/solver.h"

#include <benchmark/benchmark.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

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

// The tangent of the stabilised linear lv-3d discretisation on the human ellipsoid (element_order
// 1, one quadrature point, 10 MPa bulk modulus, pressure_stabilization 0.1, base fixed, Guccione's
// law) in the unloaded reference, and as right-hand side the load vector of 1 kPa on the
// endocardium there (at this softness, 10 kPa of follower pressure on the unstrained wall makes
// the displacement block indefinite, which no beat's equilibrium tangent is). Mesh arguments 0-2:
// (n_transmural, n_longitudinal, n_circumferential).
struct Lv3dTangent {
  std::unique_ptr<Mechanics> mech;
  SparseMatrix K;
  Eigen::VectorXd R;
  bool ok = false;
  explicit Lv3dTangent(const benchmark::State& st, double grad_div = 0.0) {
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
    opt.grad_div = grad_div;
    mech = std::make_unique<Mechanics>(mesh, ellipsoid_fibres(mesh, geometry, FibreOptions{}, 1),
                                       std::make_unique<Guccione>(GuccioneParameters{}), opt);
    mech->fix_surface(kBase);
    const State s = mech->initial_state();
    ok = mech->assemble(s, Load{1e3, 0.0}, &R, nullptr) && mech->assemble(s, Load{}, nullptr, &K);
  }
};

// The cost of one GMRES iteration of the iterative solver against mesh size, on the tangent of
// Lv3dTangent (the pattern of a beat's tangents). An iteration is a fixed number of passes over arrays that grow
// with the mesh: a BoomerAMG V-cycle on the displacement block, SIMPLE's diagonal on the
// pressures, a product with the tangent and a Gram-Schmidt step. GMRES runs 20 iterations (its
// tolerance set out of reach). Arguments (n_transmural, n_longitudinal, n_circumferential,
// aggressive_levels: 0 or 1, the latter iterative_options_for()'s choice; grad_div beta: 0 or 1,
// with 1 the Schur approximation is iterative_options_for()'s kMass).
// Counters: unknowns, nonzeros of the tangent and of the AMG hierarchy (all levels), GMRES
// iterations to 1e-2 and 1e-8 on the tangent (its_1e-2, its_1e-8), ns per GMRES
// iteration and unknown, and ns per nonzero of one product K x with the tangent alone (Eigen,
// column-major: the GMRES product).
void BM_Lv3dGmresIterationBySize(benchmark::State& st) {
  if (!linear_solver_available(LinearSolver::kAmg)) {
    st.SkipWithError("linear solver amg not built in");
    return;
  }
  const Lv3dTangent t(st, static_cast<double>(st.range(4)));
  if (!t.ok) {
    st.SkipWithError("assembly failed");
    return;
  }
  const Mesh& mesh = t.mech->mesh();
  const SparseMatrix& K = t.K;
  const SparseMatrix Mw = t.mech->schur_mass();
  const Eigen::VectorXd& R = t.R;
  IterativeOptions io = iterative_options_for(t.mech->options());
  io.aggressive_levels = static_cast<int>(st.range(3));
  io.relative_tolerance = 1e-15;  // not reached: every solve runs max_iterations
  io.max_iterations = 20;
  SparseSolver solver(LinearSolver::kAmg, io);
  solver.set_saddle_point(3 * mesh.n_nodes());
  solver.set_schur_mass(Mw);
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
  // The same product row-major (GMRES's, solver.cpp): a kernel whose work is exactly linear in the
  // nonzeros, so its time per nonzero against size is this machine's memory hierarchy alone
  // (experiments/lv3d-solver/NOTES.md, "What a linear kernel costs on this machine").
  const Eigen::SparseMatrix<double, Eigen::RowMajor, int> Kr = K;
  const auto t1 = std::chrono::steady_clock::now();
  for (int r = 0; r < reps; ++r) {
    y.noalias() = Kr * x;
    benchmark::DoNotOptimize(y.data());
  }
  const double row_matvec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count() / reps;
  // GMRES iterations to 1e-2 (the beats' inexact Newton) and to 1e-8 on the same tangent.
  for (const double tol : {1e-2, 1e-8}) {
    IterativeOptions to = io;
    to.relative_tolerance = tol;
    to.max_iterations = 1000;
    SparseSolver s2(LinearSolver::kAmg, to);
    s2.set_saddle_point(3 * mesh.n_nodes());
    s2.set_schur_mass(Mw);
    const bool ok = s2.factorize(K) && s2.solve(-R).allFinite();
    st.counters[tol > 1e-3 ? "its_1e-2" : "its_1e-8"] = ok ? s2.iterative_stats().last_iterations : -1.0;
  }
  st.counters["unknowns"] = n;
  st.counters["tangent_nnz"] = static_cast<double>(K.nonZeros());
  st.counters["amg_nnz"] = static_cast<double>(solver.factor_nonzeros());
  st.counters["ns_per_it_unknown"] = 1e9 * is.solve_seconds / static_cast<double>(is.iterations) / n;
  st.counters["matvec_ns_per_nnz"] = 1e9 * matvec / static_cast<double>(K.nonZeros());
  st.counters["row_matvec_ns_per_nnz"] = 1e9 * row_matvec / static_cast<double>(K.nonZeros());
}

// GMRES's iterations to the relative residual `tol` (at most 400) on diag(lambda) x = 1: the
// first k at which the polynomial of degree k with p(0) = 1 minimising ||p(Lambda) 1|| gets there. With lambda the
// eigenvalues of Shat^-1 S and an exact displacement solve, the block-triangular preconditioned
// saddle point has these eigenvalues (and ones), so this models GMRES's iterations from the
// spectrum alone (Elman, Silvester & Wathen 2014, s.9.2; normal-matrix model, no rounding).
int gmres_iterations_on_spectrum(const Eigen::VectorXd& lambda, double tol) {
  const Eigen::Index n = lambda.size();
  const int kmax = 400;
  Eigen::MatrixXd V(n, kmax + 1), H = Eigen::MatrixXd::Zero(kmax + 1, kmax);
  const double beta = std::sqrt(static_cast<double>(n));
  V.col(0) = Eigen::VectorXd::Ones(n) / beta;
  for (int k = 0; k < kmax; ++k) {
    Eigen::VectorXd w = lambda.cwiseProduct(V.col(k));
    for (int pass = 0; pass < 2; ++pass)  // Gram-Schmidt twice
      for (int i = 0; i <= k; ++i) {
        const double h = V.col(i).dot(w);
        H(i, k) += h;
        w -= h * V.col(i);
      }
    H(k + 1, k) = w.norm();
    if (H(k + 1, k) > 0) V.col(k + 1) = w / H(k + 1, k);
    Eigen::VectorXd e = Eigen::VectorXd::Zero(k + 2);
    e(0) = beta;
    const Eigen::MatrixXd Hk = H.topLeftCorner(k + 2, k + 1);
    const Eigen::VectorXd y = Hk.colPivHouseholderQr().solve(e);
    if ((e - Hk * y).norm() <= tol * beta || !(H(k + 1, k) > 0)) return k + 1;
  }
  return kmax;
}

// The spectrum of the pressure Schur complement of Lv3dTangent against its approximation in the
// iterative solver, where GMRES's iterations grow with the mesh (experiments/lv3d-solver/NOTES.md,
// "Where the iterations grow"). The exact S = B A^-1 B^T - C (A^-1 by UMFPACK, one solve per
// pressure unknown; A is symmetric in the unloaded reference), and Shat either SIMPLE's diagonal
// diag(B |diag A|^-1 B^T) - diag C (argument 3 = 0, the solver's choice with the stabilisation) or
// diag(B |diag A|^-1 B^T) - C, the stabilisation's Laplacian kept whole (1), or, on the tangent with
// the grad-div term (grad_div 1), the solver's kMass approximation Mechanics::schur_mass() - C (2;
// docs/solvers.md s.3). Dense generalized
// eigenproblem S v = lambda Shat v (Eigen), so up to ~5 000 pressure unknowns. Counters: the
// extreme eigenvalues; how many lie below 0.3 and above 3; the GMRES iterations that the spectrum
// implies to 1e-2 and 1e-8 (gmres_iterations_on_spectrum), and to 1e-2 with the 20 largest
// replaced by 1 (what a coarse correction of those modes could give); where the 10 smallest and
// the 10 largest modes sit, up to 3 000 pressure unknowns: the v^2-weighted mean height above the
// apex [mm] and the mean share of v^2 on the inner vertex layers against the endo- and epicardial
// ones (transmural shape).
void BM_Lv3dSchurSpectrum(benchmark::State& st) {
  const Lv3dTangent t(st, st.range(3) == 2 ? 1.0 : 0.0);
  if (!t.ok) {
    st.SkipWithError("assembly failed");
    return;
  }
  const Mesh& mesh = t.mech->mesh();
  const Eigen::Index n = t.K.rows(), nu = 3 * mesh.n_nodes(), np = n - nu;
  const SparseMatrix A = t.K.topLeftCorner(nu, nu), Bt = t.K.topRightCorner(nu, np);
  const SparseMatrix B = t.K.bottomLeftCorner(np, nu), C = t.K.bottomRightCorner(np, np);
  Eigen::VectorXd lambda;
  Eigen::MatrixXd modes;
  bool with_modes = false;
  for (auto _ : st) {
    SparseSolver direct(LinearSolver::kAuto);
    if (!direct.factorize(A)) {
      st.SkipWithError("factorisation failed");
      return;
    }
    Eigen::MatrixXd Y(nu, np);
    for (Eigen::Index j = 0; j < np; ++j) Y.col(j) = direct.solve(Eigen::VectorXd(Bt.col(j)));
    Eigen::MatrixXd S = B * Y - Eigen::MatrixXd(C);
    S = (0.5 * (S + S.transpose())).eval();
    const Eigen::VectorXd dinv = A.diagonal().cwiseAbs().cwiseInverse();
    const Eigen::VectorXd d = SparseMatrix(B.cwiseProduct(B)) * dinv;
    const Eigen::MatrixXd Shat =
        st.range(3) == 0   ? Eigen::MatrixXd((d - C.diagonal()).asDiagonal())
        : st.range(3) == 1 ? Eigen::MatrixXd(Eigen::MatrixXd(d.asDiagonal()) - Eigen::MatrixXd(C))
                           : Eigen::MatrixXd(Eigen::MatrixXd(t.mech->schur_mass()) - Eigen::MatrixXd(C));
    // The eigenvectors (for the counters of where the modes sit) only up to 3 000 pressure
    // unknowns: Eigen's dense solver takes about a minute there, and 3-4 times as long with them.
    with_modes = np <= 3000;
    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> es(
        S, Shat, (with_modes ? Eigen::ComputeEigenvectors : Eigen::EigenvaluesOnly) | Eigen::Ax_lBx);
    if (es.info() != Eigen::Success) {
      st.SkipWithError("eigensolver failed");
      return;
    }
    lambda = es.eigenvalues();
    if (with_modes) modes = es.eigenvectors();
  }
  Eigen::VectorXd top20 = lambda;
  top20.tail(20).setOnes();
  st.counters["unknowns"] = static_cast<double>(n);
  st.counters["lambda_min"] = lambda(0);
  st.counters["lambda_max"] = lambda(np - 1);
  st.counters["below_0.3"] = static_cast<double>((lambda.array() < 0.3).count());
  st.counters["above_3"] = static_cast<double>((lambda.array() > 3.0).count());
  st.counters["its_1e-2"] = gmres_iterations_on_spectrum(lambda, 1e-2);
  st.counters["its_1e-8"] = gmres_iterations_on_spectrum(lambda, 1e-8);
  st.counters["its_1e-2_top20"] = gmres_iterations_on_spectrum(top20, 1e-2);
  if (!with_modes) return;
  // Height above the apex and transmural layer of each vertex (pressure unknown i is vertex i).
  const Eigen::VectorXd z = mesh.nodes.col(2).head(np);
  const double z_apex = z.minCoeff();
  const EllipsoidGeometry geometry = EllipsoidGeometry::human();
  Eigen::VectorXd middle(np);
  for (Eigen::Index i = 0; i < np; ++i) {
    const double tw = geometry.coordinates(mesh.nodes.row(i).transpose())(0);
    middle(i) = (tw > 1e-6 && tw < 1 - 1e-6) ? 1.0 : 0.0;
  }
  auto where = [&](Eigen::Index first, Eigen::Index count, double& height_mm, double& middle_share) {
    height_mm = middle_share = 0.0;
    for (Eigen::Index k = first; k < first + count; ++k) {
      const Eigen::VectorXd e = modes.col(k).cwiseAbs2() / modes.col(k).squaredNorm();
      height_mm += 1e3 * e.dot((z.array() - z_apex).matrix()) / static_cast<double>(count);
      middle_share += e.dot(middle) / static_cast<double>(count);
    }
  };
  double h_low, m_low, h_high, m_high;
  where(0, 10, h_low, m_low);
  where(np - 10, 10, h_high, m_high);
  st.counters["low10_mm"] = h_low;
  st.counters["low10_mid"] = m_low;
  st.counters["high10_mm"] = h_high;
  st.counters["high10_mid"] = m_high;
}

BENCHMARK(BM_Lv3dGmresIterationBySize)
    ->ArgsProduct({{1}, {6}, {12}, {0, 1}, {0}})->ArgsProduct({{2}, {12}, {24}, {0, 1}, {0}})
    ->ArgsProduct({{3}, {18}, {36}, {0, 1}, {0}})->ArgsProduct({{4}, {24}, {48}, {0, 1}, {0}})
    ->ArgsProduct({{5}, {30}, {60}, {0, 1}, {0}})->ArgsProduct({{6}, {36}, {72}, {0, 1}, {0}})
    ->ArgsProduct({{8}, {48}, {96}, {0, 1}, {0}})
    // One direction refined at a time from the fine mesh (3, 18, 36): around, rings, layers
    // (experiments/lv3d-solver/NOTES.md, "Where the iterations grow").
    ->Args({3, 18, 72, 1, 0})->Args({3, 36, 36, 1, 0})->Args({6, 18, 36, 1, 0})
    ->Args({3, 18, 18, 1, 0})->Args({5, 30, 30, 1, 0})->Args({5, 30, 36, 1, 0})
    // With the grad-div term (beta 1) and the mass Schur approximation, every size and the
    // refinements along the wall (docs/solvers.md s.3).
    ->ArgsProduct({{1}, {6}, {12}, {1}, {1}})->ArgsProduct({{2}, {12}, {24}, {1}, {1}})
    ->ArgsProduct({{3}, {18}, {36}, {1}, {1}})->ArgsProduct({{4}, {24}, {48}, {1}, {1}})
    ->ArgsProduct({{5}, {30}, {60}, {1}, {1}})->ArgsProduct({{6}, {36}, {72}, {1}, {1}})
    ->ArgsProduct({{7}, {42}, {84}, {1}, {1}})->ArgsProduct({{8}, {48}, {96}, {1}, {1}})
    ->Args({3, 18, 72, 1, 1})->Args({3, 36, 36, 1, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(10);

// The medium and fine meshes, and the fine one refined in one direction at a time.
BENCHMARK(BM_Lv3dSchurSpectrum)
    ->ArgsProduct({{2}, {12}, {24}, {0, 1, 2}})->ArgsProduct({{3}, {18}, {36}, {0, 1, 2}})
    ->Args({3, 18, 72, 0})->Args({3, 36, 36, 0})->Args({6, 18, 36, 0})
    ->Args({3, 18, 72, 2})->Args({3, 36, 36, 2})
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

BENCHMARK(BM_NewtonLinearAlgebra)
    ->ArgsProduct({{1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
BENCHMARK(BM_Assembly)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Iterations(3)->Complexity();
BENCHMARK(BM_LinearSolve)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Iterations(2)->Complexity();

}  // namespace

BENCHMARK_MAIN();
