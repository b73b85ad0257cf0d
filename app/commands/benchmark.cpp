// `sigmaheart benchmark land|arostica`: the verification benchmarks of the 3D mechanics
// (benchmark_land.cpp: Land et al. 2015; benchmark_arostica.cpp: Arostica et al. 2025).
#include "app/commands/commands.h"

namespace sigmaheart::app {

void register_benchmark(CLI::App& app, CommandContext& ctx) {
  CLI::App* bench = app.add_subcommand("benchmark", "Verification benchmarks of the simulators");
  bench->require_subcommand(1);
  add_land_benchmark(*bench, ctx);
  add_arostica_benchmark(*bench, ctx);
}

}  // namespace sigmaheart::app
