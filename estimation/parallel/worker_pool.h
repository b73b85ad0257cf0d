// WorkerPool: runs independent members (sigma points, design points, cases) on the threads of
// this rank and on every rank of a Communicator, and returns one row and one Status per member
// on every rank. The only code in sigmaheart that knows about ranks; estimators use it through
// estimation::Ensemble (estimation/ensemble.h).
//
// Hand-out (Schedule::kDynamic, the default): members are claimed one at a time, in increasing
// index order, by whichever worker is free: an OpenMP schedule(dynamic, 1) loop inside one rank;
// across ranks a self-scheduling counter (SharedCounter: an MPI-3 RMA window on rank 0 advanced
// with MPI_Fetch_and_op, called by worker threads inside an OpenMP critical section, hence
// MPI_THREAD_SERIALIZED). Members of unequal cost then keep every core busy. Schedule::kFixed is
// the old split, kept for comparison (bench/ensemble_bench.cpp): contiguous blocks over ranks, a
// static OpenMP schedule inside a rank. Under MPI below MPI_THREAD_SERIALIZED with several
// threads per rank, kDynamic falls back to kFixed.
//
// Determinism: a member is computed by the same task on its worker's own clone, whatever worker
// that is, and its row is placed by member index, so results are bitwise identical for every
// thread count, rank count and hand-out order, provided the task's result depends only on the
// member (not on what the worker computed before).
//
// Failures: a task that throws or returns a non-finite row gets a non-ok Status and a NaN row;
// the pool never throws for a member's failure. An exception from the progress callback on any
// rank is rethrown on every rank after the results are gathered (so no rank is left waiting).
#pragma once

#include "estimation/parallel/communicator.h"

#include "model/simulator.h"

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::estimation::parallel {

enum class Schedule { kDynamic, kFixed };
const char* to_string(Schedule schedule);
std::optional<Schedule> parse_schedule(const std::string& text);  // "dynamic", "fixed"

struct PoolOptions {
  int threads = 1;                       // worker threads in this rank, >= 1
  Communicator* communicator = nullptr;  // null or one rank: members stay in this process
  Schedule schedule = Schedule::kDynamic;
  // Called (serialised, possibly from a worker thread) after each member this rank finished:
  // done counts this rank's finished members, total is the member count (with several ranks,
  // done therefore stops below total).
  std::function<void(int done, int total)> progress;
};

struct RowResults {
  Eigen::MatrixXd rows;               // members x width; rows of failed members are NaN
  std::vector<model::Status> status;  // one per member
};

// task(member, worker, row): fill `row` (width entries, NaN on entry) for `member` using only
// worker `worker`'s resources; return its Status.
using RowTask =
    std::function<model::Status(int member, int worker, Eigen::Ref<Eigen::VectorXd> row)>;

// The scheduling and gathering engine, independent of what a worker owns.
class Scheduler {
 public:
  explicit Scheduler(PoolOptions options);

  int threads() const { return options_.threads; }
  int rank() const;
  int ranks() const;
  const PoolOptions& options() const { return options_; }

  // Collective over the communicator (every rank calls it with the same members and width).
  RowResults map_rows(int members, int width, const RowTask& task) const;
  // Every member on this rank's threads (never across ranks: the task's results stay in the
  // caller's memory). The exception of the lowest failing member is rethrown after all ran.
  void for_each_local(int members, const std::function<void(int member, int worker)>& task) const;

 private:
  PoolOptions options_;
};

// A Scheduler plus one clone of `Model` per worker thread (Model has
// std::unique_ptr<Model> clone() const, e.g. ForwardModel or model::Simulator).
template <class Model>
class WorkerPool {
 public:
  WorkerPool(const Model& prototype, PoolOptions options) : scheduler_(std::move(options)) {
    for (int w = 0; w < scheduler_.threads(); ++w) {
      auto c = prototype.clone();
      if (!c) throw std::invalid_argument("worker pool: clone() returned null");
      clones_.push_back(std::move(c));
    }
  }

  int workers() const { return static_cast<int>(clones_.size()); }
  Model& model(int worker) {
    if (worker < 0 || worker >= workers()) {
      std::ostringstream s;
      s << "worker pool: worker " << worker << " out of range [0, " << workers() << ")";
      throw std::out_of_range(s.str());
    }
    return *clones_[static_cast<size_t>(worker)];
  }
  const Scheduler& scheduler() const { return scheduler_; }

  RowResults map_rows(int members, int width, const RowTask& task) const {
    return scheduler_.map_rows(members, width, task);
  }
  void for_each_local(int members, const std::function<void(int member, int worker)>& task) const {
    scheduler_.for_each_local(members, task);
  }

 private:
  Scheduler scheduler_;
  std::vector<std::unique_ptr<Model>> clones_;
};

}  // namespace sigmaheart::estimation::parallel
