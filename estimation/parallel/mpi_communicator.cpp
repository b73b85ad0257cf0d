#include "estimation/parallel/mpi_communicator.h"

#ifdef SIGMAHEART_HAVE_MPI

#include <limits>
#include <stdexcept>
#include <string>

namespace sigmaheart::estimation::parallel {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int length = 0;
    MPI_Error_string(code, text, &length);
    throw std::runtime_error(std::string("MPI: ") + what + " failed: " + std::string(text, static_cast<size_t>(length)));
  }
}

int checked_count(size_t n) {
  if (n > static_cast<size_t>(std::numeric_limits<int>::max())) {
    throw std::length_error("MPI: message larger than 2 GiB");
  }
  return static_cast<int>(n);
}

// One long on rank 0 behind an RMA window; fetch_add is MPI_Fetch_and_op(MPI_SUM) under a shared
// lock, which MPI makes atomic with respect to every other accumulate on the same location.
class RmaCounter final : public SharedCounter {
 public:
  explicit RmaCounter(MPI_Comm comm) : comm_(comm) {
    int rank = 0;
    MPI_Comm_rank(comm_, &rank);
    const MPI_Aint bytes = rank == 0 ? static_cast<MPI_Aint>(sizeof(long)) : 0;
    check(MPI_Win_allocate(bytes, sizeof(long), MPI_INFO_NULL, comm_, &base_, &window_),
          "MPI_Win_allocate");
    if (rank == 0) {
      const long zero = 0;
      MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, window_);
      MPI_Put(&zero, 1, MPI_LONG, 0, 0, 1, MPI_LONG, window_);
      MPI_Win_unlock(0, window_);
    }
    MPI_Barrier(comm_);  // nobody fetches before the counter is zero
  }
  ~RmaCounter() override { MPI_Win_free(&window_); }  // collective, as the construction
  RmaCounter(const RmaCounter&) = delete;
  RmaCounter& operator=(const RmaCounter&) = delete;

  long fetch_add(long increment) override {
    long before = 0;
    MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, window_);
    MPI_Fetch_and_op(&increment, &before, MPI_LONG, 0, 0, MPI_SUM, window_);
    MPI_Win_unlock(0, window_);
    return before;
  }

 private:
  MPI_Comm comm_;
  MPI_Win window_ = MPI_WIN_NULL;
  void* base_ = nullptr;
};

}  // namespace

MpiCommunicator::MpiCommunicator(MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  int level = MPI_THREAD_SINGLE;
  MPI_Query_thread(&level);
  serialized_ = level >= MPI_THREAD_SERIALIZED;
}

void MpiCommunicator::barrier() { check(MPI_Barrier(comm_), "MPI_Barrier"); }

void MpiCommunicator::broadcast(std::span<std::byte> data, int root) {
  check(MPI_Bcast(data.data(), checked_count(data.size()), MPI_BYTE, root, comm_), "MPI_Bcast");
}

std::vector<std::vector<std::byte>> MpiCommunicator::all_gather(std::span<const std::byte> local) {
  const int mine = checked_count(local.size());
  std::vector<int> counts(static_cast<size_t>(size_));
  check(MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_), "MPI_Allgather");
  std::vector<int> displs(static_cast<size_t>(size_), 0);
  size_t total = static_cast<size_t>(counts[0]);
  for (size_t r = 1; r < counts.size(); ++r) {
    displs[r] = checked_count(static_cast<size_t>(displs[r - 1]) + static_cast<size_t>(counts[r - 1]));
    total += static_cast<size_t>(counts[r]);
  }
  std::vector<std::byte> all(total);
  check(MPI_Allgatherv(local.data(), mine, MPI_BYTE, all.data(), counts.data(), displs.data(),
                       MPI_BYTE, comm_),
        "MPI_Allgatherv");
  std::vector<std::vector<std::byte>> out(static_cast<size_t>(size_));
  for (size_t r = 0; r < out.size(); ++r) {
    const auto begin = all.begin() + displs[r];
    out[r].assign(begin, begin + counts[r]);
  }
  return out;
}

int MpiCommunicator::all_reduce_max(int value) {
  int result = value;
  check(MPI_Allreduce(&value, &result, 1, MPI_INT, MPI_MAX, comm_), "MPI_Allreduce");
  return result;
}

std::unique_ptr<SharedCounter> MpiCommunicator::make_counter() {
  return std::make_unique<RmaCounter>(comm_);
}

}  // namespace sigmaheart::estimation::parallel

#endif  // SIGMAHEART_HAVE_MPI
