#include "estimation/parallel/worker_pool.h"

#include "estimation/enum_names.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <utility>

namespace sigmaheart::estimation::parallel {

SIGMAHEART_ENUM_TEXT(Schedule, parse_schedule,
    {Schedule::kDynamic, "dynamic"}, {Schedule::kFixed, "fixed"}, {Schedule::kFixed, "static"})

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Contiguous block [begin, begin + count) of `rank` out of `size` (Schedule::kFixed): the first
// (members % size) ranks get one extra member.
std::pair<int, int> rank_block(int members, int rank, int size) {
  const int base = members / size;
  const int extra = members % size;
  return {rank * base + std::min(rank, extra), base + (rank < extra ? 1 : 0)};
}

model::Status status_from_exception(std::exception_ptr error) {
  try {
    std::rethrow_exception(std::move(error));
  } catch (const std::exception& e) {
    return model::Status::Error(model::StatusCode::kInvalidArgument,
                                std::string("exception: ") + e.what());
  } catch (...) {
    return model::Status::Error(model::StatusCode::kInvalidArgument,
                                "exception: unknown exception type");
  }
}

// One member finished (from any thread): counts it and reports to `progress`, keeping the first
// exception the callback throws (later calls are skipped once one has thrown).
void count_done(const std::function<void(int done, int total)>& progress, int& done, int members,
                std::exception_ptr& progress_error) {
#pragma omp critical(sigmaheart_pool_progress)
  {
    ++done;
    if (progress && !progress_error) {
      try {
        progress(done, members);
      } catch (...) {
        progress_error = std::current_exception();
      }
    }
  }
}

std::string what_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception type";
  }
}

// Byte (de)serialisation of the gathered results; every rank runs the same binary, so the
// native representation is exchanged as is.
class Writer {
 public:
  template <class T>
  void put(const T& value) {
    const auto* p = reinterpret_cast<const std::byte*>(&value);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  void put(const std::string& text) {
    put(static_cast<std::int64_t>(text.size()));
    const auto* p = reinterpret_cast<const std::byte*>(text.data());
    bytes.insert(bytes.end(), p, p + text.size());
  }
  void put(const double* values, int n) {
    const auto* p = reinterpret_cast<const std::byte*>(values);
    bytes.insert(bytes.end(), p, p + sizeof(double) * static_cast<size_t>(n));
  }
  std::vector<std::byte> bytes;
};

class Reader {
 public:
  explicit Reader(const std::vector<std::byte>& bytes) : bytes_(bytes) {}
  template <class T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  std::string get_string() {
    const auto n = static_cast<size_t>(get<std::int64_t>());
    std::string s(n, '\0');
    take(s.data(), n);
    return s;
  }
  void get(double* values, int n) { take(values, sizeof(double) * static_cast<size_t>(n)); }
  bool at_end() const { return offset_ == bytes_.size(); }

 private:
  void take(void* out, size_t n) {
    if (offset_ + n > bytes_.size()) throw std::logic_error("worker pool: truncated gather buffer");
    std::memcpy(out, bytes_.data() + offset_, n);
    offset_ += n;
  }
  const std::vector<std::byte>& bytes_;
  size_t offset_ = 0;
};

}  // namespace

Scheduler::Scheduler(PoolOptions options) : options_(std::move(options)) {
  if (options_.threads < 1) {
    std::ostringstream s;
    s << "worker pool: threads must be >= 1, got " << options_.threads;
    throw std::invalid_argument(s.str());
  }
}

int Scheduler::rank() const { return options_.communicator ? options_.communicator->rank() : 0; }
int Scheduler::ranks() const { return options_.communicator ? options_.communicator->size() : 1; }

