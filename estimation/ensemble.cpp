#include "estimation/ensemble.h"

#include "estimation/enum_names.h"
#include "estimation/interrupt.h"

#include <omp.h>

#include <algorithm>
#include <limits>

#include <sstream>
#include <stdexcept>
#include <utility>

namespace sigmaheart::estimation {

SIGMAHEART_ENUM_TEXT(Backend, parse_backend,
    {Backend::kSerial, "serial"}, {Backend::kThreads, "threads"}, {Backend::kMpi, "mpi"},
    {Backend::kThreads, "openmp"})

std::string EnsembleOptions::validate() const {
  if (threads < 0 || threads > kMaxThreads) {
    std::ostringstream s;
    s << "ensemble: threads must lie in [0, " << kMaxThreads << "] (0: all cores), got " << threads;
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

Ensemble::Ensemble(const ForwardModel& prototype, EnsembleOptions options)
    : options_(std::move(options)) {
  if (const std::string error = options_.validate(); !error.empty()) {
    throw std::invalid_argument(error);
  }
  parallel::PoolOptions pool;
  pool.threads = 1;
  if (options_.backend != Backend::kSerial) {
    pool.threads = options_.threads > 0 ? options_.threads : omp_get_max_threads();
  }
  pool.communicator = options_.communicator;
  if (!pool.communicator && options_.backend == Backend::kMpi) {
    pool.communicator = &parallel::world_communicator();
  }
  pool.schedule = options_.schedule;
  comm_ = pool.communicator;
  if (options_.progress) {
    pool.progress = [this](int done, int) {
      options_.progress(progress_done_ + done - cancelled_.load(), progress_total_);
    };
  }
  if (options_.checkpoint) instance_ = options_.checkpoint->next_instance(options_.checkpoint_scope);
  pool_ = std::make_unique<parallel::WorkerPool<ForwardModel>>(prototype, std::move(pool));
}

int Ensemble::workers() const { return pool_->workers(); }
int Ensemble::rank() const { return pool_->scheduler().rank(); }
int Ensemble::ranks() const { return pool_->scheduler().ranks(); }

ForwardModel& Ensemble::worker_model(int worker) {
  if (worker < 0 || worker >= workers()) {
    std::ostringstream s;
    s << "ensemble: worker " << worker << " out of range [0, " << workers() << ")";
    throw std::out_of_range(s.str());
  }
  return pool_->model(worker);
}

void Ensemble::for_each(int members, const std::function<void(int member, int worker)>& task) {
  pool_->for_each_local(members, task);
}

EnsembleResult Ensemble::map_rows(
    int members, int width,
    const std::function<model::Status(int member, int worker, Eigen::Ref<Eigen::VectorXd> row)>&
        task) {
  const long call = calls_++;
  MemberCheckpoint* const checkpoint = options_.checkpoint;
  const int ranks = comm_ ? comm_->size() : 1;
  const bool records = checkpoint && (ranks == 1 || comm_->rank() == 0);
  auto key = [&](int m) {
    return MemberCheckpoint::key(options_.checkpoint_scope, instance_, call, m);
  };

  EnsembleResult result;
  result.Z = Eigen::MatrixXd::Constant(members, width, std::numeric_limits<double>::quiet_NaN());
  result.status.assign(static_cast<size_t>(members), model::Status::Ok());
  std::vector<int> todo;
  int found = 0;
  for (int m = 0; m < members; ++m) {
    const MemberCheckpoint::Record* r = checkpoint ? checkpoint->find(key(m)) : nullptr;
    if (r && r->row.size() == width && r->status.code != model::StatusCode::kCancelled) {
      result.Z.row(m) = r->row.transpose();
      result.status[static_cast<size_t>(m)] = r->status;
      ++found;
    } else {
      todo.push_back(m);
    }
  }
  if (found > 0) {
    reused_ += found;
    checkpoint->note_reused(found);
  }

  const int all = static_cast<int>(todo.size());
  const int batch = !checkpoint ? std::max(all, 1)
                    : options_.checkpoint_batch > 0 ? options_.checkpoint_batch
                                                    : std::max(32, 8 * workers() * ranks);
  progress_total_ = members;
  for (int start = 0; start < all || (start == 0 && all == 0); start += batch) {
    const int n = std::min(batch, all - start);
    progress_done_ = found + start;
    cancelled_.store(0);
    if (n > 0) {
      parallel::RowResults rows = pool_->map_rows(
          n, width, [&](int b, int worker, Eigen::Ref<Eigen::VectorXd> row) -> model::Status {
            if (interrupt_signal() != 0) {
              cancelled_.fetch_add(1);
              return model::Status::Error(model::StatusCode::kCancelled, "interrupted before it ran");
            }
            return task(todo[static_cast<size_t>(start + b)], worker, row);
          });
      for (int b = 0; b < n; ++b) {
        const int m = todo[static_cast<size_t>(start + b)];
        result.Z.row(m) = rows.rows.row(b);
        result.status[static_cast<size_t>(m)] = std::move(rows.status[static_cast<size_t>(b)]);
        if (records && result.status[static_cast<size_t>(m)].code != model::StatusCode::kCancelled) {
          checkpoint->add(key(m), result.status[static_cast<size_t>(m)], result.Z.row(m).transpose());
        }
      }
      if (records) checkpoint->flush();
    }
    // Every rank stops together: the largest signal number seen on any rank.
    int signal = interrupt_signal();
    if (ranks > 1) signal = comm_->all_reduce_max(signal);
    if (signal != 0) throw Interrupted{signal};
    if (all == 0) break;
  }
  return result;
}

EnsembleResult Ensemble::evaluate(const Eigen::MatrixXd& thetas) {
  return evaluate(thetas, Eigen::VectorXd(), false);
}

EnsembleResult Ensemble::evaluate(const Eigen::MatrixXd& thetas, const Eigen::VectorXd& from,
                                  bool produce) {
  const int inputs = pool_->model(0).input_size();
  if (thetas.cols() != inputs) {
    std::ostringstream s;
    s << "ensemble: thetas must have one column per input (" << inputs << "), got "
      << thetas.cols();
    throw std::invalid_argument(s.str());
  }
  const int outputs = static_cast<int>(pool_->model(0).outputs().size());
  const bool warm = produce || from.size() > 0;
  const int extra = produce ? pool_->model(0).warm_start_size() : 0;
  EnsembleResult result = map_rows(
      static_cast<int>(thetas.rows()), outputs + extra,
      [&](int m, int w, Eigen::Ref<Eigen::VectorXd> row) {
        const Eigen::VectorXd theta = thetas.row(m).transpose();
        if (!warm) return pool_->model(w).evaluate(theta, row);
        Eigen::VectorXd own;
        const model::Status st = pool_->model(w).evaluate_warm(theta, row.head(outputs), from,
                                                               produce ? &own : nullptr);
        // A warm start of the wrong size is none (zeros), never a NaN that fails the member.
        if (produce) row.tail(extra) = own.size() == extra ? own : Eigen::VectorXd::Zero(extra);
        return st;
      });
  if (extra > 0) {
    result.warm = result.Z.rightCols(extra);
    result.Z = result.Z.leftCols(outputs).eval();
  }
  return result;
}

}  // namespace sigmaheart::estimation
