// Throughput of the sensitivity studies: Sobol' points per second, the overhead of a Saltelli
// study (design, estimators, bootstrap) on a cheap analytic model, and simulations per second
// through a Sobol' study of the lumped sphere on 1 and 2 threads; a 100-parameter study and the
// cost of second-order indices.
// Run: build/bench/sensitivity_bench
#include "estimation/forward_model.h"
#include "estimation/sensitivity/sobol_indices.h"
#include "estimation/sensitivity/test_functions.h"
#include "model/lumped/sphere.h"
#include "observers/global_indices.h"

#include <benchmark/benchmark.h>

namespace {

namespace sh = sigmaheart::estimation::sensitivity;

// 2^14 points of a scrambled 16-dimensional sequence (a Saltelli design for p = 8).
void BM_SobolPoints(benchmark::State& bench) {
  sh::SobolSequenceOptions o;
  o.dimension = 16;
  const sh::SobolSequence seq(o);
  for (auto _ : bench) {
    const Eigen::MatrixXd P = seq.points(0, 1 << 14);
    benchmark::DoNotOptimize(P.data());
  }
  bench.SetItemsProcessed(bench.iterations() * (1 << 14));
}
BENCHMARK(BM_SobolPoints)->Unit(benchmark::kMillisecond);

// A G-function study (p = 8, N = 1024: 10240 runs, 500 bootstrap replicates, 4 convergence
// levels): everything but the simulator.
void BM_SobolStudyGFunction(benchmark::State& bench) {
  const Eigen::VectorXd a = sh::g_function_default_a();
  sh::SobolOptions o;
  o.base_samples = 1024;
  o.bootstrap_samples = 500;
  o.ensemble.threads = static_cast<int>(bench.range(0));
  for (auto _ : bench) {
    const auto r = sh::run_sobol(sh::GFunctionModel(a), sh::g_function_prior(8), o);
    benchmark::DoNotOptimize(r.estimate.S1.data());
  }
  bench.SetItemsProcessed(bench.iterations() * 1024 * 10);
}
BENCHMARK(BM_SobolStudyGFunction)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// Sensitivity at scale: a G-function study of p = 100 parameters (a Sobol' sequence of dimension
// 200, beyond the old 53-dimension table), N = 1024: 104 448 runs, 200 bootstrap replicates, one
// convergence level. Argument: threads.
void BM_SobolStudyHundredParameters(benchmark::State& bench) {
  const int p = 100;
  Eigen::VectorXd a = Eigen::VectorXd::Constant(p, 99.0);
  a.head(10) << 0, 0.5, 1, 1.5, 2, 3, 4.5, 6, 9, 0;
  sh::SobolOptions o;
  o.base_samples = 1024;
  o.bootstrap_samples = 200;
  o.convergence_levels = 1;
  o.ensemble.threads = static_cast<int>(bench.range(0));
  for (auto _ : bench) {
    const auto r = sh::run_sobol(sh::GFunctionModel(a), sh::g_function_prior(p), o);
    benchmark::DoNotOptimize(r.estimate.S1.data());
  }
  bench.SetItemsProcessed(bench.iterations() * 1024 * (p + 2));
}
BENCHMARK(BM_SobolStudyHundredParameters)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// The cost of second-order indices (Saltelli 2002 design, N (2p + 2) runs, and the p (p - 1) / 2
// pairs in every bootstrap replicate): G-function p = 8 and p = 20, N = 1024, 500 replicates.
void BM_SobolSecondOrder(benchmark::State& bench) {
  const int p = static_cast<int>(bench.range(0));
  Eigen::VectorXd a = Eigen::VectorXd::Constant(p, 9.0);
  a.head(4) << 0, 1, 4.5, 9;
  sh::SobolOptions o;
  o.base_samples = 1024;
  o.bootstrap_samples = 500;
  o.convergence_levels = 1;
  o.second_order = true;
  o.ensemble.threads = 2;
  for (auto _ : bench) {
    const auto r = sh::run_sobol(sh::GFunctionModel(a), sh::g_function_prior(p), o);
    benchmark::DoNotOptimize(r.estimate.S2.data());
  }
  bench.SetItemsProcessed(bench.iterations() * 1024 * (2 * p + 2));
}
BENCHMARK(BM_SobolSecondOrder)->Arg(8)->Arg(20)->Unit(benchmark::kMillisecond);

// The lumped sphere, two parameters (sigma0, R_p) +-20 % around nominal, global indices observed;
// N = 16: 64 simulations per study. Items = simulations.
void BM_SobolStudyLumpedSphere(benchmark::State& bench) {
  using sigmaheart::model::lumped::LumpedSphere;
  const LumpedSphere sim;
  const sigmaheart::observers::GlobalIndices observer({}, sim.channels());
  const std::vector<std::string> names = {"sigma0", "R_p"};
  const sigmaheart::estimation::SimulatorForwardModel model(sim, observer, names);
  sigmaheart::estimation::Prior prior;
  for (const auto& n : names) {
    const auto& p = sim.parameters()[sim.parameters().index_or_throw(n)];
    prior.parameters.push_back(sigmaheart::estimation::PriorParameter::uniform(
        n, p.unit, 0.8 * p.nominal, 1.2 * p.nominal, p.nominal));
  }
  sh::SobolOptions o;
  o.base_samples = 16;
  o.bootstrap_samples = 0;
  o.convergence_levels = 1;
  o.ensemble.threads = static_cast<int>(bench.range(0));
  int sims = 0;
  for (auto _ : bench) {
    const auto r = sh::run_sobol(model, prior, o);
    if (!r.failed_runs.empty()) {
      bench.SkipWithError(r.message.c_str());
      return;
    }
    sims += r.runs;
  }
  bench.SetItemsProcessed(sims);
  bench.counters["sims_per_s"] = benchmark::Counter(sims, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SobolStudyLumpedSphere)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
