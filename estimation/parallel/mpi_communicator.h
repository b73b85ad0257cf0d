// Communicator over an MPI communicator handle (only with SIGMAHEART_HAVE_MPI). The handle is
// borrowed, not duplicated or freed: the creator (MpiSession for the world) keeps it alive.
// The shared counter is an MPI-3 RMA window of one long on rank 0, advanced with
// MPI_Fetch_and_op under a shared passive-target lock; fetch_add may be called from worker
// threads when MPI runs at MPI_THREAD_SERIALIZED or above (MpiSession asks for it).
#pragma once

#ifdef SIGMAHEART_HAVE_MPI

#include "estimation/parallel/communicator.h"

#include <mpi.h>

namespace sigmaheart::estimation::parallel {

class MpiCommunicator final : public Communicator {
 public:
  explicit MpiCommunicator(MPI_Comm comm);

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void barrier() override;
  using Communicator::broadcast;
  void broadcast(std::span<std::byte> data, int root) override;
  std::vector<std::vector<std::byte>> all_gather(std::span<const std::byte> local) override;
  int all_reduce_max(int value) override;
  std::unique_ptr<SharedCounter> make_counter() override;
  bool counter_from_threads() const override { return serialized_; }

  MPI_Comm handle() const { return comm_; }

 private:
  MPI_Comm comm_;
  int rank_ = 0;
  int size_ = 1;
  bool serialized_ = false;
};

}  // namespace sigmaheart::estimation::parallel

#endif  // SIGMAHEART_HAVE_MPI
