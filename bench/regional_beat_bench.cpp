// CPU time per simulated beat of the 17-patch regional ventricle (LBBB activation, dt 1 ms, 850
// backward-Euler steps with a 72-unknown Newton solve condensed to 21 global unknowns), and of the
// one-patch model for comparison with lumped_beat_bench.
// Run: build/bench/regional_beat_bench
#include "model/lumped/regional.h"

#include "beat_bench_support.h"

#include <benchmark/benchmark.h>

namespace {

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
  if (!sigmaheart::bench::time_one_beat(bench, sim, 12)) return;
  bench.SetLabel(bench.range(0) == 1 ? "1 patch" : "17 AHA patches, LBBB");
}
BENCHMARK(BM_RegionalOneBeat)->Arg(17)->Arg(1)->Unit(benchmark::kMillisecond);

// A whole run(): beats until periodic and the last-beat trajectory (17 patches, LBBB).
void BM_RegionalRunToPeriodicity(benchmark::State& bench) {
  RegionalOptions o;
  o.activation = ActivationPattern::kLbbb;
  RegionalVentricle sim(o);
  sigmaheart::bench::time_runs(bench, sim);
}
BENCHMARK(BM_RegionalRunToPeriodicity)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
