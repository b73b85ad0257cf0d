// Overhead of the black-box models per ensemble member (docs/architecture.md s.9): the
// external-program runner (member directory, parameter file, spawn, wait, CSV read, clean-up)
// around a trivial program, against spawning the same program alone; and a UM-Bridge Evaluate on
// loopback against the same run in process. Target: under 5 ms per member beyond the program's
// own run time. The server's throughput with 1, 2 and 8 concurrent clients (2 evaluation slots);
// the lumped-sphere beat in process, against which bench/python_api_bench.py gives the Python
// API's overhead per call. Run: build/bench/blackbox_bench
#include "app/blackbox/external_model.h"
#include "app/blackbox/process.h"
#include "app/blackbox/register.h"
#include "app/blackbox/umbridge.h"
#include "app/config.h"

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <thread>

namespace {

namespace fs = std::filesystem;
namespace bb = sigmaheart::app::blackbox;
using namespace sigmaheart;

fs::path bench_dir() {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("sigmaheart-blackbox-bench-" + std::to_string(::getpid()));
    fs::create_directories(d);
    // A trivial program: writes a three-row CSV to its second argument.
    {
      std::ofstream f(d / "trivial.sh");
      f << "#!/bin/sh\nprintf 'time [s], V_lv [m^3]\\n0, 1e-4\\n0.4, 5e-5\\n0.8, 1e-4\\n' > \"$2\"\n";
    }
    fs::permissions(d / "trivial.sh", fs::perms::owner_all, fs::perm_options::add);
    std::ofstream(d / "m.yaml") << "name: bench\nsimulator:\n  model: external\n  numerics:\n"
                                   "    command: \"./trivial.sh --out {output} --params {params}\"\n"
                                   "    workdir: runs\n    output: curves.csv\n    timeout: 10 s\n"
                                   "    parameters:\n"
                                   "      - {name: a, unit: Pa, nominal: 1, lower: 0, upper: 2}\n"
                                   "      - {name: b, unit: s, nominal: 1, lower: 0, upper: 2}\n"
                                   "    channels:\n      - {name: V_lv, unit: m^3}\n";
    return d;
  }();
  return dir;
}

// Runs the simulator of config `cfg` at its nominal parameters once per benchmark iteration.
void run_nominal(benchmark::State& state, const fs::path& cfg) {
  const app::Config c = app::load_config(cfg, {}, bb::cli_models());
  auto sim = c.simulator.make();
  const Eigen::VectorXd theta = sim->parameters().nominal();
  for (auto _ : state) {
    const auto r = sim->run(theta);
    if (!r.status.ok()) state.SkipWithError(r.status.message.c_str());
    benchmark::DoNotOptimize(r.trajectory.values.data());
  }
}

// The whole member: directory, parameter file, spawn, wait, CSV, removal.
void BM_ExternalMember(benchmark::State& state) {
  run_nominal(state, bench_dir() / "m.yaml");
}
BENCHMARK(BM_ExternalMember)->Unit(benchmark::kMillisecond)->UseRealTime();

// The program alone (same spawn path, fixed output file): the baseline the overhead is beyond.
void BM_ProgramAlone(benchmark::State& state) {
  const fs::path dir = bench_dir();
  bb::ProcessOptions p;
  p.executable = (dir / "trivial.sh").string();
  p.argv = {p.executable, "--out", (dir / "alone.csv").string()};
  p.workdir = dir;
  p.stdout_file = dir / "alone.out";
  p.stderr_file = dir / "alone.err";
  p.timeout = 10.0;
  for (auto _ : state) {
    const auto r = bb::run_process(p);
    if (!r.ok()) state.SkipWithError("the trivial program failed");
  }
}
BENCHMARK(BM_ProgramAlone)->Unit(benchmark::kMillisecond)->UseRealTime();

// A constant 4-parameter, 2-channel model, 81 samples: the model costs nothing, so the time is
// the protocol's.
class Flat final : public model::Simulator {
 public:
  Flat()
      : p_({{"a", "Pa", 1, 0, 2, "a"}, {"b", "Pa", 1, 0, 2, "b"}, {"c", "Pa", 1, 0, 2, "c"},
            {"d", "Pa", 1, 0, 2, "d"}}) {}
  std::string name() const override { return "flat"; }
  const model::ParameterSpace& parameters() const override { return p_; }
  std::vector<model::Channel> channels() const override { return {{"V_lv", "m^3", ""}, {"P_lv", "Pa", ""}}; }
  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override {
    model::RunResult r;
    r.trajectory.channels = channels();
    r.trajectory.times = Eigen::VectorXd::LinSpaced(81, 0.0, 0.8);
    r.trajectory.values = Eigen::MatrixXd::Constant(81, 2, theta.sum());
    return r;
  }
  std::unique_ptr<model::Simulator> clone() const override { return std::make_unique<Flat>(); }

