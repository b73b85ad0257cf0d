#include "estimation/ensemble.h"
#include "tests/support/bitwise_equal.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;

// A cheap nonlinear map with deliberate failures: theta0 < 0 is a failed run, theta0 > 100
// throws, theta1 > 50 returns NaN.
FunctionModel toy_model() {
  return FunctionModel({"a", "b"}, {{"z0", "1", ""}, {"z1", "1", ""}, {"z2", "1", ""}},
                       [](const Eigen::VectorXd& theta, Eigen::Ref<Eigen::VectorXd> z) {
                         if (theta(0) < 0) return model::Status::Error(model::StatusCode::kDiverged, "negative a");
                         if (theta(0) > 100) throw std::runtime_error("a too large");
                         z(0) = std::sin(theta(0)) * std::exp(0.1 * theta(1));
                         double acc = 0;
                         for (int k = 1; k <= 200; ++k) acc += std::cos(k * theta(0) + theta(1)) / k;
                         z(1) = acc;
                         z(2) = theta(1) > 50 ? std::numeric_limits<double>::quiet_NaN() : theta(0) * theta(1);
                         return model::Status::Ok();
                       });
}

Eigen::MatrixXd design(int members) {
  Eigen::MatrixXd t(members, 2);
  for (int i = 0; i < members; ++i) {
    t(i, 0) = 0.3 + 0.17 * i;
    t(i, 1) = std::cos(0.5 * i);
  }
  t(3, 0) = -1.0;   // fails with a Status
  t(7, 0) = 200.0;  // throws
  t(9, 1) = 60.0;   // NaN output
  return t;
}

EnsembleOptions options(Backend backend, int threads = 0) {
  EnsembleOptions o;
  o.backend = backend;
  o.threads = threads;
  return o;
}

using sigmaheart::testing::bitwise_equal;

TEST(Ensemble, OneAndTwoThreadsGiveBitwiseIdenticalResultsIncludingFailures) {
  const FunctionModel proto = toy_model();
  const Eigen::MatrixXd thetas = design(23);
  Ensemble serial(proto, options(Backend::kSerial));
  Ensemble one(proto, options(Backend::kThreads, 1));
  Ensemble two(proto, options(Backend::kThreads, 2));
  EXPECT_EQ(two.workers(), 2);
  const EnsembleResult rs = serial.evaluate(thetas);
  const EnsembleResult r1 = one.evaluate(thetas);
  const EnsembleResult r2 = two.evaluate(thetas);
  EXPECT_TRUE(bitwise_equal(rs.Z, r1.Z));
  EXPECT_TRUE(bitwise_equal(r1.Z, r2.Z));
  ASSERT_EQ(r2.status.size(), 23u);
  for (size_t i = 0; i < 23; ++i) {
    EXPECT_EQ(r1.status[i].code, r2.status[i].code);
    EXPECT_EQ(r1.status[i].message, r2.status[i].message);
  }
  EXPECT_EQ(r2.failures(), 3);
  EXPECT_EQ(r2.failed_members(), (std::vector<int>{3, 7, 9}));
  EXPECT_EQ(r2.status[3].code, model::StatusCode::kDiverged);
  EXPECT_EQ(r2.status[7].code, model::StatusCode::kInvalidArgument);
  EXPECT_NE(r2.status[7].message.find("a too large"), std::string::npos);
  EXPECT_EQ(r2.status[9].code, model::StatusCode::kNonFinite);
  EXPECT_TRUE(r2.Z.row(7).array().isNaN().all());
  // A good member holds the value of a direct evaluation.
  FunctionModel direct = toy_model();
  Eigen::VectorXd z(3);
  ASSERT_TRUE(direct.evaluate(thetas.row(5).transpose(), z).ok());
  EXPECT_NEAR(r2.Z(5, 0), z(0), 0.0);
  EXPECT_NEAR(r2.Z(5, 1), z(1), 0.0);
}

