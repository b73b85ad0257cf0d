// Ensemble throughput (forward evaluations per second, the items_per_second column) on 1 and 2
// threads: a cheap CPU-bound map (scheduling overhead) and the lumped sphere through
// SimulatorForwardModel (real members); plus the wall time of a one-shot UT calibration of the
// lumped sphere (3 parameters, star rule, 7 members + centre + fit). And the hand-out of members
// of unequal cost (1 ms and 10 ms, the dear ones first) on 2 threads, dynamic vs the fixed split:
// the `efficiency` counter is (sum of member costs) / (threads x wall time).
// Under mpirun the same unequal members are spread over the ranks (one thread each) by the
// self-scheduling counter of the worker pool; the efficiency is then over ranks x wall time:
//   build/bench/ensemble_bench --benchmark_filter=Lumped
//   build/bench/ensemble_bench --benchmark_filter=UnequalCost
//   mpirun -np 2 build/bench/ensemble_bench --benchmark_filter=UnequalCostRanks
#include "estimation/checkpoint.h"
#include "estimation/ensemble.h"
#include "estimation/forward_model.h"
#include "estimation/mpi.h"
#include "estimation/ut_calibration.h"
#include "model/lumped/sphere.h"

#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <cmath>
#include <memory>
#include <thread>

namespace {

using namespace sigmaheart;
using estimation::Backend;
using estimation::EnsembleOptions;

// About 20 microseconds of transcendental arithmetic per member.
class CheapModel final : public estimation::ForwardModel {
 public:
  int input_size() const override { return 3; }
  std::vector<std::string> input_names() const override { return {"a", "b", "c"}; }
  std::vector<model::Channel> outputs() const override {
    return {{"s", "1", ""}, {"c", "1", ""}};
  }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& t,
                         Eigen::Ref<Eigen::VectorXd> z) override {
    double s = 0, c = 0;
    for (int k = 1; k <= 1000; ++k) {
      s += std::sin(k * t(0) + t(1)) / k;
      c += std::cos(k * t(2)) * std::exp(-1e-3 * k);
    }
    z << s, c;
    return model::Status::Ok();
  }
  std::unique_ptr<ForwardModel> clone() const override { return std::make_unique<CheapModel>(); }
};

// EDV and ESV of the simulated beat: the smallest observer that makes the sphere a forward map.
class VolumeExtremes final : public observers::Observer {
 public:
  std::vector<model::Channel> outputs() const override {
    return {{"EDV", "m^3", "max V_lv"}, {"ESV", "m^3", "min V_lv"}};
  }
  model::Status observe(const model::Trajectory& tr, Eigen::Ref<Eigen::VectorXd> z) const override {
    if (!tr.has_channel("V_lv") || tr.samples() < 3) {
      return model::Status::Error(model::StatusCode::kBadOutput, "no V_lv samples");
    }
    const Eigen::VectorXd v = tr.channel("V_lv");
    z << v.maxCoeff(), v.minCoeff();
    return model::Status::Ok();
  }
  std::unique_ptr<Observer> clone() const override { return std::make_unique<VolumeExtremes>(); }
};

// Busy for theta(0) milliseconds of wall time: spinning (a core is occupied as by a simulation)
// or sleeping (measures the hand-out alone, unaffected by other load on the machine).
class SpinModel final : public estimation::ForwardModel {
 public:
  explicit SpinModel(bool sleep) : sleep_(sleep) {}
  int input_size() const override { return 1; }
  std::vector<std::string> input_names() const override { return {"ms"}; }
  std::vector<model::Channel> outputs() const override { return {{"spins", "1", ""}}; }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& t,
                         Eigen::Ref<Eigen::VectorXd> z) override {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(t(0));
    if (sleep_) {
      std::this_thread::sleep_until(end);
      z(0) = t(0);
      return model::Status::Ok();
    }
    double spins = 0;
    while (std::chrono::steady_clock::now() < end) spins += 1;
    z(0) = spins > 0 ? t(0) : 0.0;
    return model::Status::Ok();
  }
  std::unique_ptr<ForwardModel> clone() const override { return std::make_unique<SpinModel>(sleep_); }

 private:
  bool sleep_;
};

