// The MPI session of a process (docs/architecture.md, "Parallelism and scale-out"). Without MPI
// compiled in (SIGMAHEART_HAVE_MPI undefined), or before MPI is initialised, the process is
// rank 0 of 1 and MpiSession does nothing, so the same code runs serially. Ranks and collectives
// are reached through parallel::Communicator (estimation/parallel/communicator.h); this file is
// the only place that names MPI_COMM_WORLD.
#pragma once

#include "estimation/parallel/communicator.h"

#include <memory>

namespace sigmaheart::estimation {

// True when the library was built with MPI (SIGMAHEART_HAVE_MPI).
bool mpi_compiled();
// True when MPI is compiled in, initialised and not yet finalised.
bool mpi_active();

// Initialises MPI when it is not initialised yet, asking for MPI_THREAD_SERIALIZED (worker
// threads take members from the shared RMA counter one at a time, WorkerPool), and finalises it
// on destruction if this session initialised it. Create one in main(), before anything parallel;
// world() is then the communicator of all ranks (parallel::world_communicator() returns it while
// the session lives). One session at a time.
class MpiSession {
 public:
  MpiSession();
  MpiSession(int* argc, char*** argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  bool owns() const { return owns_; }
  parallel::Communicator& world() { return *world_; }

 private:
  bool owns_ = false;
  std::unique_ptr<parallel::Communicator> world_;
};

}  // namespace sigmaheart::estimation