// A model with warm starts (docs/estimation.md s.3.8): z0 = a + the sum of the warm start it
// started from (what a solve from a different start would move), its own warm start (a, b).
class WarmModel final : public ForwardModel {
 public:
  int input_size() const override { return 2; }
  std::vector<std::string> input_names() const override { return {"a", "b"}; }
  std::vector<model::Channel> outputs() const override { return {{"z0", "1", ""}}; }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& theta,
                         Eigen::Ref<Eigen::VectorXd> z) override {
    return evaluate_warm(theta, z, Eigen::VectorXd(), nullptr);
  }
  int warm_start_size() const override { return 2; }
  model::Status evaluate_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                              Eigen::Ref<Eigen::VectorXd> z, const Eigen::VectorXd& from,
                              Eigen::VectorXd* produce) override {
    if (produce) *produce = Eigen::VectorXd::Zero(2);
    if (theta(0) < 0) return model::Status::Error(model::StatusCode::kDiverged, "negative a");
    z(0) = theta(0) + from.sum();
    if (produce) *produce = theta;
    return model::Status::Ok();
  }
  std::unique_ptr<ForwardModel> clone() const override { return std::make_unique<WarmModel>(); }
};

TEST(Ensemble, EveryMemberStartsFromTheGivenWarmStartAndHandsOnItsOwn) {
  const WarmModel proto;
  Eigen::MatrixXd thetas(5, 2);
  thetas << 1, 2, 3, 4, -1, 0, 5, 6, 7, 8;
  const Eigen::VectorXd from = Eigen::Vector2d(0.25, 0.5);
  Ensemble one(proto, options(Backend::kThreads, 1));
  Ensemble two(proto, options(Backend::kThreads, 2));
  const EnsembleResult r1 = one.evaluate(thetas, from, true);
  const EnsembleResult r2 = two.evaluate(thetas, from, true);
  ASSERT_EQ(r2.Z.cols(), 1);
  ASSERT_EQ(r2.warm.rows(), 5);
  ASSERT_EQ(r2.warm.cols(), 2);
  EXPECT_TRUE(bitwise_equal(r1.Z, r2.Z));
  EXPECT_TRUE(bitwise_equal(r1.warm, r2.warm));
  for (int i : {0, 1, 3, 4}) {
    EXPECT_EQ(r2.Z(i, 0), thetas(i, 0) + 0.75) << i;
    EXPECT_EQ(Eigen::VectorXd(r2.warm.row(i).transpose()), Eigen::VectorXd(thetas.row(i).transpose())) << i;
  }
  EXPECT_EQ(r2.failed_members(), (std::vector<int>{2}));
  EXPECT_TRUE(r2.warm.row(2).array().isNaN().all());  // a failed member's row, warm part too
  // Without a warm start nothing is added: the plain evaluate() is a cold start.
  const EnsembleResult cold = two.evaluate(thetas);
  EXPECT_EQ(cold.warm.size(), 0);
  EXPECT_EQ(cold.Z(0, 0), 1.0);
}

TEST(Ensemble, ProgressCountsEveryMemberOnce) {
  const FunctionModel proto = toy_model();
  int calls = 0;
  int last = 0;
  EnsembleOptions opt = options(Backend::kThreads, 2);
  opt.progress = [&](int done, int total) {
    ++calls;
    last = std::max(last, done);
    EXPECT_EQ(total, 11);
  };
  Ensemble e(proto, opt);
  e.evaluate(design(11));
  EXPECT_EQ(calls, 11);
  EXPECT_EQ(last, 11);
}

TEST(Ensemble, ForEachRunsEveryMemberOnceAndRethrowsTheFirstError) {
  const FunctionModel proto = toy_model();
  Ensemble e(proto, options(Backend::kThreads, 2));
  std::vector<double> out(17, 0.0);
  e.for_each(17, [&](int m, int w) {
    Eigen::VectorXd z(3);
    Eigen::Vector2d t(0.1 * m + 0.05, 0.2);
    ASSERT_TRUE(e.worker_model(w).evaluate(t, z).ok());
    out[static_cast<size_t>(m)] += z(0);
  });
  for (int m = 0; m < 17; ++m) {
    EXPECT_NEAR(out[static_cast<size_t>(m)], std::sin(0.1 * m + 0.05) * std::exp(0.02), 1e-15);
  }
  try {
    e.for_each(9, [](int m, int) {
      if (m == 4 || m == 6) throw std::runtime_error("member " + std::to_string(m));
    });
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& error) {
    EXPECT_STREQ(error.what(), "member 4");
  }
}

TEST(Ensemble, MapRowsFillsRowsAndTurnsFailuresIntoStatuses) {
  const FunctionModel proto = toy_model();
  Ensemble e(proto, options(Backend::kThreads, 2));
  const EnsembleResult r = e.map_rows(6, 2, [](int m, int, Eigen::Ref<Eigen::VectorXd> row) {
    if (m == 2) return model::Status::Error(model::StatusCode::kTimeout, "slow");
    row << m, 2.0 * m;
    return model::Status::Ok();
  });
  EXPECT_NEAR(r.Z(5, 1), 10.0, 0.0);
  EXPECT_TRUE(std::isnan(r.Z(2, 0)));
  EXPECT_EQ(r.failed_members(), (std::vector<int>{2}));
}