EnsembleOptions threads(int n) {
  EnsembleOptions o;
  o.backend = Backend::kThreads;
  o.threads = n;
  return o;
}

void BM_EnsembleCheapModel(benchmark::State& state) {
  const int members = 64;
  const CheapModel proto;
  estimation::Ensemble ensemble(proto, threads(static_cast<int>(state.range(0))));
  Eigen::MatrixXd thetas(members, 3);
  for (int i = 0; i < members; ++i) thetas.row(i) << 0.01 * i, 0.3, 0.02 * i;
  for (auto _ : state) benchmark::DoNotOptimize(ensemble.evaluate(thetas).Z.data());
  state.SetItemsProcessed(state.iterations() * members);
}
BENCHMARK(BM_EnsembleCheapModel)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// 16 members: the first 4 cost 10 ms, the other 12 cost 1 ms (52 ms in all). A contiguous split
// on 2 threads gives one thread 44 ms and the other 8 ms (efficiency 52 / 88 = 0.59); dynamic
// hand-out approaches 26 ms (efficiency ~1). Args: threads, schedule (0 dynamic, 1 fixed),
// cost (0 spinning, 1 sleeping: use it on a loaded machine, where spinning threads share cores).
// The members of the unequal-cost benchmarks, `workers` threads or ranks of one thread each.
void run_unequal_cost(benchmark::State& state, EnsembleOptions o, int workers) {
  const int members = 16;
  Eigen::MatrixXd thetas(members, 1);
  for (int i = 0; i < members; ++i) thetas(i, 0) = i < 4 ? 10.0 : 1.0;
  const double serial_ms = thetas.sum();
  const SpinModel proto(state.range(2) == 1);
  o.schedule = state.range(1) == 0 ? estimation::parallel::Schedule::kDynamic
                                   : estimation::parallel::Schedule::kFixed;
  estimation::Ensemble ensemble(proto, o);
  double wall_ms = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(ensemble.evaluate(thetas).Z.data());
    wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  state.SetItemsProcessed(state.iterations() * members);
  state.SetLabel(estimation::parallel::to_string(o.schedule));
  state.counters["efficiency"] = serial_ms * static_cast<double>(state.iterations()) /
                                 (static_cast<double>(workers) * wall_ms);
}

void BM_EnsembleUnequalCost(benchmark::State& state) {
  run_unequal_cost(state, threads(static_cast<int>(state.range(0))), static_cast<int>(state.range(0)));
}
BENCHMARK(BM_EnsembleUnequalCost)
    ->ArgsProduct({{1, 2}, {0, 1}, {0, 1}})
    ->ArgNames({"threads", "fixed", "sleep"})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

const std::vector<std::string> kEstimated = {"sigma0", "R_p", "c1"};

