// The timing loops shared by lumped_beat_bench and regional_beat_bench.
#pragma once

#include "model/simulator.h"

#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include <optional>

namespace sigmaheart::bench {

// Warms `sim` up for `warmup_beats` periods from its initial state, then times one beat advanced
// from that (periodic) state per iteration. Returns the number of timed beats, with
// SetItemsProcessed set, or nullopt after SkipWithError when the warm-up or a beat fails.
template <class Sim>
std::optional<int> time_one_beat(benchmark::State& bench, Sim& sim, int warmup_beats) {
  const Eigen::VectorXd theta = sim.parameters().nominal();
  const double period = theta(*sim.parameters().index("period"));
  model::State s = sim.initial_state(theta);
  if (!sim.advance(s, theta, warmup_beats * period).ok()) {
    bench.SkipWithError("warm-up failed");
    return std::nullopt;
  }
  const model::State periodic = s;
  int beats = 0;
  for (auto _ : bench) {
    s = periodic;
    const auto status = sim.advance(s, theta, s.time + period);
    benchmark::DoNotOptimize(s.x.data());
    if (!status.ok()) {
      bench.SkipWithError(status.message.c_str());
      return std::nullopt;
    }
    ++beats;
  }
  bench.SetItemsProcessed(beats);
  return beats;
}

// Times one whole run() (beats until periodic, then the last-beat trajectory) per iteration, sets
// the "beats_per_run" counter and returns the number of beats simulated over all iterations.
template <class Sim>
int time_runs(benchmark::State& bench, Sim& sim) {
  const Eigen::VectorXd theta = sim.parameters().nominal();
  int beats = 0;
  for (auto _ : bench) {
    const auto r = sim.run(theta);
    benchmark::DoNotOptimize(r.trajectory.values.data());
    beats += r.info.beats;
  }
  bench.counters["beats_per_run"] =
      static_cast<double>(beats) / static_cast<double>(bench.iterations());
  return beats;
}

}  // namespace sigmaheart::bench
