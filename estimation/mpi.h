// MPI helpers for the ensemble's kMpi backend (ARCHITECTURE.md, "Parallelism and scale-out").
// Without MPI compiled in (SIGMAHEART_HAVE_MPI undefined), or before MPI is initialised, the
// process is rank 0 of 1 and MpiSession does nothing, so the same code runs serially.
#pragma once

namespace sigmaheart::estimation {

// True when the library was built with MPI (SIGMAHEART_HAVE_MPI).
bool mpi_compiled();
// True when MPI is compiled in, initialised and not yet finalised.
bool mpi_active();
// MPI_COMM_WORLD rank and size; 0 and 1 when MPI is not active.
int mpi_rank();
int mpi_size();

// Initialises MPI (thread level FUNNELED: only the thread that owns the session calls MPI) when
// it is not initialised yet, and finalises it on destruction if this session initialised it.
// Create one in main() before any Ensemble with Backend::kMpi.
class MpiSession {
 public:
  MpiSession();
  MpiSession(int* argc, char*** argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  bool owns() const { return owns_; }

 private:
  bool owns_ = false;
};

}  // namespace sigmaheart::estimation
