#include "estimation/mpi.h"

#ifdef SIGMAHEART_HAVE_MPI
#include <mpi.h>
#endif

namespace sigmaheart::estimation {

bool mpi_compiled() {
#ifdef SIGMAHEART_HAVE_MPI
  return true;
#else
  return false;
#endif
}

bool mpi_active() {
#ifdef SIGMAHEART_HAVE_MPI
  int initialised = 0;
  int finalised = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalised);
  return initialised && !finalised;
#else
  return false;
#endif
}

int mpi_rank() {
#ifdef SIGMAHEART_HAVE_MPI
  if (!mpi_active()) return 0;
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
#else
  return 0;
#endif
}

int mpi_size() {
#ifdef SIGMAHEART_HAVE_MPI
  if (!mpi_active()) return 1;
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size;
#else
  return 1;
#endif
}

MpiSession::MpiSession() : MpiSession(nullptr, nullptr) {}

MpiSession::MpiSession(int* argc, char*** argv) {
#ifdef SIGMAHEART_HAVE_MPI
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) {
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    owns_ = true;
  }
#else
  (void)argc;
  (void)argv;
#endif
}

MpiSession::~MpiSession() {
#ifdef SIGMAHEART_HAVE_MPI
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (owns_ && !finalised) MPI_Finalize();
#endif
}

}  // namespace sigmaheart::estimation
