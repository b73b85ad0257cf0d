// Calibration wall time of the lumped sphere on a foreign 30-frame case (issue 11, "Benchmark"):
// the UT calibration (mode map) against the Ceres MAP reference (multi-start least squares, the
// config's global_start), for the 5- and the 12-parameter configs of experiments/foreign-data,
// on 2 threads. Counters: `simulations` (forward runs per calibration), `objective` (the MAP
// objective Phi reached), `converged` (1 when the estimator says so). The target is a
// 12-parameter calibration in under 10 s on 2 threads (experiments/foreign-data/README.md).
//   build/bench/calibration_bench                                   # all four, one pass each
//   build/bench/calibration_bench --benchmark_filter='params:12/ceres:0'
#include "app/calibration_setup.h"
#include "app/config.h"
#include "estimation/forward_model.h"
#include "estimation/least_squares.h"
#include "estimation/ut_calibration.h"

#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <tuple>
#include <vector>

namespace {

using namespace sigmaheart;

constexpr int kThreads = 2;
constexpr const char* kCase = "one-fibre-healthy";  // 72 bpm, 30 frames of V_lv and P_lv

// The shipped config (14 parameters, sphere with an atrial chamber), the prescribed-atrium one
// (12) or the 5-parameter one on kCase with its period, parsed as `sigmaheart calibrate` parses
// it, and the forward model of its estimated parameters.
struct ForeignProblem {
  explicit ForeignProblem(int parameters, const std::string& case_name = kCase,
                          const std::string& period = "0.833333", std::vector<std::string> overrides = {})
      : config(app::load_config(
            std::string(SIGMAHEART_SOURCE_DIR) + "/experiments/foreign-data/" +
                (parameters == 5    ? "calibrate-foreign-5.yaml"
                 : parameters == 12 ? "calibrate-foreign-12.yaml"
                                    : "calibrate-foreign.yaml"),
            with_case(std::move(overrides), case_name, period))),
        problem(app::parse_calibration_problem(config)),
        simulator(config.simulator.make()),
        forward(*simulator, *problem.observer, problem.prior.names()) {
    ensemble.backend = estimation::Backend::kThreads;
    ensemble.threads = kThreads;
  }
  app::Config config;
  app::CalibrationProblem problem;
  std::unique_ptr<model::Simulator> simulator;
  estimation::SimulatorForwardModel forward;
  estimation::EnsembleOptions ensemble;

