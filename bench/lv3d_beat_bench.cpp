// Wall time of one heartbeat of the 3D electromechanical LV (model/fem/electromechanics.h) against
// mesh size, on 1 and 2 OpenMP threads (the element assembly is threaded; the sparse LU is not).
// One iteration = the passive inflation plus one beat (period 0.85 s, dt 5 ms). Arguments:
// (mesh preset 0 coarse, 1 medium, 2 fine; threads; linear solver 0 SparseLU, 1 UMFPACK, 2 GMRES +
// BoomerAMG). Counters: tetrahedra, unknowns of the
// mechanics (u, p), Newton iterations, factorisations and step cuts of the beat, EF of the beat [%].
//   build/bench/lv3d_beat_bench --benchmark_counters_tabular=true
// The target of issue 13: a beat on about 10 000 tetrahedra under 60 s on one core. Linear
// tetrahedra (BM_Lv3dBeatLinearBySize, element_order 1) with the factors carried from step to step
// within the run and the predicted first iterate (LeftVentricle3DOptions::carry_factors, the
// default; last argument 1), 1 thread, 2026-11-27 13:57-14:04 UTC, second core busy with another
// job: 396 / 3312 / 11 340 / 27 072 tets 1.02 / 14.2 / 50.2 / 166 s (fresh factors at every step,
// last argument 0: 1.85 / 20.5 / 90.9 s), 48 / 57 / 62 / 65 factorisations (fresh: 181 / 207 /
// 223), 914 / 955 / 998 / 1015 Newton iterations, the same EF; growth unknowns^1.48 / 1.15 / 1.50.
// (5, 30, 60), 53 100 tets, 43 224 unknowns, 17:20 UTC, second core idle: 514 s, 74 factorisations,
// 1021 Newton iterations, EF 40.92 % (growth 1.80 from (4, 24, 48)).
// Idle machine, 15:09-15:11 UTC, carried: 0.77 / 11.7 / 58.2 s on 1 thread, 0.79 / 10.8 / 50.0 s
// on 2. The fine beat meets the target on this machine (50.2 and 58.2 s on 1 thread in two runs).
// experiments/lv3d-solver/NOTES.md.
//   build/bench/lv3d_beat_bench --benchmark_filter='LinearBySize/.*/1/1/[01]$'
// The iterative solver on the same linear tetrahedra (BM_Lv3dBeatLinearBySizeAmg, sparse Schur
// approximation; 1 thread, CPU time, 2026-11-27 16:23-17:07 UTC, second core partly busy):
// 584 / 3468 / 10 384 unknowns: GMRES to 1e-10 15.9 / 247 / 1517 s, to 1e-2 5.29 / 63.1 / 372 s;
// 536 / 620 / 659 and 744 / 783 / 844 Newton iterations, EF as UMFPACK's to four digits. 5-30x
// UMFPACK's time, growth unknowns^1.54 / 1.65 (1e-10) and 1.39 / 1.62 (1e-2): the GMRES iterations
// grow with the mesh (experiments/lv3d-solver/NOTES.md).
//   build/bench/lv3d_beat_bench --benchmark_filter='LinearBySizeAmg/.*/1/'
// With the pressure stabilisation (BM_Lv3dBeatLinearStabilized, pressure_stabilization 0.1,
// SIMPLE's diagonal Schur approximation; 1 thread, CPU time, 2026-11-27 19:25-20:20 UTC, second core
// busy with another size or a test): GMRES + BoomerAMG to 1e-2 with the set-ups carried from step
// to step, 584 / 3468 / 10 384 / 23 060 unknowns: 2.38 / 22.0 / 126 / 377 s (a set-up per step:
// 3.04 / 29.9 / 141 / 431 s; unstabilised, per step: 5.29 / 63.1 / 372 s), 7.7 / 9.3 / 11.1 / 12.5
// GMRES iterations per solve, 49 / 79 / 130 / 131 set-ups; growth unknowns^1.25 / 1.59 / 1.37.
// UMFPACK with carried factors 0.97 / 14.6 / 76.6 / 198 s (unstabilised 0.77-1.02 / 11.7-14.2 /
// 50-58 / 166 s: the per-step tau evaluation and more refactorisations), EF 40.71 / 41.96 / 41.16 /
// 40.95 %. (5, 30, 60), 43 224 unknowns, both cores loaded by two other jobs: AMG carried 1034 s,
// 14.3 GMRES iterations per solve, 140 set-ups (growth ^1.61, an upper bound); UMFPACK 580 s, 87
// factorisations (the other core busy). Re-measured on an idle machine (23:00 UTC, before the
// aggressive coarsening): (4, 24, 48) 488 s, (5, 30, 60) 1128 s, 16.3 GMRES iterations per Newton
// iteration (growth ^1.33; the machine ran 10-30 % slower than in the evening). With one
// aggressively coarsened AMG level (iterative_options_for(), since 23:30 UTC): fine 106 s (120 s
// without, same hour), 14 794 GMRES iterations, 155 set-ups; (4, 24, 48) 317 s, 18 476 GMRES
// iterations, 193 set-ups (growth ^1.37 against 1.76 without). Again on 2026-11-28 (1 thread,
// 01:18-02:15 UTC): fine 103 s, (4, 24, 48) 315 s, (5, 30, 60) 784 s (22 545 GMRES iterations, 199
// set-ups, EF 40.8616 %), (6, 36, 72) 1458 s (26 902, 204, 40.8174 %); growth ^1.40 / 1.45 / 1.20,
// ^1.36 overall, of which ~0.3 the GMRES iterations per beat (experiments/lv3d-solver/NOTES.md,
// "Where the iterations grow").
//   build/bench/lv3d_beat_bench --benchmark_filter='LinearStabilized/.*/1/(1/10|2/2)/10/'
// With the grad-div term and the coarse correction on a grid that follows the mesh (solver 6;
// 1 thread, idle, 2026-11-28 17:30-17:55 UTC), 3 468 / 10 384 / 23 060 / 43 224 / 72 604 unknowns:
// 11.9 / 57.0 / 158 / 364 / 661 s, 4.77 / 4.71 / 4.93 / 5.10 / 5.42 GMRES iterations per Newton
// iteration, 75 / 85 / 91 / 98 / 101 set-ups; growth unknowns^1.26 from the fine mesh to
// (6, 36, 72), ^1.15 between the two largest (experiments/lv3d-solver/NOTES.md, "The coarse
// correction with the grad-div term").
//   build/bench/lv3d_beat_bench --benchmark_filter='LinearStabilized/.*/1/6/2/10/'
// Earlier the same day (before the carried factors): the fine mesh took 84.9 s on the
// machine of 2026-11-27 (AMD EPYC, 2.45 GHz, idle), where the code before that day's Newton changes
// (pattern-only UMFPACK analysis, w1 frozen with the factors, residual-only stress, Broyden
// updates; experiments/lv3d-solver/NOTES.md) took 140 s: 1.65x. The same old code took 79.7 s on
// the machine of 2026-11-26, so machines differ by 1.75x; on this one the target was missed by
// 1.4x. The quadratic
// ones take about 1400 s extrapolated (BM_Lv3dBeatBySize).
// 2026-11-27, 1 thread, idle machine, new code (Broyden / plain chord) against the old code:
// 396 / 3312 / 11 340 tets: 1.45 / 21.6 / 84.9 s (chord 2.01 / 23.2 / 93.8 s; old 2.55 / 29.0 /
// 140 s), 948 / 1002 / 1029 Newton iterations (chord and old 1035 / 1135 / 1275), EF 41.83 / 42.50
// / 41.38 % in all three.
// Linear tetrahedra, UMFPACK on OpenBLAS, 1 thread (2026-11-26 22:21 UTC, second core busy with
// another job, old code): 396 / 3312 / 11 340 / 27 072 tets (584 / 3468 / 10 384 / 23 060 unknowns)
// 1.34 / 19.0 / 79.7 / 276 s, 1035 / 1135 / 1275 / 1285 Newton iterations, EF 41.8 / 42.5 / 41.4 /
// 41.1 %; growth unknowns^1.49 / 1.31 / 1.56 between neighbours.
//   build/bench/lv3d_beat_bench --benchmark_filter='LinearBySize'
// Quadratic, UMFPACK on OpenBLAS (the build had linked ATLAS before, CMakeLists.txt), same session:
// 396 / 918 / 1656 / 3312 tets 13.1 / 40.7 / 80.8 / 230 s (within 5 % of the ATLAS figures below).
// Measured on the shared 2-core machine (load average 4-10 from other builds, so wall times are
// upper bounds; SparseLU, quadrature degree 2):
//   coarse (396 tets, 2639 unknowns), one beat at dt 5 ms: 1 thread 26.1 s wall / 24.7 s CPU,
//     848 Newton iterations, no step cut, EF 40.8 %; 2 threads 65.2 s wall / 39.2 s CPU, the same
//     EF to the last digit (colour-ordered assembly); the LU factorisation dominates and is not
//     threaded, and the per-colour OpenMP barriers cost more than they save on a loaded machine.
//   coarse, inflation + 10 steps: 1 thread 3.68 s wall / 3.11 s CPU; 2 threads 26.1 s / 6.47 s.
//   medium (3312 tets, 17 802 unknowns), inflation + 10 steps, 1 thread: 805 s wall / 264 s CPU
//     (a beat would take tens of CPU minutes). Medium on 2 threads, the medium beat and the fine
//     mesh (~11 000 tets) were not run: the SparseLU factorisation of the P2-P1 tangent grows far
//     faster than the mesh and is the cost to attack (an iterative solver with an algebraic
//     multigrid preconditioner, or UMFPACK/METIS with its nondeterminism accepted).
// UMFPACK against the iterative solver (model/fem/solver.h), inflation + 10 steps, CPU time (load
// average ~10: wall 4-7x CPU): coarse 1 thread UMFPACK 3.25 s, AMG 8.93 s; 2 threads 7.51 s and
// 7.11 s; medium 1 thread UMFPACK 37.9 s, AMG 147 s (growth exponents 1.29 and 1.47 in the
// unknowns). The fine mesh was not run. experiments/lv3d-solver/NOTES.md discusses why AMG loses
// here.
//   build/bench/lv3d_beat_bench --benchmark_filter='TenSteps/(0/[12]/[12]|1/1/[12])/'
// A whole beat against mesh size with UMFPACK (BM_Lv3dBeatBySize, idle machine, 2026-11-26):
// 396 / 918 / 1656 / 3312 tets (2639 / 6005 / 10739 / 17802 unknowns): 20.1 / 57.3 / 111 / 283 s
// on 1 thread, 19.1 / 54.1 / 105 / 273 s on 2; time ~ unknowns^1.39; fine extrapolated ~1400 s.
// SparseLU: 23.8 s and 212 s for the first two (exponent 2.7). experiments/lv3d-solver/NOTES.md.
//   build/bench/lv3d_beat_bench --benchmark_filter='BySize/.*/1/iterations'
// The iterative solver as an inexact Newton method (BM_Lv3dBeatBySizeAmg, linear_tolerance
// 10^-k; 2026-11-26, second core busy): coarse 111 / 73.9 / 55.9 / 42.2 s CPU at 1e-10 / 1e-6 /
// 1e-4 / 1e-2 (848 / 848 / 870 / 1002 Newton iterations, the same EF); at 1e-2, 918 tets 133 s and
// 1656 tets 371 s: time ~ unknowns^1.55, still 2-3x UMFPACK. experiments/lv3d-solver/NOTES.md.
//   build/bench/lv3d_beat_bench --benchmark_filter='BySizeAmg'
// Without UMFPACK's iterative refinement (model/fem/solver.cpp, UMFPACK_IRSTEP 0; second core busy):
// 396 / 918 / 1656 / 3312 tets 17.0 / 46.4 / 104 / 276 s on 1 thread (918 tets: 70.2 s with the
// refinement, same load); growth unknowns^1.46. Trial points of the line search assembled without
// the tangent: 12.0 / 38.9 / 85.8 / 241 s, the same Newton iterations (848 / 851 / 863 / 878).
#include "estimation/roukf/roukf.h"
#include "model/fem/electromechanics.h"
#include "model/fem/register.h"

