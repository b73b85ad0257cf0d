// Wall time of one heartbeat of the 3D electromechanical LV (model/fem/electromechanics.h) against
// mesh size, on 1 and 2 OpenMP threads (the element assembly is threaded; the sparse LU is not).
// One iteration = the passive inflation plus one beat (period 0.85 s, dt 5 ms). Arguments:
// (mesh preset 0 coarse, 1 medium, 2 fine; threads). Counters: tetrahedra, unknowns of the
// mechanics (u, p), Newton iterations and step cuts of the beat, EF of the beat [%].
//   build/bench/lv3d_beat_bench --benchmark_counters_tabular=true
// The target of issue 13: a beat on about 10 000 tetrahedra under 60 s on one core.
#include "model/fem/electromechanics.h"
#include "model/fem/register.h"

#include <benchmark/benchmark.h>
#include <omp.h>

namespace {

using namespace sigmaheart::model;
using namespace sigmaheart::model::fem;

void BM_Lv3dBeat(benchmark::State& st) {
  const char* presets[] = {"coarse", "medium", "fine"};
  LeftVentricle3DOptions o = with_mesh_preset({}, presets[st.range(0)]);
  o.max_beats = 1;
  o.periodic_tolerance = 1.0;
  omp_set_num_threads(static_cast<int>(st.range(1)));
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
  if (r.status.ok()) {
    const Eigen::VectorXd V = r.trajectory.channel("V_lv");
    st.counters["EF_percent"] = 100.0 * (1.0 - V.minCoeff() / V.maxCoeff());
  }
}
// The passive inflation plus the first 10 time steps of the beat (isovolumic contraction, the
// hardest Newton solves), for sizes whose full beat takes too long to repeat: a beat is ~170 steps
// at dt 5 ms, about half of them in the easier ejection and filling phases.
void BM_Lv3dInflationAndTenSteps(benchmark::State& st) {
  const char* presets[] = {"coarse", "medium", "fine"};
  LeftVentricle3DOptions o = with_mesh_preset({}, presets[st.range(0)]);
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
    ->ArgsProduct({{0, 1, 2}, {1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

BENCHMARK(BM_Lv3dBeat)
    ->ArgsProduct({{0, 1, 2}, {1, 2}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
