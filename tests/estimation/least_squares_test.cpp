#include "estimation/least_squares.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;
using sigmaheart::testing::indexed;
using sigmaheart::testing::observations_for;

LeastSquaresOptions serial() {
  LeastSquaresOptions o;
  o.ensemble.backend = Backend::kSerial;
  return o;
}

// z = A theta + b, identity transforms, correlated prior and correlated noise of mixed scales.
TEST(LeastSquares, EqualsTheExactPosteriorOnALinearGaussianProblem) {
  Eigen::MatrixXd A(5, 3);
  A << 3e-6, 1e-6, -2e-6,  //
      800.0, -1500.0, 400.0,  //
      0.2, 0.7, -0.4,         //
      1.0, 0.0, 2.0,          //
      -50.0, 20.0, 10.0;
  Eigen::VectorXd b(5);
  b << 1e-4, 1.2e4, 0.3, -1.0, 200.0;
  const Eigen::Vector3d m0(0.5, -1.0, 2.0), s0(0.4, 0.9, 0.6);
  Eigen::VectorXd y(5);
  y << 1.1e-4, 1.35e4, 0.1, 3.9, 130.0;
  const Eigen::VectorXd sd = (Eigen::VectorXd(5) << 3e-6, 200.0, 0.05, 0.2, 8.0).finished();
  Eigen::MatrixXd C = Eigen::MatrixXd::Identity(5, 5);
  C(1, 4) = C(4, 1) = -0.4;
  const Eigen::MatrixXd R = sd.asDiagonal() * C * sd.asDiagonal();
  Prior prior;
  for (int j = 0; j < 3; ++j) {
    prior.parameters.push_back(PriorParameter::gaussian(indexed("t", j), "1", m0(j), s0(j), SpreadKind::kEta, {}));
  }
  prior.correlation = Eigen::Matrix3d::Identity();
  prior.correlation(0, 2) = prior.correlation(2, 0) = 0.5;
  const FunctionModel fm(3, 5, [&](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z = A * t + b;
    return model::Status::Ok();
  });

  // Gain form (the Kalman update, another algebra than the solver's normal equations):
  // K = P0 A^T (A P0 A^T + R)^-1, mean = m0 + K (y - b - A m0), P = P0 - K A P0.
  const Eigen::MatrixXd P0 = prior.covariance_eta();
  const Eigen::MatrixXd S = A * P0 * A.transpose() + R;
  const Eigen::MatrixXd K = S.ldlt().solve(A * P0).transpose();
  const Eigen::VectorXd mean = m0 + K * (y - b - A * m0);
  const Eigen::MatrixXd P = P0 - K * A * P0;

  for (FiniteDifference d : {FiniteDifference::kCentral, FiniteDifference::kForward}) {
    LeastSquaresOptions o = serial();
    o.difference = d;
    const LeastSquaresSummary s = solve_map(fm, prior, observations_for(fm, y, R), o);
    ASSERT_EQ(s.termination, LsqTermination::kConverged) << s.message;
    EXPECT_LT((s.eta - mean).cwiseAbs().maxCoeff(), 1e-8) << to_string(d);
    EXPECT_LT((s.eta_covariance - P).cwiseAbs().maxCoeff(), 1e-8 * P.cwiseAbs().maxCoeff()) << to_string(d);
    EXPECT_LT(s.cost, s.prior_cost);
    EXPECT_LT(s.metrics_estimate.rms_normalised_residual, s.metrics_prior.rms_normalised_residual);
    EXPECT_TRUE(s.ok());
    EXPECT_NE(s.brief_report().find("MAP least squares (3 params, 5 obs, 1 start): converged"),
              std::string::npos) << s.brief_report();
  }
}

// z_i = a exp(-k t_i): a = exp(eta_a) (log transform), k = logit on (0, 5). The MAP is found
// independently: Newton on the analytic gradient of F (its fixed point is grad F = 0 whatever
// Hessian approximation drives it).
struct DecayProblem {
  Eigen::VectorXd t = (Eigen::VectorXd(6) << 0.0, 0.3, 0.7, 1.2, 1.8, 2.5).finished();
  Eigen::VectorXd y = (Eigen::VectorXd(6) << 3.1, 2.0, 1.15, 0.6, 0.25, 0.12).finished();
  double s = 0.05;
  Eigen::Vector2d m0{std::log(2.0), 0.0}, s0{0.5, 1.0};  // eta prior mean and std
  double k_lo = 0.0, k_hi = 5.0;