#include <string>

#include <benchmark/benchmark.h>

#include <cmath>
#include <omp.h>

namespace {

using namespace sigmaheart::model;
using namespace sigmaheart::model::fem;

// Third argument: the linear solver (0 SparseLU, the default; 1 UMFPACK; 2 GMRES + BoomerAMG).
const LinearSolver kSolvers[] = {LinearSolver::kSparseLU, LinearSolver::kUmfPack, LinearSolver::kAmg};

// One iteration: the inflation and one beat of `o` on `threads` OpenMP threads.
void beat(benchmark::State& st, LeftVentricle3DOptions o, int threads) {
  if (!linear_solver_available(o.linear_solver)) {
    st.SkipWithError("linear solver not built in");
    return;
  }
  o.max_beats = 1;
  o.periodic_tolerance = 1.0;
  omp_set_num_threads(threads);
  LeftVentricle3D lv(o);
  const Eigen::VectorXd theta = lv.parameters().nominal();
  RunResult r;
  for (auto _ : st) {
    r = lv.run(theta);
    if (!r.status.ok()) {
      st.SkipWithError(r.status.message.c_str());
      break;
    }
  }
  st.counters["tets"] = lv.mesh().n_tets();
  st.counters["unknowns"] = 3.0 * lv.mesh().n_nodes() + lv.mesh().n_vertices;
  st.counters["newton"] = r.info.newton_iterations;
  st.counters["cuts"] = r.info.step_cuts;
  st.counters["factorizations"] = r.info.factorizations;
  st.counters["gmres"] = static_cast<double>(r.info.linear_iterations);
  if (r.status.ok()) {
    const Eigen::VectorXd V = r.trajectory.channel("V_lv");
    st.counters["EF_percent"] = 100.0 * (1.0 - V.minCoeff() / V.maxCoeff());
  }
}

void BM_Lv3dBeat(benchmark::State& st) {
  const char* presets[] = {"coarse", "medium", "fine"};
  LeftVentricle3DOptions o = with_mesh_preset({}, presets[st.range(0)]);
  o.linear_solver = kSolvers[st.range(2)];
  beat(st, o, static_cast<int>(st.range(1)));
}

// The options with the mesh (n_transmural, n_longitudinal, n_circumferential) of the first three
// benchmark arguments.
LeftVentricle3DOptions sized_mesh(const benchmark::State& st) {
  LeftVentricle3DOptions o;
  o.n_transmural = static_cast<int>(st.range(0));
  o.n_longitudinal = static_cast<int>(st.range(1));
  o.n_circumferential = static_cast<int>(st.range(2));
  return o;
}

// A beat against mesh size up to the medium preset (n_longitudinal a multiple of 3,
// n_circumferential of 6 for the AHA segments). Arguments: (n_transmural, n_longitudinal,
// n_circumferential, threads, solver as above).
void BM_Lv3dBeatBySize(benchmark::State& st) {
  LeftVentricle3DOptions o = sized_mesh(st);
  o.linear_solver = kSolvers[st.range(4)];
  beat(st, o, static_cast<int>(st.range(3)));
}
// The same with the iterative solver (GMRES + BoomerAMG) as an inexact Newton method: arguments
// (n_transmural, n_longitudinal, n_circumferential, threads, k, beta) with linear_tolerance 10^-k
// and grad_div beta (0 or 1; with 1 the mass Schur approximation, experiments/lv3d-solver/NOTES.md,
// "The grad-div term in the beat").
void BM_Lv3dBeatBySizeAmg(benchmark::State& st) {
  LeftVentricle3DOptions o = sized_mesh(st);
  o.linear_solver = LinearSolver::kAmg;
  o.linear_tolerance = std::pow(10.0, -static_cast<double>(st.range(4)));
  o.grad_div = static_cast<double>(st.range(5));
  beat(st, o, static_cast<int>(st.range(3)));
}
// Linear tetrahedra (element_order 1, P1-P1 with a 10 MPa bulk modulus, one quadrature point;
// docs/models.md s.4.8, "Linear tetrahedra") on the mesh (n_transmural, n_longitudinal,
// n_circumferential) of the first three arguments.
LeftVentricle3DOptions linear_mesh(const benchmark::State& st) {
  LeftVentricle3DOptions o = sized_mesh(st);
  o.element_order = 1;
  o.bulk_modulus = 1e7;
  o.quadrature_degree = 1;
  return o;
}
// Linear tetrahedra (element_order 1, P1-P1 with a 10 MPa bulk modulus, one quadrature point;
// docs/models.md s.4.8, "Linear tetrahedra"), UMFPACK: arguments (n_transmural, n_longitudinal,
// n_circumferential, threads, Broyden updates of the chord iterations 1 (default) or 0, factors
// carried from step to step 1 (default) or 0). The fine
// preset (3, 18, 36) has 11 340 tetrahedra, the size of the target.
void BM_Lv3dBeatLinearBySize(benchmark::State& st) {
  LeftVentricle3DOptions o = linear_mesh(st);
  o.broyden = st.range(4) != 0;
  o.carry_factors = st.range(5) != 0;
  o.linear_solver = LinearSolver::kUmfPack;
  beat(st, o, static_cast<int>(st.range(3)));
}
// The same linear tetrahedra with the iterative solver (GMRES + BoomerAMG with the sparse Schur
// approximation, model/fem/solver.h): arguments (n_transmural, n_longitudinal, n_circumferential,
// threads, k) with linear_tolerance 10^-k (10: the default; 2: an inexact Newton method). The
// frozen tangent and its AMG set-up are carried from step to step like the direct solver's factors
// (since 2026-11-27 evening; the figures above are from before, a set-up at every step).
void BM_Lv3dBeatLinearBySizeAmg(benchmark::State& st) {
  LeftVentricle3DOptions o = linear_mesh(st);
  o.linear_solver = LinearSolver::kAmg;
  o.linear_tolerance = std::pow(10.0, -static_cast<double>(st.range(4)));
  beat(st, o, static_cast<int>(st.range(3)));
}
// Linear tetrahedra with the Brezzi-Pitkaranta pressure stabilisation (element_order 1,
// pressure_stabilization alpha; docs/models.md s.4.4): arguments (n_transmural, n_longitudinal,
// n_circumferential, threads, solver 1 UMFPACK (factors carried), 2 GMRES + BoomerAMG with
// SIMPLE's diagonal Schur approximation or 3 the same with the coarse correction of the wall modes
// (coarse_correction; experiments/lv3d-solver/NOTES.md, "The coarse correction in the beat"), 4
// GMRES + BoomerAMG
// with the grad-div term (grad_div 1) and the mass Schur approximation
// (experiments/lv3d-solver/NOTES.md, "The grad-div term in the beat") or 5 the same with an exact
// displacement solve instead of the
// V-cycle (exact_displacement_solve, a diagnostic: experiments/lv3d-solver/NOTES.md, "Where the
// beat's iterations grow") or 6 the grad-div term with the coarse correction on a grid that follows
// the
// mesh (coarse_correction; docs/solvers.md s.4-5),
// k: linear_tolerance 10^-k, 100 alpha).
void BM_Lv3dBeatLinearStabilized(benchmark::State& st) {
  LeftVentricle3DOptions o = linear_mesh(st);
  o.linear_solver = kSolvers[std::min<int64_t>(st.range(4), 2)];
  o.coarse_correction = st.range(4) == 3 || st.range(4) == 6;
  o.grad_div = st.range(4) >= 4 ? 1.0 : 0.0;
  o.exact_displacement_solve = st.range(4) == 5;
  o.linear_tolerance = std::pow(10.0, -static_cast<double>(st.range(5)));
  o.pressure_stabilization = 0.01 * static_cast<double>(st.range(6));
  beat(st, o, static_cast<int>(st.range(3)));
}
// The passive inflation plus the first 10 time steps of the beat (isovolumic contraction, the
// hardest Newton solves), for sizes whose full beat takes too long to repeat: a beat is ~170 steps
// at dt 5 ms, about half of them in the easier ejection and filling phases.
void BM_Lv3dInflationAndTenSteps(benchmark::State& st) {
  const char* presets[] = {"coarse", "medium", "fine"};
  LeftVentricle3DOptions o = with_mesh_preset({}, presets[st.range(0)]);
  o.linear_solver = kSolvers[st.range(2)];
  if (!linear_solver_available(o.linear_solver)) {
    st.SkipWithError("linear solver not built in");
    return;
  }
  omp_set_num_threads(static_cast<int>(st.range(1)));
  LeftVentricle3D lv(o);
  const Eigen::VectorXd theta = lv.parameters().nominal();
  for (auto _ : st) {
    sigmaheart::model::State s = lv.initial_state(theta);
    const Status status = lv.advance(s, theta, 10 * o.dt);
    if (!status.ok()) {
      st.SkipWithError(status.message.c_str());
      break;
    }
  }
  st.counters["tets"] = lv.mesh().n_tets();
  st.counters["unknowns"] = 3.0 * lv.mesh().n_nodes() + lv.mesh().n_vertices;
}
BENCHMARK(BM_Lv3dInflationAndTenSteps)
    ->ArgsProduct({{0, 1, 2}, {1, 2}, {0, 1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeat)
    ->ArgsProduct({{0, 1, 2}, {1, 2}, {0, 1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeatBySize)
    ->Args({1, 6, 12, 1, 1})->Args({1, 9, 18, 1, 1})->Args({1, 12, 24, 1, 1})->Args({2, 12, 24, 1, 1})
    ->Args({1, 6, 12, 2, 1})->Args({1, 9, 18, 2, 1})->Args({1, 12, 24, 2, 1})->Args({2, 12, 24, 2, 1})
    ->Args({1, 6, 12, 1, 0})->Args({1, 9, 18, 1, 0})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeatLinearBySize)
    ->ArgsProduct({{1}, {6}, {12}, {1, 2}, {1, 0}, {1, 0}})
    ->ArgsProduct({{2}, {12}, {24}, {1, 2}, {1, 0}, {1, 0}})
    ->ArgsProduct({{3}, {18}, {36}, {1, 2}, {1, 0}, {1, 0}})
    ->ArgsProduct({{4}, {24}, {48}, {1, 2}, {1, 0}, {1, 0}})
    ->Args({5, 30, 60, 1, 1, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeatLinearBySizeAmg)
    ->ArgsProduct({{1}, {6}, {12}, {1, 2}, {10, 2}})
    ->ArgsProduct({{2}, {12}, {24}, {1, 2}, {10, 2}})
    ->ArgsProduct({{3}, {18}, {36}, {1, 2}, {10, 2}})
    ->ArgsProduct({{4}, {24}, {48}, {1}, {10, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeatLinearStabilized)
    ->ArgsProduct({{1}, {6}, {12}, {1}, {1, 2}, {10, 2}, {0, 3, 10, 30}})
    ->ArgsProduct({{2}, {12}, {24}, {1}, {1, 2, 3, 4}, {10, 2}, {0, 10, 30}})
    ->ArgsProduct({{3}, {18}, {36}, {1}, {1, 2, 3, 4}, {10, 2}, {0, 10}})
    ->ArgsProduct({{4}, {24}, {48}, {1}, {1, 2, 3, 4}, {2}, {10}})
    ->Args({2, 12, 24, 1, 5, 2, 10})->Args({3, 18, 36, 1, 5, 2, 10})->Args({4, 24, 48, 1, 5, 2, 10})
    ->ArgsProduct({{5}, {30}, {60}, {1}, {1, 2, 3, 4}, {2}, {10}})
    ->Args({6, 36, 72, 1, 2, 2, 10})
    ->Args({6, 36, 72, 1, 3, 2, 10})
    ->Args({6, 36, 72, 1, 4, 2, 10})
    ->ArgsProduct({{2}, {12}, {24}, {1, 2}, {6}, {2}, {10}})->ArgsProduct({{3}, {18}, {36}, {1, 2}, {6}, {2}, {10}})
    ->ArgsProduct({{4}, {24}, {48}, {1, 2}, {6}, {2}, {10}})
    ->Args({5, 30, 60, 1, 6, 2, 10})->Args({6, 36, 72, 1, 6, 2, 10})->Args({7, 42, 84, 1, 6, 2, 10})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeatBySizeAmg)
    ->ArgsProduct({{1}, {6}, {12}, {1}, {10, 6, 4, 2}, {0}})
    ->ArgsProduct({{1}, {6}, {12}, {1}, {2}, {1}})
    ->ArgsProduct({{1}, {9}, {18}, {1}, {2}, {0, 1}})->ArgsProduct({{1}, {12}, {24}, {1}, {2}, {0, 1}})
    ->Args({2, 12, 24, 1, 2, 0})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

// One ROUKF step on the coarse mesh (issue 13): the 17 segment contractilities (log, 50 % prior)
// from V_seg01..16 (V_seg17 of lv-3d holds no cavity), 18 simplex members advanced from the
// inflated state over one frame of 1/30 beat (28.3 ms, 6 steps at dt 5 ms, the start of the
// isovolumic contraction), then the correction. Argument: ensemble threads (members in parallel;
// the assembly inside a member then runs on one thread). Data: the nominal beat itself, so the
// step is timed, not its estimate. Measured 2026-11-26 14:29 UTC, idle 2-core machine, SparseLU:
// 22.8 s on 1 thread, 11.4 s on 2 (1.27 s per member and frame; a 17-segment pass over 30 frames
// would take about 6 min on 2 threads, plus each member's inflation).
//   build/bench/lv3d_beat_bench --benchmark_filter=RoukfStep
void BM_Lv3dRoukfStep(benchmark::State& st) {
  LeftVentricle3DOptions o = with_mesh_preset({}, "coarse");
  LeftVentricle3D lv(o);
  const Eigen::VectorXd theta = lv.parameters().nominal();
  const sigmaheart::model::State start = lv.initial_state(theta);
  const double frame = start.time + 0.85 / 30.0;
  sigmaheart::model::State s = start;
  if (!lv.advance(s, theta, frame).ok()) {
    st.SkipWithError("the nominal run failed");
    return;
  }
  const Eigen::VectorXd z = lv.sample(s, theta);
  const auto channels = lv.channels();
  sigmaheart::estimation::RoukfData data;
  data.times = Eigen::VectorXd::Constant(1, frame);
  data.values.resize(1, 16);
  for (int k = 1; k <= 16; ++k) {
    const std::string name = std::string("V_seg") + (k < 10 ? "0" : "") + std::to_string(k);
    data.channels.push_back(name);
    for (size_t c = 0; c < channels.size(); ++c) {
      if (channels[c].name == name) data.values(0, k - 1) = z(static_cast<Eigen::Index>(c));
    }
  }
  sigmaheart::estimation::Prior prior;
  for (int k = 1; k <= 17; ++k) {
    const auto& q = lv.parameters()[*lv.parameters().index(std::string("sigma0_") + (k < 10 ? "0" : "") + std::to_string(k))];
    prior.parameters.push_back(sigmaheart::estimation::PriorParameter::gaussian(
        q.name, q.unit, q.nominal, 0.5, sigmaheart::estimation::SpreadKind::kEta,
        sigmaheart::estimation::Transform{sigmaheart::estimation::TransformKind::kLog, q.nominal}, 0.0));
  }
  sigmaheart::estimation::RoukfOptions f;
  f.R = Eigen::MatrixXd::Identity(16, 16) * std::pow(0.2e-6, 2);  // (0.2 mL)^2
  f.initial_state = start;
  f.ensemble.backend = sigmaheart::estimation::Backend::kThreads;
  f.ensemble.threads = static_cast<int>(st.range(0));
  omp_set_num_threads(1);
  sigmaheart::estimation::RoukfSummary r;
  for (auto _ : st) {
    r = sigmaheart::estimation::run_roukf(lv, prior, data, f);
    if (!r.ok()) {
      st.SkipWithError(r.message.c_str());
      return;
    }
  }
  st.counters["members"] = r.members;
  st.counters["tets"] = lv.mesh().n_tets();
}
BENCHMARK(BM_Lv3dRoukfStep)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