  static std::vector<std::string> with_case(std::vector<std::string> overrides, const std::string& case_name,
                                            const std::string& period) {
    overrides.push_back(std::string("observations.file=../../configs/data/foreign/") + case_name + ".csv");
    overrides.push_back("period=" + period);
    return overrides;
  }
};

// Args: number of estimated parameters (5, 12 or 14, picking the config); estimator (0: the UT as
// the config sets it, 1: the Ceres reference as the config sets it); start (0: as the config sets
// it, i.e. the 12- and 14-parameter configs' global start of 32 screened points and 4 local runs;
// 1: one local run from the prior mean).
void BM_CalibrateForeign(benchmark::State& state) {
  ForeignProblem f(static_cast<int>(state.range(0)));
  const bool ceres = state.range(1) == 1;
  if (state.range(2) == 1) {
    f.problem.options.global_start = {};
    f.problem.least_squares.screen_points = 0;
    f.problem.least_squares.starts = 1;
  }
  int simulations = 0;
  double objective = 0;
  bool converged = false;
  std::string termination;
  for (auto _ : state) {
    if (ceres) {
      estimation::LeastSquaresOptions options = f.problem.least_squares;
      options.ensemble = f.ensemble;
      const auto s = estimation::solve_map(f.forward, f.problem.prior, f.problem.observations, options);
      std::tie(simulations, objective, converged) = std::tuple(s.simulations, s.cost, s.ok());
      termination = estimation::to_string(s.termination);
    } else {
      estimation::UtOptions options = f.problem.options;
      options.ensemble = f.ensemble;
      const auto s =
          estimation::UtCalibration(f.forward, f.problem.prior, f.problem.observations, options).run();
      std::tie(simulations, objective, converged) =
          std::tuple(s.simulations, s.objective, s.termination == estimation::UtTermination::kConverged);
      termination = estimation::to_string(s.termination);
    }
  }
  state.counters["simulations"] = simulations;
  state.counters["objective"] = objective;
  state.counters["converged"] = converged ? 1 : 0;
  state.SetLabel(std::string(ceres ? "Ceres, " : "UT, ") + kCase + ", " + termination);
}
BENCHMARK(BM_CalibrateForeign)
    ->ArgNames({"params", "ceres", "single"})
    ->Args({5, 0, 0})->Args({5, 1, 0})
    ->Args({12, 0, 0})->Args({12, 1, 0})->Args({12, 0, 1})->Args({12, 1, 1})
    ->Args({14, 0, 0})->Args({14, 1, 0})->Args({14, 0, 1})->Args({14, 1, 1})
    ->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

// The shipped config on one case of each foreign family (issue 45, "Benchmark"): per case the
// wall time, forward runs and iterations, before and after side by side. Args: case (index into
// kCases); stop (0: the step-only stop of before issue 45, objective_tolerance 0, which also
// disables the valley finishing step; 1: the shipped config, objective-based stop).
// Arg version: which config (0: as issue 45 found it and first changed it: star sigma points, no
// secant iterations, a screen of 32 and 4 local runs, max_beats 120; 1: the shipped one: simplex,
// secant 8, a screen of 64 and 6 local runs, max_beats 60; experiments/foreign-data/README.md),
// 0 and 1 with the local runs one after another on both threads; 2: the shipped one with the local
// runs side by side, one per thread (UtGlobalStart::concurrent, the default): same numbers as 1.
//   build/bench/calibration_bench --benchmark_filter='BM_CalibrateForeignCase/case:1/'
struct BenchCase {
  const char* name;
  const char* period;  // [s], configs/data/foreign/cases.yaml
};
constexpr BenchCase kCases[] = {{"elastance-healthy", "0.923077"},
                                {"one-fibre-healthy", "0.833333"},
                                {"mooney-rivlin-healthy", "0.882353"},
                                {"mooney-rivlin-stiff", "0.937500"}};

void BM_CalibrateForeignCase(benchmark::State& state) {
  const BenchCase& c = kCases[state.range(0)];
  std::vector<std::string> overrides;
  if (state.range(2) == 0) {
    overrides = {"calibration.sigma_points=star", "calibration.secant_iterations=0",
                 "calibration.global_start.samples=32", "calibration.global_start.keep=4",
                 "simulator.numerics.max_beats=120"};
  }
  ForeignProblem f(14, c.name, c.period, overrides);
  estimation::UtOptions options = f.problem.options;
  options.ensemble = f.ensemble;
  if (state.range(1) == 0) options.objective_tolerance = 0.0;
  options.global_start.concurrent = state.range(2) == 2;
  estimation::UtSummary s;
  for (auto _ : state) {
    s = estimation::UtCalibration(f.forward, f.problem.prior, f.problem.observations, options).run();
  }
  state.counters["simulations"] = s.simulations;
  state.counters["iterations"] = static_cast<double>(s.iterations.size());
  state.counters["objective"] = s.objective;
  state.counters["converged"] = s.termination == estimation::UtTermination::kConverged ? 1 : 0;
  state.SetLabel(std::string("UT, ") + c.name + (state.range(1) == 0 ? ", step-only stop, " : ", ") +
                 (state.range(2) == 0   ? "before (star, 32/4), "
                  : state.range(2) == 1 ? "shipped, one after another, "
                                        : "shipped, side by side, ") +
                 estimation::to_string(s.termination));
}
BENCHMARK(BM_CalibrateForeignCase)
    ->ArgNames({"case", "stop", "version"})->ArgsProduct({{0, 1, 2, 3}, {0, 1}, {0, 1, 2}})
    ->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