void BM_EnsembleLumpedSphere(benchmark::State& state) {
  const model::lumped::LumpedSphere sphere;
  const VolumeExtremes observer;
  const estimation::SimulatorForwardModel fm(sphere, observer, kEstimated);
  const int members = 8;
  Eigen::MatrixXd thetas(members, 3);
  const auto& space = sphere.parameters();
  for (int i = 0; i < members; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double base = space[space.index_or_throw(kEstimated[static_cast<size_t>(j)])].nominal;
      thetas(i, j) = base * (1.0 + 0.05 * std::sin(1.0 + i + 2.0 * j));
    }
  }
  estimation::Ensemble ensemble(fm, threads(static_cast<int>(state.range(0))));
  int failures = 0;
  for (auto _ : state) failures = ensemble.evaluate(thetas).failures();
  state.SetItemsProcessed(state.iterations() * members);
  state.counters["failures"] = failures;
}
BENCHMARK(BM_EnsembleLumpedSphere)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_UtCalibrationLumpedSphereOneShot(benchmark::State& state) {
  const model::lumped::LumpedSphere sphere;
  const VolumeExtremes observer;
  const estimation::SimulatorForwardModel fm(sphere, observer, kEstimated);
  const auto& space = sphere.parameters();
  estimation::Prior pars;
  Eigen::VectorXd truth(3);
  for (int j = 0; j < 3; ++j) {
    const model::Parameter& q = space[space.index_or_throw(kEstimated[static_cast<size_t>(j)])];
    pars.parameters.push_back(estimation::PriorParameter::gaussian(
        q.name, q.unit, q.nominal, 0.1, estimation::SpreadKind::kRelative,
        {estimation::TransformKind::kLog, q.nominal}, 0.0));
    truth(j) = q.nominal * 1.08;
  }
  observers::ObservationSet obs;
  obs.names = {"EDV", "ESV"};
  obs.units = {"m^3", "m^3"};
  obs.y.resize(2);
  auto probe = fm.clone();
  if (!probe->evaluate(truth, obs.y).ok()) {
    state.SkipWithError("the lumped sphere failed at the synthetic truth");
    return;
  }
  obs.R = (0.02 * obs.y).array().square().matrix().asDiagonal();
  estimation::UtOptions opt;
  opt.sigma = {estimation::SigmaRule::kStar, 0.5};
  opt.ensemble = threads(static_cast<int>(state.range(0)));
  int runs = 0;
  for (auto _ : state) {
    const auto summary = estimation::UtCalibration(fm, pars, obs, opt).run();
    runs = summary.simulations;
    benchmark::DoNotOptimize(summary.eta_mean.data());
  }
  state.counters["runs"] = runs;
}
BENCHMARK(BM_UtCalibrationLumpedSphereOneShot)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The same members over the ranks of mpirun, one thread per rank (state.range(0) is unused: the
// rank count). Registered only under mpirun with several ranks, with a fixed iteration count so
// that every rank makes the same collective calls.
estimation::parallel::Communicator* g_world = nullptr;

// The cost of the checkpoint per UT iteration (docs/architecture.md s.5): `members` records of 60
// observations (the foreign-data calibration's vector) appended, flushed and fsynced, as
// Ensemble::map_rows does after each batch; and the lookup of the same records when resuming.
void BM_CheckpointIteration(benchmark::State& state) {
  const int members = static_cast<int>(state.range(0));
  const auto path = std::filesystem::temp_directory_path() / "sigmaheart-bench.checkpoint";
  estimation::CheckpointOptions co;
  co.path = path;
  co.fingerprint = 1;
  estimation::MemberCheckpoint checkpoint(co);
  const Eigen::VectorXd row = Eigen::VectorXd::LinSpaced(60, 1e-4, 2e4);
  long call = 0;
  for (auto _ : state) {
    for (int m = 0; m < members; ++m) {
      checkpoint.add(estimation::MemberCheckpoint::key("", 0, call, m), model::Status::Ok(), row);
    }
    checkpoint.flush();
    ++call;
  }
  state.counters["bytes_per_iteration"] = static_cast<double>(std::filesystem::file_size(path)) / call;
  checkpoint.remove();
}
BENCHMARK(BM_CheckpointIteration)->Arg(6)->Arg(25)->UseRealTime()->Unit(benchmark::kMicrosecond);

void BM_EnsembleUnequalCostRanks(benchmark::State& state) {
  EnsembleOptions o = threads(1);
  o.communicator = g_world;
  run_unequal_cost(state, o, g_world->size());
}

// Ranks other than 0 run the same benchmarks (their collective calls must match) and print nothing.
class QuietReporter final : public benchmark::BenchmarkReporter {
 public:
  bool ReportContext(const Context&) override { return true; }
  void ReportRuns(const std::vector<Run>&) override {}
};

}  // namespace

int main(int argc, char** argv) {
  estimation::MpiSession session(&argc, &argv);
  benchmark::Initialize(&argc, argv);
  if (session.world().size() > 1) {
    g_world = &session.world();
    benchmark::RegisterBenchmark("BM_EnsembleUnequalCostRanks", BM_EnsembleUnequalCostRanks)
        ->ArgsProduct({{session.world().size()}, {0, 1}, {0, 1}})
        ->ArgNames({"ranks", "fixed", "sleep"})
        ->Iterations(20)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
  }
  if (session.world().root()) {
    benchmark::RunSpecifiedBenchmarks();
  } else {
    QuietReporter quiet;
    benchmark::RunSpecifiedBenchmarks(&quiet);
  }
  benchmark::Shutdown();
  return 0;
}
