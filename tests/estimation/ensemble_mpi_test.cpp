// Run under mpiexec (tests/estimation/CMakeLists.txt registers it with 2 ranks and 3): the MPI
// backend must give every rank the numbers of a serial run, bit for bit, failures included.
#include "estimation/ensemble.h"
#include "estimation/mpi.h"
#include "estimation/ut_calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>

namespace sigmaheart::estimation {
namespace {

class Toy final : public ForwardModel {
 public:
  int input_size() const override { return 2; }
  std::vector<std::string> input_names() const override { return {"t0", "t1"}; }
  std::vector<model::Channel> outputs() const override {
    return {{"o0", "1", ""}, {"o1", "1", ""}, {"o2", "1", ""}};
  }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& t,
                         Eigen::Ref<Eigen::VectorXd> z) override {
    if (t(0) < -5) return model::Status::Error(model::StatusCode::kDiverged, "rank-independent failure");
    if (t(0) > 50) throw std::runtime_error("thrown on some rank");
    z << std::exp(0.3 * t(0)), std::sin(t(0) * t(1)), t(0) - t(1) * t(1);
    return model::Status::Ok();
  }
  std::unique_ptr<ForwardModel> clone() const override { return std::make_unique<Toy>(); }
};

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
  const Toy toy;
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
  const Toy toy;
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

}  // namespace
}  // namespace sigmaheart::estimation

int main(int argc, char** argv) {
  sigmaheart::estimation::MpiSession session(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  // Only rank 0 prints the report; every rank runs every test (the calls are collective).
  if (sigmaheart::estimation::mpi_rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int failed = RUN_ALL_TESTS();
  return failed;
}
