#include "estimation/ensemble.h"

#include "estimation/enum_names.h"

#include <omp.h>

#include <sstream>
#include <stdexcept>
#include <utility>

namespace sigmaheart::estimation {

constexpr std::array<EnumName<Backend>, 4> kBackendNames{{
    {Backend::kSerial, "serial"}, {Backend::kThreads, "threads"}, {Backend::kMpi, "mpi"},
    {Backend::kThreads, "openmp"},
}};
const char* to_string(Backend backend) { return enum_to_string(kBackendNames, backend); }
std::optional<Backend> parse_backend(const std::string& text) {
  return enum_from_string(kBackendNames, text);
}

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
  pool.progress = options_.progress;
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
  parallel::RowResults rows = pool_->map_rows(members, width, task);
  EnsembleResult result;
  result.Z = std::move(rows.rows);
  result.status = std::move(rows.status);
  return result;
}

EnsembleResult Ensemble::evaluate(const Eigen::MatrixXd& thetas) {
  const int inputs = pool_->model(0).input_size();
  if (thetas.cols() != inputs) {
    std::ostringstream s;
    s << "ensemble: thetas must have one column per input (" << inputs << "), got "
      << thetas.cols();
    throw std::invalid_argument(s.str());
  }
  const int width = static_cast<int>(pool_->model(0).outputs().size());
  return map_rows(static_cast<int>(thetas.rows()), width,
                  [&](int m, int w, Eigen::Ref<Eigen::VectorXd> z) {
                    const Eigen::VectorXd theta = thetas.row(m).transpose();
                    return pool_->model(w).evaluate(theta, z);
                  });
}

}  // namespace sigmaheart::estimation
