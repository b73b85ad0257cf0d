// Ensembles of independent forward evaluations (sigma points, designs), serial, on threads and
// on ranks, implemented on parallel::WorkerPool (estimation/parallel/worker_pool.h). Each worker
// owns its own clone of the forward model; nothing mutable is shared, so the numbers do not
// depend on the backend, the thread count, the rank count or the hand-out order (docs/architecture.md,
// "Parallelism").
//
// Interruption (estimation/interrupt.h): once SIGINT or SIGTERM has been received, members not
// yet started are not run (Status kCancelled); after the batch the finished members are recorded in
// the checkpoint (if any) and evaluate()/map_rows() throw Interrupted on every rank.
//
// Failures: a member whose forward model returns a non-ok Status, throws, or returns non-finite
// z gets a non-ok Status and a NaN row; the ensemble itself never throws for a member's failure.
// Exceptions thrown by a member are turned into StatusCode::kInvalidArgument with the message
// "exception: <what()>" (the contract has no dedicated code for them); non-finite output becomes
// kNonFinite.
//
// Ranks: set EnsembleOptions::communicator (commands pass CommandContext::comm). With more than
// one rank every rank runs the same estimator code and calls evaluate()/map_rows() collectively
// with the same arguments; members are handed out dynamically over the threads of all ranks and
// the rows are gathered on every rank, so every rank continues with identical numbers. Without a
// communicator (or with one rank) members stay in this process. Backend::kMpi is the older way to
// ask for ranks: it uses the world communicator (parallel::world_communicator(), the MPI world
// while an MpiSession lives, else one rank). With several ranks per node set `threads`
// explicitly (0 means all cores in every rank).
#pragma once

#include "estimation/checkpoint.h"
#include "estimation/mpi.h"
#include "estimation/parallel/communicator.h"
#include "estimation/parallel/worker_pool.h"

#include "model/simulator.h"

#include <Eigen/Core>

#include <atomic>
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

  // Warm starts (model::Simulator::run_warm; docs/estimation.md s.3.8): evaluate() starting from
  // the warm start `from` of an earlier evaluation (empty: cold), writing this evaluation's own to
  // `produce` (warm_start_size() entries, all zero when it has none). Default: no warm starts.
  virtual int warm_start_size() const { return 0; }
  virtual model::Status evaluate_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                      Eigen::Ref<Eigen::VectorXd> z, const Eigen::VectorXd& from,
                                      Eigen::VectorXd* produce) {
    (void)from;
    if (produce) *produce = Eigen::VectorXd::Zero(warm_start_size());
    return evaluate(theta, z);
  }
};

enum class Backend { kSerial, kThreads, kMpi };
const char* to_string(Backend backend);
std::optional<Backend> parse_backend(const std::string& text);  // "serial", "threads", "mpi"

// The most threads an ensemble starts per rank. Far more than any node has cores; above it the
// OpenMP runtime fails to create the team (100000 crashed the process) and the request is a typo.
inline constexpr int kMaxThreads = 1024;

struct EnsembleOptions {
  Backend backend = Backend::kThreads;  // kSerial: one thread per rank
  int threads = 0;  // kThreads and kMpi (threads per rank); 0: all cores (omp_get_max_threads)
  // Called (serialised, possibly from a worker thread) after each finished member. With several
  // ranks each rank reports its own members (done counts this rank's, total all members). An
  // exception thrown by it on any rank is rethrown on every rank after the gather.
  std::function<void(int done, int total)> progress;
  // The ranks to spread members over (not owned; must outlive the Ensemble). Null: this process
  // only, unless backend is kMpi (then the world communicator). With several ranks evaluate() and
  // map_rows() are collective: call them from one thread per rank (not from inside a parallel
  // loop over cases; give such inner ensembles no communicator).
  parallel::Communicator* communicator = nullptr;
  // Hand-out of members to workers: dynamic (default; balances members of unequal cost) or the
  // fixed contiguous/static split (for comparison). Results are the same either way.
  parallel::Schedule schedule = parallel::Schedule::kDynamic;
  // Checkpoint (estimation/checkpoint.h; not owned, outlives the Ensemble): members found in it are
  // not run again, members run are recorded after each batch. Null: no checkpoint.
  MemberCheckpoint* checkpoint = nullptr;
  // The checkpoint scope of this ensemble (a case id in a specificity study; see checkpoint.h).
  std::string checkpoint_scope;
  // Members per recorded batch with a checkpoint; 0: max(32, 8 x the workers of all ranks).
  int checkpoint_batch = 0;
  // Empty when valid; kMpi without MPI compiled in is an error.
  std::string validate() const;
};