 private:
  model::ParameterSpace p_;
};

void BM_UmbridgeEvaluate(benchmark::State& state) {
  bb::ServeOptions o;
  o.frames = 50;
  bb::UmbridgeServer server(std::make_unique<Flat>(), o);
  const int port = server.bind("127.0.0.1", 0);
  server.start();
  const fs::path cfg = bench_dir() / "u.yaml";
  std::ofstream(cfg) << "name: u\nsimulator:\n  model: umbridge\n  numerics:\n"
                        "    url: http://127.0.0.1:" << port << "\n    frames: 50\n    period: 0.8 s\n"
                        "    parameters:\n"
                        "      - {name: a, unit: Pa, nominal: 1, lower: 0, upper: 2}\n"
                        "      - {name: b, unit: Pa, nominal: 1, lower: 0, upper: 2}\n"
                        "      - {name: c, unit: Pa, nominal: 1, lower: 0, upper: 2}\n"
                        "      - {name: d, unit: Pa, nominal: 1, lower: 0, upper: 2}\n"
                        "    channels:\n      - {name: V_lv, unit: m^3}\n      - {name: P_lv, unit: Pa}\n";
  run_nominal(state, cfg);
  server.stop();
}
BENCHMARK(BM_UmbridgeEvaluate)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_FlatInProcess(benchmark::State& state) {
  Flat flat;
  const Eigen::VectorXd theta = flat.parameters().nominal();
  for (auto _ : state) {
    const auto r = flat.run(theta);
    benchmark::DoNotOptimize(bb::sample_curves(r.trajectory, {0, 1}, 50).data());
  }
}
BENCHMARK(BM_FlatInProcess)->Unit(benchmark::kMillisecond)->UseRealTime();

// The server under load: `clients` threads, each with its own keep-alive connection, send 50
// Evaluate requests each per iteration; 2 evaluation slots (the default of `serve`). Reported:
// requests per second.
void BM_ServerThroughput(benchmark::State& state) {
  const int clients = static_cast<int>(state.range(0));
  const int per_client = 50;
  bb::ServeOptions o;
  o.frames = 50;
  o.threads = 2;
  o.connections = 16;
  bb::UmbridgeServer server(std::make_unique<Flat>(), o);
  const int port = server.bind("127.0.0.1", 0);
  server.start();
  const std::string url = "http://127.0.0.1:" + std::to_string(port);
  const std::string body = R"({"name": "forward", "input": [[1, 1, 1, 1]], "config": {}})";
  long failed = 0;
  for (auto _ : state) {
    std::vector<std::thread> threads;
    std::vector<long> bad(static_cast<size_t>(clients), 0);
    for (int c = 0; c < clients; ++c) {
      threads.emplace_back([&, c] {
        httplib::Client client(url);
        client.set_keep_alive(true);
        client.set_tcp_nodelay(true);
        for (int r = 0; r < per_client; ++r) {
          auto res = client.Post("/Evaluate", body, "application/json");
          if (!res || res->status != 200) ++bad[static_cast<size_t>(c)];
        }
      });
    }
    for (auto& t : threads) t.join();
    for (long b : bad) failed += b;
  }
  if (failed > 0) state.SkipWithError("some requests failed");
  state.counters["requests/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * clients * per_client, benchmark::Counter::kIsRate);
  server.stop();
}
BENCHMARK(BM_ServerThroughput)->Arg(1)->Arg(2)->Arg(8)->Unit(benchmark::kMillisecond)->UseRealTime();

// One beat of configs/healthy.yaml in process (a simulator made per call, as the Python API's
// Config.run does): bench/python_api_bench.py times the same call from Python.
void BM_SphereBeatInProcess(benchmark::State& state) {
  const app::Config c = app::load_config(fs::path(SIGMAHEART_SOURCE_DIR) / "configs" / "healthy.yaml", {},
                                         bb::cli_models());
  const Eigen::VectorXd theta = c.simulator.parameters.nominal();
  for (auto _ : state) {
    auto sim = c.simulator.make();
    const auto r = sim->run(theta);
    if (!r.status.ok()) state.SkipWithError(r.status.message.c_str());
    benchmark::DoNotOptimize(r.trajectory.values.data());
  }
}
BENCHMARK(BM_SphereBeatInProcess)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