RowResults Scheduler::map_rows(int members, int width, const RowTask& task) const {
  if (members < 0 || width < 0) {
    std::ostringstream s;
    s << "ensemble: map_rows needs members >= 0 and width >= 0, got " << members << ", " << width;
    throw std::invalid_argument(s.str());
  }
  Communicator* comm = options_.communicator;
  const bool distributed = comm != nullptr && comm->size() > 1;
  const int threads = options_.threads;

  // Row-major: one contiguous row per member (what the gather exchanges).
  std::vector<double> rows(static_cast<size_t>(members) * static_cast<size_t>(width), kNaN);
  std::vector<model::Status> status(static_cast<size_t>(members));
  std::vector<char> mine(static_cast<size_t>(members), 0);
  std::exception_ptr progress_error;
  int done = 0;

  auto run = [&](int m, int w) {
    const auto k = static_cast<size_t>(m);
    Eigen::Map<Eigen::VectorXd> row(rows.data() + k * static_cast<size_t>(width), width);
    model::Status st;
    try {
      st = task(m, w, row);
    } catch (...) {
      st = status_from_exception(std::current_exception());
    }
    if (st.ok() && !row.allFinite()) {
      std::ostringstream s;
      s << "member " << m << " returned non-finite output:";
      for (int j = 0; j < width; ++j) {
        if (!std::isfinite(row(j))) s << " [" << j << "] = " << row(j);
      }
      st = model::Status::Error(model::StatusCode::kNonFinite, s.str());
    }
    if (!st.ok()) row.setConstant(kNaN);
    status[k] = std::move(st);
    mine[k] = 1;
    count_done(options_.progress, done, members, progress_error);
  };

  const bool dynamic = options_.schedule == Schedule::kDynamic;
  if (!distributed) {
    if (threads <= 1 || members <= 1) {
      for (int m = 0; m < members; ++m) run(m, 0);
    } else if (dynamic) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
      for (int m = 0; m < members; ++m) run(m, omp_get_thread_num());
    } else {
#pragma omp parallel for schedule(static) num_threads(threads)
      for (int m = 0; m < members; ++m) run(m, omp_get_thread_num());
    }
  } else if (dynamic && (threads == 1 || comm->counter_from_threads())) {
    // Self-scheduling over all threads of all ranks: the counter on rank 0 hands out the next
    // member index; MPI calls are serialised by the critical section.
    const std::unique_ptr<SharedCounter> counter = comm->make_counter();  // collective
    auto claim_and_run = [&](int w) {
      for (;;) {
        long next = 0;
#pragma omp critical(sigmaheart_pool_counter)
        next = counter->fetch_add(1);
        if (next >= members) break;
        run(static_cast<int>(next), w);
      }
    };
    if (threads <= 1) {
      claim_and_run(0);
    } else {
#pragma omp parallel num_threads(threads)
      claim_and_run(omp_get_thread_num());
    }
  } else {
    const auto [begin, count] = rank_block(members, comm->rank(), comm->size());
    if (threads <= 1 || count <= 1) {
      for (int m = begin; m < begin + count; ++m) run(m, 0);
    } else {
#pragma omp parallel for schedule(static) num_threads(threads)
      for (int m = begin; m < begin + count; ++m) run(m, omp_get_thread_num());
    }
  }

  if (distributed) {
    Writer out;
    out.put(static_cast<std::int32_t>(progress_error ? 1 : 0));
    out.put(progress_error ? what_of(progress_error) : std::string());
    for (int m = 0; m < members; ++m) {
      const auto k = static_cast<size_t>(m);
      if (!mine[k]) continue;
      out.put(static_cast<std::int32_t>(m));
      out.put(static_cast<std::int32_t>(status[k].code));
      out.put(status[k].message);
      out.put(rows.data() + k * static_cast<size_t>(width), width);
    }
    const auto all = comm->all_gather(out.bytes);  // collective
    std::vector<char> seen(static_cast<size_t>(members), 0);
    std::string remote_error;
    for (size_t r = 0; r < all.size(); ++r) {
      Reader in(all[r]);
      const bool failed = in.get<std::int32_t>() != 0;
      const std::string message = in.get_string();
      if (failed && remote_error.empty()) {
        remote_error = "progress callback failed on rank " + std::to_string(r) + ": " + message;
      }
      while (!in.at_end()) {
        const std::int32_t m = in.get<std::int32_t>();
        if (m < 0 || m >= members || seen[static_cast<size_t>(m)]) {
          throw std::logic_error("worker pool: member " + std::to_string(m) +
                                 " gathered twice or out of range");
        }
        const auto k = static_cast<size_t>(m);
        seen[k] = 1;
        status[k].code = static_cast<model::StatusCode>(in.get<std::int32_t>());
        status[k].message = in.get_string();
        in.get(rows.data() + k * static_cast<size_t>(width), width);
      }
    }
    if (std::count(seen.begin(), seen.end(), 1) != members) {
      throw std::logic_error("worker pool: some members were computed by no rank");
    }
    if (!remote_error.empty()) {
      if (progress_error) std::rethrow_exception(progress_error);
      throw std::runtime_error(remote_error);
    }
  }

  RowResults result;
  result.rows = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      rows.data(), members, width);
  result.status = std::move(status);
  if (progress_error) std::rethrow_exception(progress_error);
  return result;
}

void Scheduler::for_each_local(int members,
                               const std::function<void(int member, int worker)>& task) const {
  if (members < 0) throw std::invalid_argument("ensemble: negative member count");
  std::vector<std::exception_ptr> errors(static_cast<size_t>(members));
  std::exception_ptr progress_error;
  int done = 0;
  auto run = [&](int m, int w) {
    try {
      task(m, w);
    } catch (...) {
      errors[static_cast<size_t>(m)] = std::current_exception();
    }
    count_done(options_.progress, done, members, progress_error);
  };
  const int threads = options_.threads;
  if (threads <= 1 || members <= 1) {
    for (int m = 0; m < members; ++m) run(m, 0);
  } else if (options_.schedule == Schedule::kDynamic) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int m = 0; m < members; ++m) run(m, omp_get_thread_num());
  } else {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int m = 0; m < members; ++m) run(m, omp_get_thread_num());
  }
  for (auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  if (progress_error) std::rethrow_exception(progress_error);
}

}  // namespace sigmaheart::estimation::parallel