struct EnsembleResult {
  Eigen::MatrixXd Z;                  // members x outputs; rows of failed members are NaN
  std::vector<model::Status> status;  // one per member
  // evaluate(thetas, from, true): members x warm_start_size(), each member's own warm start (NaN
  // rows for failed members, zero rows where a member has none); else empty.
  Eigen::MatrixXd warm;
  int failures() const;
  std::vector<int> failed_members() const;
};

class Ensemble {
 public:
  Ensemble(const ForwardModel& prototype, EnsembleOptions options);

  int workers() const;
  // thetas: members x inputs (one member per row).
  EnsembleResult evaluate(const Eigen::MatrixXd& thetas);
  // The same, every member starting from the warm start `from` (empty: cold), and with `produce`
  // each member's own warm start in EnsembleResult::warm. A member depends only on its theta and
  // `from`, so the numbers stay independent of threads, ranks and hand-out; the warm starts travel
  // in the members' rows, so they are gathered over ranks and kept in the checkpoint like z.
  EnsembleResult evaluate(const Eigen::MatrixXd& thetas, const Eigen::VectorXd& from, bool produce);

  // Generic form for estimators with their own member task (the ROUKF advances model states):
  // task(member, worker) runs once per member, worker in [0, workers()), each worker on one thread
  // at a time; a member's result must depend only on the member (not on what its worker ran
  // before), so results written per member are identical for any thread count and hand-out.
  // If tasks throw, the exception of the lowest member index is rethrown after all members ran.
  // With several ranks every rank runs all members (results stay in the caller's memory, so they
  // cannot be distributed; not collective); use map_rows() to spread members over ranks.
  void for_each(int members, const std::function<void(int member, int worker)>& task);

  // Distributed form (added for the ROUKF and others): task(member, worker, row) fills row
  // (width entries, initialised to NaN) and returns a Status. Returns members x width rows and
  // statuses; rows of failed members are NaN. Exceptions and non-finite rows become Statuses as
  // in evaluate(). With several ranks the members are spread over ranks and gathered on every
  // rank (collective, as evaluate()).
  EnsembleResult map_rows(
      int members, int width,
      const std::function<model::Status(int member, int worker, Eigen::Ref<Eigen::VectorXd> row)>&
          task);

  ForwardModel& worker_model(int worker);
  // Members taken from the checkpoint instead of being run, over all calls so far.
  int reused_members() const { return reused_; }
  // The rank context the members are spread over: 0 and 1 when local.
  int rank() const;
  int ranks() const;

 private:
  EnsembleOptions options_;
  std::unique_ptr<parallel::WorkerPool<ForwardModel>> pool_;
  parallel::Communicator* comm_ = nullptr;  // the ranks of the pool (null: this process)
  int instance_ = 0;                        // checkpoint instance number
  long calls_ = 0;                          // evaluate()/map_rows() calls so far
  int reused_ = 0;
  int progress_done_ = 0;                   // members done before the current pool call
  int progress_total_ = 0;                  // members of the current call
  std::atomic<int> cancelled_{0};           // members of the current batch not run (a signal)
};

}  // namespace sigmaheart::estimation
