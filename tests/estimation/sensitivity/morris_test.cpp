#include "estimation/sensitivity/morris.h"

#include "estimation/sensitivity/test_functions.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace sh = sigmaheart::estimation::sensitivity;
using sigmaheart::estimation::Backend;
using sigmaheart::estimation::ForwardModel;
namespace model = sigmaheart::model;

namespace {

// y_k = sum_i c_ik x_i (two outputs), optionally failing when x1 > fail_above.
class Linear final : public ForwardModel {
 public:
  explicit Linear(Eigen::MatrixXd c, double fail_above = 2.0) : c_(std::move(c)), fail_(fail_above) {}
  int input_size() const override { return static_cast<int>(c_.rows()); }
  std::vector<std::string> input_names() const override {
    std::vector<std::string> n;
    for (int i = 0; i < input_size(); ++i) n.push_back(std::string(1, 'x') += std::to_string(i + 1));
    return n;
  }
  std::vector<model::Channel> outputs() const override {
    std::vector<model::Channel> o;
    for (int k = 0; k < c_.cols(); ++k) {
      o.push_back({std::string(1, 'y') += std::to_string(k + 1), std::string("1"), std::string()});
    }
    return o;
  }
  model::Status evaluate(const Eigen::Ref<const Eigen::VectorXd>& x,
                         Eigen::Ref<Eigen::VectorXd> z) override {
    if (x(0) > fail_) return model::Status::Error(model::StatusCode::kDiverged, "x1 too large");
    z = c_.transpose() * x;
    return model::Status::Ok();
  }
  std::unique_ptr<ForwardModel> clone() const override { return std::make_unique<Linear>(*this); }

 private:
  Eigen::MatrixXd c_;
  double fail_;
};

sh::MorrisOptions options(int r) {
  sh::MorrisOptions o;
  o.trajectories = r;
  o.seed = 99;
  o.bootstrap_samples = 300;
  o.ensemble.threads = 2;
  return o;
}

Eigen::MatrixXd coefficients() {
  Eigen::MatrixXd c(4, 2);
  c << 3.0, 0.5,  //
      -2.0, 0.0,  //
      0.5, -4.0,  //
      0.0, 1.0;
  return c;
}

}  // namespace

