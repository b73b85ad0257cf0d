#include "estimation/ensemble.h"

#include <omp.h>

#ifdef SIGMAHEART_HAVE_MPI
#include <mpi.h>
#endif

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace sigmaheart::estimation {

const char* to_string(Backend backend) {
  switch (backend) {
    case Backend::kSerial: return "serial";
    case Backend::kThreads: return "threads";
    case Backend::kMpi: return "mpi";
  }
  return "unknown";
}

std::optional<Backend> parse_backend(const std::string& text) {
  if (text == "serial") return Backend::kSerial;
  if (text == "threads" || text == "openmp") return Backend::kThreads;
  if (text == "mpi") return Backend::kMpi;
  return std::nullopt;
}

std::string EnsembleOptions::validate() const {
  if (threads < 0) {
    std::ostringstream s;
    s << "ensemble: threads must be >= 0 (0: all cores), got " << threads;
    return s.str();
  }
  if (backend == Backend::kMpi && !mpi_compiled()) {
    return "ensemble: backend 'mpi' requested but sigmaheart was built without MPI "
           "(install OpenMPI or MPICH and reconfigure with SIGMAHEART_WITH_MPI=ON)";
  }
  return {};
}

int EnsembleResult::failures() const {
  int n = 0;
  for (const auto& s : status) n += s.ok() ? 0 : 1;
  return n;
}

std::vector<int> EnsembleResult::failed_members() const {
  std::vector<int> out;
  for (size_t i = 0; i < status.size(); ++i) {
    if (!status[i].ok()) out.push_back(static_cast<int>(i));
  }
  return out;
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Members [begin, end) on `workers` threads, static schedule; body(member, worker) must not throw.
template <class Body>
void parallel_members(int begin, int end, int workers, const Body& body) {
  if (workers <= 1 || end - begin <= 1) {
    for (int m = begin; m < end; ++m) body(m, 0);
    return;
  }
#pragma omp parallel for schedule(static) num_threads(workers)
  for (int m = begin; m < end; ++m) body(m, omp_get_thread_num());
}

// Contiguous block of members owned by `rank` out of `size`: the first (members % size) ranks get
// one extra member.
std::pair<int, int> rank_block(int members, int rank, int size) {
  const int base = members / size;
  const int extra = members % size;
  const int begin = rank * base + std::min(rank, extra);
  const int count = base + (rank < extra ? 1 : 0);
  return {begin, count};
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

#ifdef SIGMAHEART_HAVE_MPI
// Every rank contributes `count` items of `local`; all ranks receive the concatenation.
template <class T>
std::vector<T> allgatherv(const std::vector<T>& local, MPI_Datatype type) {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int mine = static_cast<int>(local.size());
  std::vector<int> counts(static_cast<size_t>(size));
  MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  std::vector<int> displs(static_cast<size_t>(size), 0);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  std::vector<T> all(static_cast<size_t>(displs.back() + counts.back()));
  MPI_Allgatherv(local.data(), mine, type, all.data(), counts.data(), displs.data(), type,
                 MPI_COMM_WORLD);
  return all;
}
#endif

}  // namespace

Ensemble::Ensemble(const ForwardModel& prototype, EnsembleOptions options)
    : options_(std::move(options)) {
  if (const std::string error = options_.validate(); !error.empty()) {
    throw std::invalid_argument(error);
  }
  int n = 1;
  if (options_.backend != Backend::kSerial) {
    n = options_.threads > 0 ? options_.threads : omp_get_max_threads();
  }
  clones_.reserve(static_cast<size_t>(n));
  for (int w = 0; w < n; ++w) {
    auto c = prototype.clone();
    if (!c) throw std::invalid_argument("ensemble: ForwardModel::clone() returned null");
    clones_.push_back(std::move(c));
  }
}

int Ensemble::workers() const { return static_cast<int>(clones_.size()); }

ForwardModel& Ensemble::worker_model(int worker) {
  if (worker < 0 || worker >= workers()) {
    std::ostringstream s;
    s << "ensemble: worker " << worker << " out of range [0, " << workers() << ")";
    throw std::out_of_range(s.str());
  }
  return *clones_[static_cast<size_t>(worker)];
}

void Ensemble::for_each(int members, const std::function<void(int member, int worker)>& task) {
  if (members < 0) throw std::invalid_argument("ensemble: negative member count");
  std::vector<std::exception_ptr> errors(static_cast<size_t>(members));
  std::exception_ptr progress_error;
  int done = 0;
  parallel_members(0, members, workers(), [&](int m, int w) {
    try {
      task(m, w);
    } catch (...) {
      errors[static_cast<size_t>(m)] = std::current_exception();
    }
#pragma omp critical(sigmaheart_ensemble_progress)
    {
      ++done;
      if (options_.progress && !progress_error) {
        try {
          options_.progress(done, members);
        } catch (...) {
          progress_error = std::current_exception();
        }
      }
    }
  });
  for (auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  if (progress_error) std::rethrow_exception(progress_error);
}

EnsembleResult Ensemble::map_rows(
    int members, int width,
    const std::function<model::Status(int member, int worker, Eigen::Ref<Eigen::VectorXd> row)>&
        task) {
  if (members < 0 || width < 0) {
    std::ostringstream s;
    s << "ensemble: map_rows needs members >= 0 and width >= 0, got " << members << ", " << width;
    throw std::invalid_argument(s.str());
  }
  int rank = 0;
  int size = 1;
  if (options_.backend == Backend::kMpi) {
    rank = mpi_rank();
    size = mpi_size();
  }
  const auto [begin, count] = rank_block(members, rank, size);

  // Row-major local block: one contiguous row per member (what the gather exchanges).
  std::vector<double> local(static_cast<size_t>(count) * static_cast<size_t>(width), kNaN);
  std::vector<model::Status> local_status(static_cast<size_t>(count));
  std::exception_ptr progress_error;
  int done = 0;
  parallel_members(begin, begin + count, workers(), [&](int m, int w) {
    const auto k = static_cast<size_t>(m - begin);
    Eigen::Map<Eigen::VectorXd> row(local.data() + k * static_cast<size_t>(width), width);
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
    local_status[k] = std::move(st);
#pragma omp critical(sigmaheart_ensemble_progress)
    {
      ++done;
      if (options_.progress && !progress_error) {
        try {
          options_.progress(done, count);
        } catch (...) {
          progress_error = std::current_exception();
        }
      }
    }
  });

  EnsembleResult result;
  result.status.resize(static_cast<size_t>(members));
  std::vector<double> rows;
  if (size == 1) {
    rows = std::move(local);
    result.status = std::move(local_status);
  } else {
#ifdef SIGMAHEART_HAVE_MPI
    rows = allgatherv(local, MPI_DOUBLE);
    std::vector<int> codes;
    std::vector<int> lengths;
    std::vector<char> text;
    for (const auto& s : local_status) {
      codes.push_back(static_cast<int>(s.code));
      lengths.push_back(static_cast<int>(s.message.size()));
      text.insert(text.end(), s.message.begin(), s.message.end());
    }
    codes = allgatherv(codes, MPI_INT);
    lengths = allgatherv(lengths, MPI_INT);
    text = allgatherv(text, MPI_CHAR);
    size_t offset = 0;
    for (int m = 0; m < members; ++m) {
      auto& s = result.status[static_cast<size_t>(m)];
      s.code = static_cast<model::StatusCode>(codes[static_cast<size_t>(m)]);
      const auto n = static_cast<size_t>(lengths[static_cast<size_t>(m)]);
      s.message.assign(text.data() + offset, n);
      offset += n;
    }
#endif
  }
  result.Z = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      rows.data(), members, width);
  if (progress_error) std::rethrow_exception(progress_error);
  return result;
}

EnsembleResult Ensemble::evaluate(const Eigen::MatrixXd& thetas) {
  const int inputs = clones_.front()->input_size();
  if (thetas.cols() != inputs) {
    std::ostringstream s;
    s << "ensemble: thetas must have one column per input (" << inputs << "), got "
      << thetas.cols();
    throw std::invalid_argument(s.str());
  }
  const int width = static_cast<int>(clones_.front()->outputs().size());
  return map_rows(static_cast<int>(thetas.rows()), width,
                  [&](int m, int w, Eigen::Ref<Eigen::VectorXd> z) {
                    const Eigen::VectorXd theta = thetas.row(m).transpose();
                    return clones_[static_cast<size_t>(w)]->evaluate(theta, z);
                  });
}

}  // namespace sigmaheart::estimation
