// CPU time per simulated beat of the lumped BCS sphere at the default dt (1 ms, 850 steps).
// Run: build/bench/lumped_beat_bench
#include "model/lumped/sphere.h"

#include "beat_bench_support.h"

#include <benchmark/benchmark.h>

namespace {

using sigmaheart::model::lumped::LumpedSphere;

// One beat advanced from the periodic state (the state after run()'s beats), repeated: each
// iteration is one beat of 850 backward-Euler steps with their Newton solves.
void BM_LumpedSphereOneBeat(benchmark::State& bench) {
  LumpedSphere sim;
  const auto beats = sigmaheart::bench::time_one_beat(bench, sim, 10);
  if (!beats) return;
  bench.counters["beats"] = benchmark::Counter(*beats, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LumpedSphereOneBeat)->Unit(benchmark::kMicrosecond);

// A whole run(): beats until periodic (7 for the healthy preset) and the last-beat trajectory.
void BM_LumpedSphereRunToPeriodicity(benchmark::State& bench) {
  LumpedSphere sim;
  const int beats = sigmaheart::bench::time_runs(bench, sim);
  bench.counters["us_per_beat"] = benchmark::Counter(
      static_cast<double>(beats), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_LumpedSphereRunToPeriodicity)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