TEST(Morris, LinearModelGivesMuStarEqualToTheAbsoluteCoefficientsAndZeroSigma) {
  const Eigen::MatrixXd c = coefficients();
  const auto r = sh::run_morris(Linear(c), sh::g_function_prior(4), options(12));
  ASSERT_TRUE(r.ok()) << r.report();
  EXPECT_EQ(r.thetas.rows(), 12 * 5);
  EXPECT_LT((r.mu_star - c.cwiseAbs()).cwiseAbs().maxCoeff(), 1e-12) << r.report();
  EXPECT_LT((r.mu - c).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(r.sigma.cwiseAbs().maxCoeff(), 1e-12);
  // Bootstrap intervals of a constant collapse on the value.
  EXPECT_LT((r.mu_star_high - r.mu_star_low).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(r.ranking(0).front(), 0);  // |3| is the largest for y1
  EXPECT_EQ(r.ranking(1).front(), 2);  // |-4| for y2
}

TEST(Morris, EffectsAreScaledToTheParameterRange) {
  // theta_1 in [10, 30]: crossing the whole range changes y1 by 3 * 20 = 60.
  auto prior = sh::g_function_prior(4);
  prior.parameters[0].lower = 10.0;
  prior.parameters[0].upper = 30.0;
  prior.parameters[0].theta_nominal = 20.0;
  const auto r = sh::run_morris(Linear(coefficients(), 100.0), prior, options(6));
  EXPECT_NEAR(r.mu_star(0, 0), 60.0, 1e-9);
}

TEST(Morris, TrajectoriesFollowTheGridWithOneStepOfDeltaPerParameter) {
  auto o = options(20);
  const Eigen::MatrixXd U = sh::morris_design(5, o);
  ASSERT_EQ(U.rows(), 20 * 6);
  const double delta = o.delta();  // 4 levels: 2/3
  EXPECT_NEAR(delta, 2.0 / 3.0, 1e-15);
  for (int t = 0; t < 20; ++t) {
    std::vector<int> moved;
    for (int s = 0; s < 5; ++s) {
      const Eigen::RowVectorXd d = U.row(t * 6 + s + 1) - U.row(t * 6 + s);
      int changed = 0;
      for (int i = 0; i < 5; ++i) {
        if (d(i) != 0.0) {
          ++changed;
          moved.push_back(i);
          EXPECT_NEAR(std::abs(d(i)), delta, 1e-15);
        }
      }
      EXPECT_EQ(changed, 1);
    }
    std::sort(moved.begin(), moved.end());
    EXPECT_EQ(moved, (std::vector<int>{0, 1, 2, 3, 4})) << "trajectory " << t;
  }
  // All points on the 4-level grid {0, 1/3, 2/3, 1}.
  for (Eigen::Index i = 0; i < U.size(); ++i) {
    const double l = U.data()[i] * 3.0;
    EXPECT_NEAR(l, std::round(l), 1e-12);
    EXPECT_GE(U.data()[i], 0.0);
    EXPECT_LE(U.data()[i], 1.0);
  }
}

TEST(Morris, ATrajectoryWithAFailedRunIsDroppedWholeAndReported) {
  // x1 = 1 (the top level) fails.
  const auto r = sh::run_morris(Linear(coefficients(), 0.9), sh::g_function_prior(4), options(30));
  int expected_dropped = 0;
  for (int t = 0; t < 30; ++t) {
    bool fails = false;
    for (int s = 0; s < 5; ++s) fails = fails || r.thetas(t * 5 + s, 0) > 0.9;
    expected_dropped += fails ? 1 : 0;
  }
  ASSERT_GT(expected_dropped, 0);
  ASSERT_LT(expected_dropped, 30);
  EXPECT_EQ(static_cast<int>(r.dropped_trajectories.size()), expected_dropped);
  EXPECT_EQ(static_cast<int>(r.used_trajectories.size()), 30 - expected_dropped);
  EXPECT_EQ(static_cast<int>(r.effects.size()), 30 - expected_dropped);
  EXPECT_TRUE(r.ok());
  EXPECT_LT((r.mu_star - coefficients().cwiseAbs()).cwiseAbs().maxCoeff(), 1e-12);
  const std::string report = r.report();
  EXPECT_NE(report.find(std::to_string(expected_dropped) + " of 30 trajectories dropped"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("x1 too large"), std::string::npos);
}

TEST(Morris, IshigamiRanksTheInputsAsTheirTotalIndices) {
  // mu* screens like ST (Campolongo 2007): x1 (ST 0.56) above x3 (0.24). The effect of x2
  // (a sin^2 x2) changes sign across its range: mu near 0 while mu* is large.
  const auto r = sh::run_morris(sh::IshigamiModel(), sh::ishigami_prior(), options(50));
  ASSERT_TRUE(r.ok());
  EXPECT_GT(r.mu_star(0, 0), r.mu_star(2, 0));
  EXPECT_LT(std::abs(r.mu(1, 0)), 0.5 * r.mu_star(1, 0));
  EXPECT_LE(r.mu_star_low(0, 0), r.mu_star(0, 0));
  EXPECT_GE(r.mu_star_high(0, 0), r.mu_star(0, 0));
}

TEST(Morris, ResultsDoNotDependOnTheThreadCount) {
  auto serial = options(10);
  serial.ensemble.backend = Backend::kSerial;
  auto threaded = options(10);
  const auto a = sh::run_morris(sh::IshigamiModel(), sh::ishigami_prior(), serial);
  const auto b = sh::run_morris(sh::IshigamiModel(), sh::ishigami_prior(), threaded);
  EXPECT_EQ((a.Z - b.Z).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.mu_star_low - b.mu_star_low).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.sigma_high - b.sigma_high).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Morris, OddLevelCountsAreRejected) {
  auto o = options(4);
  o.levels = 5;
  EXPECT_FALSE(o.validate().empty());
  EXPECT_THROW(sh::run_morris(sh::IshigamiModel(), sh::ishigami_prior(), o), std::invalid_argument);
}