  Prior prior() const {
    Prior p;
    p.parameters.push_back(PriorParameter::gaussian("t0", "1", 2.0, s0(0), SpreadKind::kEta,
                                                    {TransformKind::kLog, 1.0}));
    p.parameters.push_back(PriorParameter::gaussian("t1", "1", 2.5, s0(1), SpreadKind::kEta,
                                                    {TransformKind::kLogit, 1.0, k_lo, k_hi}, k_lo, k_hi));
    return p;
  }
  FunctionModel model() const {
    return FunctionModel(2, 6, [t = t](const Eigen::VectorXd& th, Eigen::Ref<Eigen::VectorXd> z) {
      z = th(0) * (-th(1) * t.array()).exp();
      return model::Status::Ok();
    });
  }
  observers::ObservationSet data(const FunctionModel& fm) const {
    return observations_for(fm, y, s * s * Eigen::MatrixXd::Identity(y.size(), y.size()));
  }
  double k_of(double eta) const { return k_lo + (k_hi - k_lo) / (1 + std::exp(-eta)); }
  double cost(const Eigen::Vector2d& eta) const {
    const Eigen::ArrayXd r = (std::exp(eta(0)) * (-k_of(eta(1)) * t.array()).exp() - y.array()) / s;
    return 0.5 * r.square().sum() + 0.5 * ((eta - eta0()).array() / s0.array()).square().sum();
  }
  Eigen::Vector2d eta0() const { return {m0(0), 0.0}; }  // k = 2.5 is the logit's centre
  Eigen::Vector2d gradient(const Eigen::Vector2d& eta) const {
    const double a = std::exp(eta(0));
    const double k = k_of(eta(1));
    const Eigen::ArrayXd e = (-k * t.array()).exp();
    const Eigen::ArrayXd r = (a * e - y.array()) / (s * s);
    const double dk = (k - k_lo) * (k_hi - k) / (k_hi - k_lo);
    Eigen::Vector2d g = ((eta - eta0()).array() / s0.array().square()).matrix();
    g(0) += (r * e).sum() * a;
    g(1) += (r * (-t.array() * a * e)).sum() * dk;
    return g;
  }
  // A grid over eta0 +- 3 std for the basin, then Newton on the analytic gradient.
  Eigen::Vector2d map() const {
    Eigen::Vector2d eta = eta0();
    for (int i = -60; i <= 60; ++i) {
      for (int j = -60; j <= 60; ++j) {
        const Eigen::Vector2d c = eta0() + Eigen::Vector2d(0.05 * i * s0(0), 0.05 * j * s0(1));
        if (cost(c) < cost(eta)) eta = c;
      }
    }
    for (int it = 0; it < 50 && gradient(eta).cwiseAbs().maxCoeff() > 1e-11; ++it) {
      Eigen::Matrix2d H;
      for (int j = 0; j < 2; ++j) {
        const Eigen::Vector2d h = 1e-6 * Eigen::Vector2d::Unit(j);
        H.col(j) = (gradient(eta + h) - gradient(eta - h)) / 2e-6;
      }
      eta -= H.ldlt().solve(gradient(eta));
    }
    return eta;
  }
};

