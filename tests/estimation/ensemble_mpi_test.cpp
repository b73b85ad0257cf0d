// Run under mpiexec (tests/estimation/CMakeLists.txt registers it with 2 ranks and 3): the MPI
// backend must give every rank the numbers of a serial run, bit for bit, failures included.
#include "estimation/ensemble.h"
#include "estimation/mpi.h"
#include "estimation/ut_calibration.h"
#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>
#include <memory>
#include <stdexcept>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;

FunctionModel toy_model() {
  return FunctionModel({"t0", "t1"}, {{"o0", "1", ""}, {"o1", "1", ""}, {"o2", "1", ""}},
                       [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
                         if (t(0) < -5) return model::Status::Error(model::StatusCode::kDiverged, "rank-independent failure");
                         if (t(0) > 50) throw std::runtime_error("thrown on some rank");
                         z << std::exp(0.3 * t(0)), std::sin(t(0) * t(1)), t(0) - t(1) * t(1);
                         return model::Status::Ok();
                       });
}

EnsembleOptions make(Backend b, int threads) {
  EnsembleOptions o;
  o.backend = b;
  o.threads = threads;
  return o;
}

TEST(EnsembleMpi, EveryRankHoldsTheSerialResultsBitForBit) {
  Eigen::MatrixXd thetas(13, 2);
  for (int i = 0; i < 13; ++i) thetas.row(i) << 0.1 * i - 0.3, std::cos(i);
  thetas(2, 0) = -9;
  thetas(11, 0) = 99;
  const FunctionModel toy = toy_model();
  Ensemble mpi(toy, make(Backend::kMpi, 2));
  Ensemble serial(toy, make(Backend::kSerial, 0));
  const EnsembleResult a = mpi.evaluate(thetas);
  const EnsembleResult b = serial.evaluate(thetas);
  ASSERT_EQ(a.Z.rows(), 13);
  EXPECT_EQ(0, std::memcmp(a.Z.data(), b.Z.data(), sizeof(double) * 39));
  for (size_t i = 0; i < 13; ++i) {
    EXPECT_EQ(a.status[i].code, b.status[i].code);
    EXPECT_EQ(a.status[i].message, b.status[i].message);
  }
  EXPECT_EQ(a.failed_members(), (std::vector<int>{2, 11}));
  EXPECT_NE(a.status[11].message.find("thrown on some rank"), std::string::npos);
}

TEST(EnsembleMpi, UtCalibrationGivesTheSameEstimateOnEveryRankAsSerially) {
  const FunctionModel toy = toy_model();
  observers::ObservationSet obs;
  obs.names = {"o0", "o1", "o2"};
  obs.units = {"1", "1", "1"};
  obs.y = Eigen::Vector3d(1.2, 0.3, 0.1);
  obs.R = Eigen::Matrix3d::Identity() * 0.01;
  Prior pars;
  pars.parameters = {PriorParameter::gaussian("t0", "1", 0.5, 0.2, SpreadKind::kRelative, {}),
                     PriorParameter::gaussian("t1", "1", 0.4, 0.2, SpreadKind::kRelative, {})};
  UtOptions opt;
  opt.mode = UtMode::kIterateKeepSpread;
  opt.max_iterations = 5;
  opt.ensemble = make(Backend::kMpi, 1);
  const UtSummary a = UtCalibration(toy, pars, obs, opt).run();
  opt.ensemble = make(Backend::kSerial, 0);
  const UtSummary b = UtCalibration(toy, pars, obs, opt).run();
  EXPECT_NEAR((a.eta_mean - b.eta_mean).norm(), 0.0, 0.0);
  EXPECT_NEAR((a.eta_covariance - b.eta_covariance).norm(), 0.0, 0.0);
  EXPECT_EQ(a.simulations, b.simulations);
}

parallel::Communicator& world() { return parallel::world_communicator(); }

