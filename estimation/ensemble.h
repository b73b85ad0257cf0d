// Ensembles of independent forward evaluations (sigma points, designs), serial or on threads.
// Each worker owns its own clone of the forward model; nothing mutable is shared, so the numbers
// do not depend on the backend or the thread count (ARCHITECTURE.md, "Parallelism").
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::estimation {

// theta (the estimated parameters, physical units) -> z (observations, SI). A failure is a Status.
class ForwardModel {
 public:
  virtual ~ForwardModel() = default;
  virtual int input_size() const = 0;
  virtual std::vector<std::string> input_names() const = 0;
  virtual std::vector<model::Channel> outputs() const = 0;   // names and SI units of z
  virtual model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                 Eigen::Ref<Eigen::VectorXd> z) = 0;
  virtual std::unique_ptr<ForwardModel> clone() const = 0;
};

enum class Backend { kSerial, kThreads, kMpi };
const char* to_string(Backend backend);
std::optional<Backend> parse_backend(const std::string& text);  // "serial", "threads", "mpi"

struct EnsembleOptions {
  Backend backend = Backend::kThreads;
  int threads = 0;  // 0: all cores (omp_get_max_threads)
  // Called on the calling thread's behalf (serialised) after each finished member.
  std::function<void(int done, int total)> progress;
  std::string validate() const;
};

struct EnsembleResult {
  Eigen::MatrixXd Z;                  // members x outputs; rows of failed members are NaN
  std::vector<model::Status> status;  // one per member
  int failures() const;
  std::vector<int> failed_members() const;
};

class Ensemble {
 public:
  Ensemble(const ForwardModel& prototype, EnsembleOptions options);

  int workers() const;
  // thetas: members x inputs (one member per row).
  EnsembleResult evaluate(const Eigen::MatrixXd& thetas);

  // Generic form for estimators with their own member task (the ROUKF advances model states):
  // task(member, worker) runs once per member, worker in [0, workers()), each worker on one thread
  // at a time. Member order is the static schedule, so results written per member are identical
  // for any thread count.
  void for_each(int members, const std::function<void(int member, int worker)>& task);

  ForwardModel& worker_model(int worker);

 private:
  EnsembleOptions options_;
  std::vector<std::unique_ptr<ForwardModel>> clones_;
};

}  // namespace sigmaheart::estimation