TEST(LeastSquares, FindsTheMapOfANonlinearProblemThroughLogAndLogitTransforms) {
  const DecayProblem dp;
  const Eigen::Vector2d expected = dp.map();
  ASSERT_LT(dp.gradient(expected).cwiseAbs().maxCoeff(), 1e-9);
  const FunctionModel fm = dp.model();
  const LeastSquaresSummary s =
      solve_map(fm, dp.prior(), dp.data(fm), serial());
  ASSERT_EQ(s.termination, LsqTermination::kConverged) << s.message;
  EXPECT_LT((s.eta - expected).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_NEAR(s.theta(0), std::exp(expected(0)), 1e-6 * std::exp(expected(0)));
  // Delta method: std of a = exp(eta) is a * std_eta.
  EXPECT_NEAR(s.theta_std(0), s.theta(0) * s.eta_std(0), 1e-12);
  ASSERT_TRUE(s.fit_estimate && s.fit_prior);
  EXPECT_LT(s.fit_estimate->misfit(), s.fit_prior->misfit());
}

TEST(LeastSquares, ASobolScreenStartsFromTheBestPointsAndFindsTheSameMap) {
  const DecayProblem dp;
  const FunctionModel fm = dp.model();
  LeastSquaresOptions o = serial();
  o.screen_points = 16;
  o.starts = 2;
  o.seed = 7;
  const LeastSquaresSummary s =
      solve_map(fm, dp.prior(), dp.data(fm), o);
  ASSERT_EQ(s.termination, LsqTermination::kConverged) << s.message;
  ASSERT_EQ(s.starts.size(), 3u);
  for (const auto& st : s.starts) EXPECT_NE(st.ceres_termination.find("CONVERGENCE"), std::string::npos);
  EXPECT_LT((s.eta - dp.map()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GE(s.simulations, 16);
}

// The data ask for k = 8 (outside (0, 5)): the logit keeps the estimate inside.
TEST(LeastSquares, StaysInsideTheBoundsWhenTheDataPointOutside) {
  DecayProblem dp;
  for (Eigen::Index i = 0; i < dp.t.size(); ++i) dp.y(i) = 2.0 * std::exp(-8.0 * dp.t(i));
  const FunctionModel fm = dp.model();
  const LeastSquaresSummary s =
      solve_map(fm, dp.prior(), dp.data(fm), serial());
  EXPECT_TRUE(s.theta.allFinite());
  EXPECT_GT(s.theta(1), 4.0);
  EXPECT_LT(s.theta(1), dp.k_hi);
  EXPECT_LT(s.cost, s.prior_cost);
  EXPECT_TRUE(s.termination == LsqTermination::kConverged || s.termination == LsqTermination::kAtBound)
      << s.message;
}

// theta = exp(eta) > 0 with lower bound 0, data asking for theta = -1 and a weak prior: the
// estimate goes to the bound and says so.
TEST(LeastSquares, ReportsAnEstimateStuckAtABound) {
  Prior prior;
  prior.parameters.push_back(PriorParameter::gaussian("t0", "1", 1.0, 30.0, SpreadKind::kEta,
                                                      {TransformKind::kLog, 1.0}, 0.0));
  const FunctionModel fm(1, 1, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z(0) = t(0);
    return model::Status::Ok();
  });
  LeastSquaresOptions o = serial();
  o.max_iterations = 200;
  const LeastSquaresSummary s =
      solve_map(fm, prior, observations_for(fm, Eigen::VectorXd::Constant(1, -1.0), Eigen::MatrixXd::Constant(1, 1, 1e-4)), o);
  EXPECT_EQ(s.termination, LsqTermination::kAtBound) << s.message;
  EXPECT_EQ(s.at_bound, std::vector<std::string>{"t0"});
  EXPECT_GT(s.theta(0), 0.0);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message.find("bound of t0"), std::string::npos) << s.message;
}

// The model fails for theta_1 > 1.5: Jacobians and trial steps there are unsuccessful steps.
TEST(LeastSquares, AModelFailingInPartOfTheSpaceDoesNotCrash) {
  Prior prior;
  prior.parameters.push_back(PriorParameter::gaussian("t0", "1", 0.0, 1.0, SpreadKind::kEta, {}));
  prior.parameters.push_back(PriorParameter::gaussian("t1", "1", 0.0, 1.0, SpreadKind::kEta, {}));
  const FunctionModel fm(2, 3, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(1) > 1.5) return model::Status::Error(model::StatusCode::kDiverged, "Newton diverged");
    z << t(0) + t(1), t(0) - t(1), t(0) * t(1);
    return model::Status::Ok();
  });
  // The data ask for t = (1, 3): beyond the failing edge.
  const Eigen::Vector3d y(4.0, -2.0, 3.0);
  const LeastSquaresSummary s = solve_map(fm, prior, observations_for(fm, y, 0.01 * Eigen::Matrix3d::Identity()), serial());
  EXPECT_GT(s.failures, 0);
  EXPECT_FALSE(s.failure_messages.empty());
  EXPECT_NE(s.failure_messages[0].find("Newton diverged"), std::string::npos);
  EXPECT_TRUE(s.theta.allFinite());
  EXPECT_LE(s.theta(1), 1.5);
  EXPECT_LT(s.cost, s.prior_cost);

  // Failing at the prior mean: no convergence, in words, never an exception.
  const FunctionModel always(2, 3, [](const Eigen::VectorXd&, Eigen::Ref<Eigen::VectorXd>) {
    return model::Status::Error(model::StatusCode::kNonFinite, "NaN in the state");
  });
  const LeastSquaresSummary f = solve_map(always, prior, observations_for(fm, y, 0.01 * Eigen::Matrix3d::Identity()), serial());
  EXPECT_EQ(f.termination, LsqTermination::kNoConvergence);
  EXPECT_NE(f.message.find("NaN in the state"), std::string::npos) << f.message;
  EXPECT_FALSE(f.ok());
}

TEST(LeastSquares, GivesTheSameNumbersWithOneAndTwoThreads) {
  const DecayProblem dp;
  const FunctionModel fm = dp.model();
  LeastSquaresOptions one;
  one.ensemble.backend = Backend::kThreads;
  one.ensemble.threads = 1;
  one.screen_points = 8;
  one.starts = 1;
  LeastSquaresOptions two = one;
  two.ensemble.threads = 2;
  const auto obs = dp.data(fm);
  const LeastSquaresSummary a = solve_map(fm, dp.prior(), obs, one);
  const LeastSquaresSummary b = solve_map(fm, dp.prior(), obs, two);
  EXPECT_EQ(a.eta, b.eta);
  EXPECT_EQ(a.eta_covariance, b.eta_covariance);
  EXPECT_EQ(a.simulations, b.simulations);
  EXPECT_EQ(a.iterations.size(), b.iterations.size());
}

TEST(LeastSquares, RefusesInconsistentInput) {
  const DecayProblem dp;
  const FunctionModel fm = dp.model();
  const auto obs = dp.data(fm);
  Prior one = dp.prior();
  one.parameters.pop_back();
  EXPECT_THROW(solve_map(fm, one, obs, serial()), std::invalid_argument);
  LeastSquaresOptions bad = serial();
  bad.relative_step = 0.0;
  EXPECT_NE(bad.validate().find("relative_step"), std::string::npos);
  EXPECT_THROW(solve_map(fm, dp.prior(), obs, bad), std::invalid_argument);
  auto renamed = obs;
  renamed.names[2] = "x";
  EXPECT_NE(validate_map_problem(fm, dp.prior(), renamed).find("not the forward model's outputs"),
            std::string::npos);
}

}  // namespace
}  // namespace sigmaheart::estimation