TEST(Ensemble, MpiBackendWithoutAnActiveSessionRunsAsOneRank) {
  const FunctionModel proto = toy_model();
  EnsembleOptions opt = options(Backend::kMpi, 2);
  if (!mpi_compiled()) {
    EXPECT_FALSE(opt.validate().empty());
    return;
  }
  EXPECT_EQ(parallel::world_communicator().size(), 1);
  Ensemble mpi(proto, opt);
  Ensemble serial(proto, options(Backend::kSerial));
  const Eigen::MatrixXd thetas = design(12);
  EXPECT_TRUE(bitwise_equal(mpi.evaluate(thetas).Z, serial.evaluate(thetas).Z));
}

TEST(Ensemble, OptionsValidationNamesTheProblem) {
  EXPECT_NE(options(Backend::kThreads, -2).validate().find("threads"),
            std::string::npos);
  EXPECT_EQ(parse_backend("mpi"), Backend::kMpi);
  EXPECT_FALSE(parse_backend("gpu").has_value());
}

// Members whose cost differs (member 0 sleeps longest): the dynamic hand-out gives the same bits
// as the fixed split and as a serial run, whatever member finishes first.
TEST(Ensemble, DynamicAndFixedHandOutGiveTheSerialResultsBitForBit) {
  const FunctionModel proto = toy_model();
  const Eigen::MatrixXd thetas = design(17);
  EnsembleOptions dyn = options(Backend::kThreads, 3);
  EnsembleOptions fixed = dyn;
  fixed.schedule = parallel::Schedule::kFixed;
  Ensemble a(proto, dyn), b(proto, fixed), serial(proto, options(Backend::kSerial));
  auto slow_task = [](Ensemble& e) {
    return [&e](int m, int w, Eigen::Ref<Eigen::VectorXd> row) {
      std::this_thread::sleep_for(std::chrono::milliseconds(m == 0 ? 20 : 1));
      Eigen::VectorXd theta(2);
      theta << 0.3 + 0.1 * m, std::cos(m);
      return e.worker_model(w).evaluate(theta, row);
    };
  };
  const EnsembleResult ra = a.map_rows(17, 3, slow_task(a));
  const EnsembleResult rb = b.map_rows(17, 3, slow_task(b));
  const EnsembleResult rs = serial.map_rows(17, 3, slow_task(serial));
  EXPECT_TRUE(bitwise_equal(ra.Z, rs.Z));
  EXPECT_TRUE(bitwise_equal(rb.Z, rs.Z));
  EXPECT_TRUE(bitwise_equal(a.evaluate(thetas).Z, serial.evaluate(thetas).Z));
  EXPECT_EQ(a.evaluate(thetas).failed_members(), (std::vector<int>{3, 7, 9}));
}

TEST(Ensemble, ACommunicatorOfOneRankKeepsMembersLocal) {
  const FunctionModel proto = toy_model();
  parallel::SerialCommunicator one;
  EnsembleOptions opt = options(Backend::kThreads, 2);
  opt.communicator = &one;
  int calls = 0;
  opt.progress = [&](int done, int total) {
    ++calls;
    EXPECT_LE(done, total);
    EXPECT_EQ(total, 12);
  };
  Ensemble e(proto, opt);
  EXPECT_EQ(e.ranks(), 1);
  EXPECT_EQ(e.rank(), 0);
  Ensemble serial(proto, options(Backend::kSerial));
  const Eigen::MatrixXd thetas = design(12);
  EXPECT_TRUE(bitwise_equal(e.evaluate(thetas).Z, serial.evaluate(thetas).Z));
  EXPECT_EQ(calls, 12);
}

TEST(Ensemble, SchedulesParseFromTheirNames) {
  EXPECT_EQ(parallel::parse_schedule("dynamic"), parallel::Schedule::kDynamic);
  EXPECT_EQ(parallel::parse_schedule("fixed"), parallel::Schedule::kFixed);
  EXPECT_FALSE(parallel::parse_schedule("guided").has_value());
  EXPECT_STREQ(parallel::to_string(parallel::Schedule::kFixed), "fixed");
}

}  // namespace
}  // namespace sigmaheart::estimation
