// ROUKF cost on the 17-segment regional personalisation (experiments/regional-personalization):
//  - one filter step (sampling, 18 members advanced over one frame of 1/30 beat, correction with
//    17 regional volumes) on 1 and 2 threads (real_time: the wall time);
//  - one step with tempered sub-updates (RoukfOptions::tempering 1): the cost of re-drawing and
//    advancing the members once per sub-update;
//  - the whole twin experiment with the true noise (split passes, at most 16 x 30 frames) on 1 and
//    2 threads, its wall time, the passes run and the max error after the last pass as counters.
// Run: build/bench/roukf_bench   (or --benchmark_filter=Step)
#include "estimation/roukf/regional_twin.h"

#include <benchmark/benchmark.h>

namespace {

using namespace sigmaheart;

estimation::RegionalTwin make_twin(const model::lumped::RegionalVentricle& model, int beats) {
  estimation::RegionalTwinOptions o;
  o.model = model.options();
  o.beats = beats;
  return estimation::make_regional_twin(model, o);
}

model::lumped::RegionalVentricle lbbb_model() {
  model::lumped::RegionalOptions mo;
  mo.activation = model::lumped::ActivationPattern::kLbbb;
  return model::lumped::RegionalVentricle(mo);
}

// One filter step after the spin-up: the filter starts from the prior's periodic state (common to
// all members) and the data are cut to the first frame, so run_roukf does exactly one step.
void one_step(benchmark::State& bench, double tempering) {
  auto model = lbbb_model();
  estimation::RegionalTwin twin = make_twin(model, 1);
  const Eigen::VectorXd nominal = model.parameters().nominal();
  model::State start = model.initial_state(nominal);
  if (!model.advance(start, nominal, twin.data.times(0) - twin.filter.period / 30.0).ok()) {
    bench.SkipWithError("spin-up failed");
    return;
  }
  twin.filter.initial_state = start;
  twin.filter.initial_state_per_member = false;
  estimation::RoukfData one = twin.data;
  one.times = one.times.head(1).eval();
  one.values = one.values.topRows(1).eval();
  twin.filter.ensemble.threads = static_cast<int>(bench.range(0));
  twin.filter.ensemble.backend = estimation::Backend::kThreads;
  twin.filter.tempering = tempering;
  int subupdates = 0;
  for (auto _ : bench) {
    const auto s = estimation::run_roukf(model, twin.prior, one, twin.filter);
    if (!s.ok()) {
      bench.SkipWithError(s.message.c_str());
      return;
    }
    benchmark::DoNotOptimize(s.eta.data());
    subupdates = s.subupdates;
  }
  bench.counters["members"] = 18;
  bench.counters["subupdates"] = subupdates;
}
void BM_RoukfOneStep(benchmark::State& bench) { one_step(bench, 0.0); }
BENCHMARK(BM_RoukfOneStep)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
void BM_RoukfOneTemperedStep(benchmark::State& bench) { one_step(bench, 1.0); }
BENCHMARK(BM_RoukfOneTemperedStep)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// The twin experiment: 17 contractilities from noisy regional volumes, at most 16 split passes.
void BM_RoukfTwinExperiment(benchmark::State& bench) {
  const auto model = lbbb_model();
  estimation::RegionalTwin twin = make_twin(model, 16);
  twin.filter.ensemble.threads = static_cast<int>(bench.range(0));
  estimation::RoukfSummary s;
  for (auto _ : bench) {
    s = estimation::run_roukf(model, twin.prior, twin.data, twin.filter);
    if (!s.ok()) {
      bench.SkipWithError(s.message.c_str());
      return;
    }
  }
  const Eigen::MatrixXd err = estimation::per_beat_relative_errors(s, twin.truth_sigma0);
  bench.counters["max_err_last_pass_pct"] = 100 * err.row(err.rows() - 1).maxCoeff();
  bench.counters["max_err_final_pct"] = s.error_percent.maxCoeff();  // after the MAP refinement
  bench.counters["map_runs"] = s.map_runs;
  bench.counters["passes"] = static_cast<double>(s.pass_fractions.size());
  bench.counters["nis_mean"] = s.nis_mean;
  bench.counters["steps"] = static_cast<double>(s.steps.size());
}
BENCHMARK(BM_RoukfTwinExperiment)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
