// Calibration wall time of the lumped sphere on a foreign 30-frame case (issue 11, "Benchmark"):
// the UT calibration (mode map) against the Ceres MAP reference (multi-start least squares, the
// config's global_start), for the 5- and the 12-parameter configs of experiments/foreign-data,
// on 2 threads. Counters: `simulations` (forward runs per calibration), `objective` (the MAP
// objective Phi reached), `converged` (1 when the estimator says so). The target is a
// 12-parameter calibration in under 10 s on 2 threads (experiments/foreign-data/README.md).
//   build/bench/calibration_bench                                   # all four, one pass each
//   build/bench/calibration_bench --benchmark_filter=Ut/12
#include "app/calibration_setup.h"
#include "app/config.h"
#include "estimation/forward_model.h"
#include "estimation/least_squares.h"
#include "estimation/ut_calibration.h"

#include <benchmark/benchmark.h>

#include <string>

namespace {

using namespace sigmaheart;

constexpr int kThreads = 2;
constexpr const char* kCase = "one-fibre-healthy";  // 72 bpm, 30 frames of V_lv and P_lv

// The shipped config (12 parameters) or the 5-parameter one, on kCase with its period.
app::Config foreign_config(int parameters) {
  const std::string dir = std::string(SIGMAHEART_SOURCE_DIR) + "/experiments/foreign-data/";
  const std::string file = parameters == 5 ? "calibrate-foreign-5.yaml" : "calibrate-foreign.yaml";
  return app::load_config(dir + file, {std::string("observations.file=../../configs/data/foreign/") +
                                           kCase + ".csv",
                                       "period=0.833333"});
}

estimation::EnsembleOptions two_threads() {
  estimation::EnsembleOptions e;
  e.backend = estimation::Backend::kThreads;
  e.threads = kThreads;
  return e;
}

// Args: number of estimated parameters (5 or 12).
void BM_CalibrateForeignUt(benchmark::State& state) {
  const app::Config config = foreign_config(static_cast<int>(state.range(0)));
  const app::CalibrationProblem problem = app::parse_calibration_problem(config);
  const auto simulator = config.simulator.make();
  estimation::SimulatorForwardModel forward(*simulator, *problem.observer, problem.prior.names());
  estimation::UtOptions options = problem.options;
  options.ensemble = two_threads();
  estimation::UtSummary summary;
  for (auto _ : state) {
    estimation::UtCalibration calibration(forward, problem.prior, problem.observations, options);
    summary = calibration.run();
  }
  state.counters["simulations"] = summary.simulations;
  state.counters["objective"] = summary.objective;
  state.counters["converged"] = summary.termination == estimation::UtTermination::kConverged ? 1 : 0;
  state.SetLabel(std::string(kCase) + ", " + estimation::to_string(summary.termination));
}
BENCHMARK(BM_CalibrateForeignUt)
    ->ArgName("params")->Arg(5)->Arg(12)
    ->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

void BM_CalibrateForeignCeres(benchmark::State& state) {
  const app::Config config = foreign_config(static_cast<int>(state.range(0)));
  const app::CalibrationProblem problem = app::parse_calibration_problem(config);
  const auto simulator = config.simulator.make();
  estimation::SimulatorForwardModel forward(*simulator, *problem.observer, problem.prior.names());
  estimation::LeastSquaresOptions options = problem.least_squares;
  options.ensemble = two_threads();
  estimation::LeastSquaresSummary summary;
  for (auto _ : state) {
    summary = estimation::solve_map(forward, problem.prior, problem.observations, options);
  }
  state.counters["simulations"] = summary.simulations;
  state.counters["objective"] = summary.cost;
  state.counters["converged"] = summary.ok() ? 1 : 0;
  state.SetLabel(std::string(kCase) + ", " + estimation::to_string(summary.termination));
}
BENCHMARK(BM_CalibrateForeignCeres)
    ->ArgName("params")->Arg(5)->Arg(12)
    ->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
