// The one abstraction of "other processes" in sigmaheart (docs/architecture.md, "Parallelism"): a
// group of ranks that run the same code and meet in collective calls. SerialCommunicator is the
// group of one; MpiCommunicator (estimation/parallel/mpi_communicator.h, built with
// SIGMAHEART_HAVE_MPI) wraps an MPI communicator handle. Only WorkerPool and app/cli.cpp call
// these; estimators see ranks only through the Ensemble.
//
// Contract: every call except rank(), size(), root() and SharedCounter::fetch_add is collective:
// all ranks call it, in the same order, with matching arguments (same root, same buffer sizes
// for broadcast). A rank that skips a collective makes the others wait forever, so code that can
// fail on one rank only must still reach the next collective (app/cli.cpp agrees on exit codes
// with all_reduce_max for that reason). Not thread-safe: call from one thread at a time.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace sigmaheart::estimation::parallel {

// A counter held by rank 0 that any thread of any rank can advance atomically: the self-scheduling
// hand-out of members (each fetch_add(1) returns the next unclaimed member index).
class SharedCounter {
 public:
  virtual ~SharedCounter() = default;
  // Adds `increment` and returns the value before. Not collective; callers serialise calls
  // within a process (WorkerPool does it in an OpenMP critical section).
  virtual long fetch_add(long increment) = 0;
};

class Communicator {
 public:
  virtual ~Communicator() = default;

  virtual int rank() const = 0;
  virtual int size() const = 0;
  bool root() const { return rank() == 0; }

  virtual void barrier() = 0;
  // Copies `data` of rank `root` into `data` of every rank (same size on every rank).
  virtual void broadcast(std::span<std::byte> data, int root) = 0;
  void broadcast(std::span<int> data, int root) { broadcast(std::as_writable_bytes(data), root); }
  void broadcast(std::span<double> data, int root) {
    broadcast(std::as_writable_bytes(data), root);
  }
  int broadcast(int value, int root);
  // Strings of any length (sizes need not match on the other ranks).
  std::string broadcast(const std::string& text, int root);
  // Every rank contributes a buffer of any length; every rank receives all of them, by rank.
  virtual std::vector<std::vector<std::byte>> all_gather(std::span<const std::byte> local) = 0;
  // The largest `value` over the ranks (used to agree on exit codes).
  virtual int all_reduce_max(int value) = 0;
  // Collective: a new counter starting at 0, shared by all ranks of this communicator.
  virtual std::unique_ptr<SharedCounter> make_counter() = 0;
  // Whether SharedCounter::fetch_add may be called from several threads of a rank (serialised);
  // false under MPI initialised below MPI_THREAD_SERIALIZED, then only the calling thread may.
  virtual bool counter_from_threads() const = 0;
};

// One rank: collectives are copies, the counter is an atomic.
class SerialCommunicator final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void barrier() override {}
  using Communicator::broadcast;
  void broadcast(std::span<std::byte>, int) override {}
  std::vector<std::vector<std::byte>> all_gather(std::span<const std::byte> local) override;
  int all_reduce_max(int value) override { return value; }
  std::unique_ptr<SharedCounter> make_counter() override;
  bool counter_from_threads() const override { return true; }
};

// The communicator of all processes of this run: the MPI world while an MpiSession
// (estimation/mpi.h) is alive, otherwise a SerialCommunicator. Backend::kMpi uses it.
Communicator& world_communicator();

}  // namespace sigmaheart::estimation::parallel
