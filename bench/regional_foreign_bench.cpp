// Time per case of the foreign regional bench (issue 46; experiments/regional-foreign): the
// 17-patch model personalised from a 3D heart's regional volumes with the shipped config
// (experiments/regional-foreign/personalize-foreign.yaml), exactly as `sigmaheart personalize`
// runs it (set-up, alignment, shares, the filter and its MAP refinement), on 2 threads. Counters:
// `runs` (member runs), `converged` (1 when the run ends completed), `nis` (whole-data NIS),
// `auc` (infarct against the other segments; -1 without an infarct). The target is under 5 minutes
// per case on 2 threads.
//   build/bench/regional_foreign_bench                                # the eight cases
//   build/bench/regional_foreign_bench --benchmark_filter='/2$'       # lbbb-lad-large
#include "app/config.h"
#include "app/personalize_setup.h"
#include "estimation/roukf/roukf.h"
#include "experiments/regional-foreign/regional_foreign_cases.h"

#include <benchmark/benchmark.h>

#include <map>
#include <string>

namespace {

using namespace sigmaheart;

void BM_PersonalizeForeign(benchmark::State& state) {
  const auto& c = regional_foreign::cases().at(static_cast<size_t>(state.range(0)));
  state.SetLabel(c.name);
  const app::Config config =
      app::load_config(std::string(SIGMAHEART_SOURCE_DIR) + "/experiments/regional-foreign/personalize-foreign.yaml",
                       {"personalize.observations.file=../../configs/data/regional-foreign/" + c.name + ".csv",
                        "personalize.filter.threads=2"});
  estimation::RoukfSummary s;
  for (auto _ : state) {
    app::PersonalizeProblem problem = app::parse_personalize(config);
    auto simulator = app::prepare_personalize_model(config, problem, model::into_steppable(config.simulator.make()));
    s = estimation::run_roukf(*simulator, problem.prior, problem.data, problem.filter);
  }
  std::map<int, double> sigma0;
  for (size_t j = 0; j < s.parameter_names.size(); ++j) {
    for (int seg = 1; seg <= 16; ++seg) {
      if (s.parameter_names[j] == "sigma0_" + std::string(seg < 10 ? "0" : "") + std::to_string(seg)) {
        sigma0[seg] = s.theta(static_cast<Eigen::Index>(j));
      }
    }
  }
  state.counters["runs"] = s.member_runs;
  state.counters["converged"] = s.ok() ? 1 : 0;
  state.counters["nis"] = s.nis_mean;
  state.counters["auc"] = sigma0.empty() ? -1.0 : regional_foreign::statistics(sigma0, c.infarct).auc;
}
BENCHMARK(BM_PersonalizeForeign)->DenseRange(0, 7)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
