// CPU time per simulated beat of the lumped BCS sphere at the default dt (1 ms, 850 steps).
// Run: build/bench/lumped_beat_bench
#include "model/lumped/sphere.h"

#include <benchmark/benchmark.h>

namespace {

using sigmaheart::model::State;
using sigmaheart::model::lumped::LumpedSphere;

// One beat advanced from the periodic state (the state after run()'s beats), repeated: each
// iteration is one beat of 850 backward-Euler steps with their Newton solves.
void BM_LumpedSphereOneBeat(benchmark::State& bench) {
  LumpedSphere sim;
  const Eigen::VectorXd theta = sim.parameters().nominal();
  const double period = theta(*sim.parameters().index("period"));
  State s = sim.initial_state(theta);
  if (!sim.advance(s, theta, 10 * period).ok()) {
    bench.SkipWithError("warm-up failed");
    return;
  }
  const State periodic = s;
  int beats = 0;
  for (auto _ : bench) {
    s = periodic;
    const auto status = sim.advance(s, theta, s.time + period);
    benchmark::DoNotOptimize(s.x.data());
    if (!status.ok()) {
      bench.SkipWithError(status.message.c_str());
      return;
    }
    ++beats;
  }
  bench.SetItemsProcessed(beats);
  bench.counters["beats"] = benchmark::Counter(beats, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LumpedSphereOneBeat)->Unit(benchmark::kMicrosecond);

// A whole run(): beats until periodic (7 for the healthy preset) and the last-beat trajectory.
void BM_LumpedSphereRunToPeriodicity(benchmark::State& bench) {
  LumpedSphere sim;
  const Eigen::VectorXd theta = sim.parameters().nominal();
  int beats = 0;
  for (auto _ : bench) {
    const auto r = sim.run(theta);
    benchmark::DoNotOptimize(r.trajectory.values.data());
    beats += r.info.beats;
  }
  bench.counters["us_per_beat"] = benchmark::Counter(
      static_cast<double>(beats), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  bench.counters["beats_per_run"] =
      static_cast<double>(beats) / static_cast<double>(bench.iterations());
}
BENCHMARK(BM_LumpedSphereRunToPeriodicity)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
