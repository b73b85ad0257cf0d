#include "estimation/mpi.h"

#ifdef SIGMAHEART_HAVE_MPI
#include "estimation/parallel/mpi_communicator.h"

#include <mpi.h>
#endif

#include <atomic>

namespace sigmaheart::estimation {

namespace {
std::atomic<parallel::Communicator*> g_world{nullptr};  // set while an MpiSession lives
}  // namespace

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

MpiSession::MpiSession() : MpiSession(nullptr, nullptr) {}

MpiSession::MpiSession(int* argc, char*** argv) {
#ifdef SIGMAHEART_HAVE_MPI
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) {
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided);
    owns_ = true;
  }
  world_ = std::make_unique<parallel::MpiCommunicator>(MPI_COMM_WORLD);
#else
  (void)argc;
  (void)argv;
  world_ = std::make_unique<parallel::SerialCommunicator>();
#endif
  g_world.store(world_.get());
}

MpiSession::~MpiSession() {
  g_world.store(nullptr);
  world_.reset();
#ifdef SIGMAHEART_HAVE_MPI
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (owns_ && !finalised) MPI_Finalize();
#endif
}

namespace parallel {

Communicator& world_communicator() {
  static SerialCommunicator serial;
  Communicator* world = g_world.load();
  return world ? *world : serial;
}

}  // namespace parallel

}  // namespace sigmaheart::estimation
