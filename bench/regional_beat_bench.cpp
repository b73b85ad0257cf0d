// CPU time per simulated beat of the 17-patch regional ventricle (LBBB activation, dt 1 ms, 850
// backward-Euler steps with a 72-unknown Newton solve condensed to 21 global unknowns), and of the
// one-patch model for comparison with lumped_beat_bench.
// Run: build/bench/regional_beat_bench
#include "model/lumped/regional.h"

#include <benchmark/benchmark.h>

namespace {

using sigmaheart::model::State;
using sigmaheart::model::lumped::ActivationPattern;
using sigmaheart::model::lumped::RegionalOptions;
using sigmaheart::model::lumped::RegionalVentricle;

// One beat advanced from the periodic state, repeated.
void BM_RegionalOneBeat(benchmark::State& bench) {
  RegionalOptions o;
  if (bench.range(0) == 1) {
    o.area_shares = {1.0};
  } else {
    o.activation = ActivationPattern::kLbbb;
  }
  RegionalVentricle sim(o);
  const Eigen::VectorXd theta = sim.parameters().nominal();
  const double period = theta(*sim.parameters().index("period"));
  State s = sim.initial_state(theta);
  if (!sim.advance(s, theta, 12 * period).ok()) {
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
  bench.SetLabel(bench.range(0) == 1 ? "1 patch" : "17 AHA patches, LBBB");
}
BENCHMARK(BM_RegionalOneBeat)->Arg(17)->Arg(1)->Unit(benchmark::kMillisecond);

// A whole run(): beats until periodic and the last-beat trajectory (17 patches, LBBB).
void BM_RegionalRunToPeriodicity(benchmark::State& bench) {
  RegionalOptions o;
  o.activation = ActivationPattern::kLbbb;
  RegionalVentricle sim(o);
  const Eigen::VectorXd theta = sim.parameters().nominal();
  int beats = 0;
  for (auto _ : bench) {
    const auto r = sim.run(theta);
    benchmark::DoNotOptimize(r.trajectory.values.data());
    beats += r.info.beats;
  }
  bench.counters["beats_per_run"] =
      static_cast<double>(beats) / static_cast<double>(bench.iterations());
}
BENCHMARK(BM_RegionalRunToPeriodicity)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
