#include "estimation/propagation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::estimation {
namespace {

Posterior linear_posterior() {
  Posterior p;
  p.names = {"a", "b", "c"};
  p.units = {"1", "1", "1"};
  p.transforms.assign(3, Transform{});
  p.eta_mean = Eigen::Vector3d(1.0, -2.0, 0.5);
  Eigen::Matrix3d L;
  L << 0.3, 0, 0, 0.1, 0.2, 0, -0.05, 0.07, 0.4;
  p.eta_covariance = L * L.transpose();
  return p;
}

Eigen::MatrixXd apply(const Eigen::MatrixXd& points, const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  return (points * A.transpose()).rowwise() + b.transpose();
}

TEST(Propagation, UnscentedTransformOfALinearResponseGivesTheExactMeanAndCovariance) {
  const Posterior post = linear_posterior();
  Eigen::MatrixXd A(2, 3);
  A << 2.0, -1.0, 0.5, 0.0, 3.0, 1.0;
  const Eigen::Vector2d b(10.0, -4.0);
  for (SigmaRule rule : {SigmaRule::kStar, SigmaRule::kSimplex, SigmaRule::kCanonical}) {
    PropagationOptions o;
    o.sigma.rule = rule;
    const PropagationPoints pts = propagation_points(post, o);
    EXPECT_EQ(pts.count(), rule == SigmaRule::kStar ? 7 : (rule == SigmaRule::kSimplex ? 4 : 6));
    const ResponseMoments m = response_moments(pts, apply(pts.theta, A, b), o);
    ASSERT_TRUE(m.ok);
    EXPECT_LT((m.mean - (A * post.eta_mean + b)).cwiseAbs().maxCoeff(), 1e-12) << to_string(rule);
    EXPECT_LT((m.covariance - A * post.eta_covariance * A.transpose()).cwiseAbs().maxCoeff(), 1e-12) << to_string(rule);
    // The 90 % interval of the Gaussian with these moments.
    EXPECT_NEAR(m.upper(0) - m.mean(0), 1.6448536 * std::sqrt((A * post.eta_covariance * A.transpose())(0, 0)), 1e-6);
  }
}

TEST(Propagation, ALinearResponseInEtaIsExactThroughALogTransformToo) {
  Posterior post = linear_posterior();
  for (auto& t : post.transforms) {
    t.kind = TransformKind::kLog;
    t.reference = 2.0;
  }
  PropagationOptions o;
  const PropagationPoints pts = propagation_points(post, o);
  // y = log(theta / 2) = eta: mean and covariance of eta itself.
  const Eigen::MatrixXd y = (pts.theta / 2.0).array().log().matrix();
  const ResponseMoments m = response_moments(pts, y, o);
  EXPECT_LT((m.mean - post.eta_mean).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((m.covariance - post.eta_covariance).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Propagation, MonteCarloAgreesWithTheLogNormalMomentsAndTheUnscentedTransform) {
  Posterior post;
  post.names = {"k"};
  post.units = {"1/s"};
  post.transforms = {Transform{TransformKind::kLog, 8.0}};
  post.eta_mean = Eigen::VectorXd::Constant(1, 0.0);
  post.eta_covariance = Eigen::MatrixXd::Constant(1, 1, 0.2 * 0.2);
  PropagationOptions mc;
  mc.method = PropagationMethod::kMonteCarlo;
  mc.samples = 20000;
  const PropagationPoints pts = propagation_points(post, mc);
  const ResponseMoments m = response_moments(pts, pts.theta, mc);
  // theta = 8 exp(eta): E = 8 exp(s^2/2), Var = 64 (exp(s^2) - 1) exp(s^2).
  const double s2 = 0.04, mean = 8.0 * std::exp(s2 / 2), sd = 8.0 * std::sqrt((std::exp(s2) - 1) * std::exp(s2));
  EXPECT_NEAR(m.mean(0), mean, 4.0 * sd / std::sqrt(20000.0));
  EXPECT_NEAR(m.std(0), sd, 0.03 * sd);
  // The empirical 5 and 95 % quantiles of a log-normal.
  EXPECT_NEAR(m.lower(0), 8.0 * std::exp(-1.6448536 * 0.2), 0.02 * 8.0);
  EXPECT_NEAR(m.upper(0), 8.0 * std::exp(1.6448536 * 0.2), 0.02 * 8.0);
  const PropagationOptions ut;
  const PropagationPoints sp = propagation_points(post, ut);
  const ResponseMoments u = response_moments(sp, sp.theta, ut);
  EXPECT_NEAR(u.mean(0), mean, 0.002 * mean);  // second-order exact
  EXPECT_NEAR(u.std(0), sd, 0.02 * sd);
  // The same seed gives the same draws.
  EXPECT_EQ(propagation_points(post, mc).eta, pts.eta);
}

TEST(Propagation, ProbabilitiesFollowTheMomentsOrTheSample) {
  const Posterior post = linear_posterior();
  PropagationOptions o;
  const PropagationPoints pts = propagation_points(post, o);
  Eigen::MatrixXd A(3, 3);
  A << 1, 0, 0, 0, 0.5, 0, 1, 0, 0;  // response 2 is response 0 minus 0.1
  const Eigen::MatrixXd y = apply(pts.theta, A, Eigen::Vector3d(0.0, 1.5, -0.1));
  const ResponseMoments m = response_moments(pts, y, o);
  const Eigen::VectorXd above = probability_above(pts, y, m, 1.0, o);
  EXPECT_NEAR(above(0), 0.5, 1e-12);  // mean 1, threshold 1
  EXPECT_NEAR(m.mean(1), 0.5, 1e-12);
  EXPECT_NEAR(above(1), 0.5 * std::erfc((1.0 - m.mean(1)) / (m.std(1) * std::sqrt(2.0))), 1e-15);
  EXPECT_LT(above(1), 1e-4);
  // Response 0 beats response 1 unless 0 - 1 (mean 0.5, std 0.27) falls below 0 (3 %); response 2
  // never wins.
  const Eigen::VectorXd best = probability_largest(pts, y, m, o);
  EXPECT_NEAR(best.sum(), 1.0, 1e-12);
  EXPECT_NEAR(best(0), 0.969, 0.005);
  EXPECT_NEAR(best(2), 0.0, 1e-12);
}

double phi(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// Points without parameters (the rows of a response given directly), each of weight w.
PropagationPoints bare_points(PropagationMethod method, int n, double w) {
  PropagationPoints pts;
  pts.method = method;
  pts.eta.resize(n, 0);
  pts.theta.resize(n, 0);
  pts.wm = pts.wc = Eigen::VectorXd::Constant(n, w);
  return pts;
}

TEST(Propagation, AnAddedErrorWidensTheGaussianMomentsExactly) {
  const Posterior post = linear_posterior();
  PropagationOptions o;
  const PropagationPoints pts = propagation_points(post, o);
  Eigen::MatrixXd A(2, 3);
  A << 2.0, -1.0, 0.5, 0.0, 3.0, 1.0;
  const Eigen::MatrixXd y = apply(pts.theta, A, Eigen::Vector2d(10.0, -4.0));
  ResponseMoments m = response_moments(pts, y, o);
  const ResponseMoments before = m;
  add_response_error(m, pts, y, 0, 1.5, o);
  const double var = (A.row(0) * post.eta_covariance * A.row(0).transpose())(0, 0) + 2.25;  // exact, plus 1.5^2
  EXPECT_NEAR(m.mean(0), before.mean(0), 1e-15);
  EXPECT_NEAR(m.std(0), std::sqrt(var), 1e-12);
  EXPECT_NEAR(m.upper(0) - m.mean(0), 1.6448536269514722 * std::sqrt(var), 1e-9);
  EXPECT_NEAR(m.lower(0) - m.mean(0), -1.6448536269514722 * std::sqrt(var), 1e-9);
  EXPECT_EQ(m.std(1), before.std(1));  // the other response untouched
  EXPECT_EQ(m.covariance(0, 1), before.covariance(0, 1));
  EXPECT_NEAR(probability_above(pts, y, m, 12.0, o)(0), phi((m.mean(0) - 12.0) / std::sqrt(var)), 1e-15);
  // Point propagation: the error is the whole spread.
  PropagationOptions po;
  po.method = PropagationMethod::kPoint;
  const PropagationPoints one = bare_points(PropagationMethod::kPoint, 1, 1.0);
  const Eigen::MatrixXd y1 = Eigen::MatrixXd::Constant(1, 1, 20.0);
  ResponseMoments m1 = response_moments(one, y1, po);
  add_response_error(m1, one, y1, 0, 4.0, po);
  EXPECT_NEAR(m1.std(0), 4.0, 1e-15);
  EXPECT_NEAR(m1.lower(0), 20.0 - 1.6448536269514722 * 4.0, 1e-9);
  EXPECT_NEAR(probability_above(one, y1, m1, 10.0, po)(0), phi(2.5), 1e-15);
  EXPECT_THROW(add_response_error(m1, one, y1, 0, -1.0, po), std::invalid_argument);
  EXPECT_THROW(add_response_error(m1, one, y1, 1, 1.0, po), std::invalid_argument);
}

TEST(Propagation, AnAddedErrorConvolvesTheMonteCarloSample) {
  // A sample of two values, 0 and 6, and an error of std 1: the interval's ends are where the
  // mixture (Phi(x) + Phi(x - 6)) / 2 takes 0.05 and 0.95 (checked with the mixture written here).
  PropagationOptions o;
  o.method = PropagationMethod::kMonteCarlo;
  const PropagationPoints pts = bare_points(PropagationMethod::kMonteCarlo, 3, 0.5);
  Eigen::MatrixXd y(3, 1);
  y << 0.0, 6.0, std::nan("");  // a failed point, dropped
  ResponseMoments m = response_moments(pts, y, o);
  add_response_error(m, pts, y, 0, 1.0, o);
  auto mixture = [](double x) { return 0.5 * (phi(x) + phi(x - 6.0)); };
  EXPECT_NEAR(mixture(m.lower(0)), 0.05, 1e-9);
  EXPECT_NEAR(mixture(m.upper(0)), 0.95, 1e-9);
  EXPECT_NEAR(m.lower(0) + m.upper(0), 6.0, 1e-9);  // symmetric
  EXPECT_NEAR(m.std(0), std::sqrt(18.0 + 1.0), 1e-12);  // sample variance 18 (n - 1 = 1), plus 1
  EXPECT_NEAR(probability_above(pts, y, m, 5.0, o)(0), 0.5 * (phi(-5.0) + phi(1.0)), 1e-15);
  // Two responses, equal without the error: the draws split the votes; 2 apart with independent
  // errors of std 1: P(second largest) = Phi(2 / sqrt(2)) = 0.921.
  Eigen::MatrixXd two(3, 2);
  two << 0.0, 2.0, 1.0, 3.0, std::nan(""), std::nan("");
  ResponseMoments m2 = response_moments(pts, two, o);
  for (int j = 0; j < 2; ++j) add_response_error(m2, pts, two, j, 1.0, o);
  const Eigen::VectorXd best = probability_largest(pts, two, m2, o);
  EXPECT_NEAR(best(1), phi(std::sqrt(2.0)), 0.01);
  EXPECT_NEAR(best.sum(), 1.0, 1e-12);
}

TEST(Propagation, TheUnscentedTransformNeedsEveryPointMonteCarloDropsTheFailedOnes) {
  const Posterior post = linear_posterior();
  PropagationOptions ut;
  const PropagationPoints sp = propagation_points(post, ut);
  Eigen::MatrixXd y = sp.theta;
  y(2, 1) = std::nan("");
  const ResponseMoments u = response_moments(sp, y, ut);
  EXPECT_FALSE(u.ok);
  EXPECT_EQ(u.failed_points, 1);
  PropagationOptions mc;
  mc.method = PropagationMethod::kMonteCarlo;
  mc.samples = 50;
  const PropagationPoints pts = propagation_points(post, mc);
  Eigen::MatrixXd z = pts.theta;
  z.row(7).setConstant(std::nan(""));
  const ResponseMoments m = response_moments(pts, z, mc);
  EXPECT_TRUE(m.ok);
  EXPECT_EQ(m.failed_points, 1);
  EXPECT_TRUE(m.mean.allFinite());
}

TEST(Propagation, InvalidInputIsRefused) {
  Posterior post = linear_posterior();
  post.eta_covariance(0, 1) += 1.0;  // not symmetric
  EXPECT_THROW(propagation_points(post, {}), std::invalid_argument);
  PropagationOptions o;
  o.interval = 1.5;
  EXPECT_THROW(propagation_points(linear_posterior(), o), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::estimation