TEST(EnsembleMpi, MembersOfUnequalCostGiveTheSerialBitsWithEitherHandOut) {
  Eigen::MatrixXd thetas(11, 2);
  for (int i = 0; i < 11; ++i) thetas.row(i) << 0.2 * i, std::sin(i);
  const FunctionModel toy = toy_model();
  auto task = [&thetas](Ensemble& e) {
    return [&e, &thetas](int m, int w, Eigen::Ref<Eigen::VectorXd> row) {
      // Member 0 is ten times dearer than the others: ranks finish at different times.
      std::this_thread::sleep_for(std::chrono::milliseconds(m == 0 ? 20 : 2));
      const Eigen::VectorXd theta = thetas.row(m).transpose();
      return e.worker_model(w).evaluate(theta, row);
    };
  };
  EnsembleOptions dyn = make(Backend::kThreads, 2);
  dyn.communicator = &world();
  EnsembleOptions fixed = dyn;
  fixed.schedule = parallel::Schedule::kFixed;
  Ensemble a(toy, dyn), b(toy, fixed), serial(toy, make(Backend::kSerial, 0));
  EXPECT_EQ(a.ranks(), world().size());
  const EnsembleResult ra = a.map_rows(11, 3, task(a));
  const EnsembleResult rb = b.map_rows(11, 3, task(b));
  const EnsembleResult rs = serial.map_rows(11, 3, task(serial));
  EXPECT_EQ(0, std::memcmp(ra.Z.data(), rs.Z.data(), sizeof(double) * 33));
  EXPECT_EQ(0, std::memcmp(rb.Z.data(), rs.Z.data(), sizeof(double) * 33));
}

TEST(EnsembleMpi, MoreRanksThanMembersAndNoMembersAreFine) {
  const FunctionModel toy = toy_model();
  EnsembleOptions o = make(Backend::kSerial, 0);
  o.communicator = &world();
  Ensemble e(toy, o);
  Eigen::MatrixXd one(1, 2);
  one << 0.5, 0.25;
  const EnsembleResult r = e.evaluate(one);
  ASSERT_EQ(r.Z.rows(), 1);
  EXPECT_EQ(r.Z(0, 0), std::exp(0.3 * 0.5));
  EXPECT_EQ(e.evaluate(Eigen::MatrixXd(0, 2)).Z.rows(), 0);
}

TEST(EnsembleMpi, AProgressFailureOnOneRankIsRethrownOnEveryRank) {
  const FunctionModel toy = toy_model();
  EnsembleOptions o = make(Backend::kSerial, 0);
  o.communicator = &world();
  o.schedule = parallel::Schedule::kFixed;  // every rank gets members, so the throwing one runs
  const int rank = world().rank();
  o.progress = [rank](int, int) {
    if (rank == world().size() - 1) throw std::runtime_error("progress broke");
  };
  Ensemble e(toy, o);
  Eigen::MatrixXd thetas(7, 2);
  for (int i = 0; i < 7; ++i) thetas.row(i) << 0.1 * i, 0.2;
  EXPECT_THROW(e.evaluate(thetas), std::runtime_error);
  // The ranks are still in step: a later collective works.
  EXPECT_EQ(world().all_reduce_max(rank), world().size() - 1);
}

TEST(EnsembleMpi, CommunicatorCollectivesAgree) {
  parallel::Communicator& c = world();
  EXPECT_EQ(c.broadcast(c.rank() == 0 ? 42 : -1, 0), 42);
  EXPECT_EQ(c.broadcast(c.rank() == 0 ? std::string("from root") : std::string(), 0), "from root");
  std::vector<double> v(3, c.rank() == 0 ? 1.5 : 0.0);
  c.broadcast(std::span<double>(v), 0);
  EXPECT_EQ(v, std::vector<double>(3, 1.5));
  const std::string mine(static_cast<size_t>(c.rank()), 'x');
  const auto all = c.all_gather(std::as_bytes(std::span<const char>(mine.data(), mine.size())));
  ASSERT_EQ(static_cast<int>(all.size()), c.size());
  for (int r = 0; r < c.size(); ++r) EXPECT_EQ(static_cast<int>(all[static_cast<size_t>(r)].size()), r);
  EXPECT_EQ(c.all_reduce_max(c.rank() == 1 ? 7 : 0), 7);
  c.barrier();
}

}  // namespace
}  // namespace sigmaheart::estimation

int main(int argc, char** argv) {
  sigmaheart::estimation::MpiSession session(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  // Only rank 0 prints the report; every rank runs every test (the calls are collective).
  if (session.world().rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int failed = RUN_ALL_TESTS();
  return failed;
}
