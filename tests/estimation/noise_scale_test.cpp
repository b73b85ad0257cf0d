// estimation/noise_scale.cpp, and the UT calibration with an estimated noise scale per channel
// (UtOptions::noise_scale) against the closed form of a linear-Gaussian problem.
#include "estimation/noise_scale.h"
#include "estimation/ut_calibration.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;

TEST(NoiseScale, ChannelsGroupFramesAndThePosteriorIsTheConjugateInverseGamma) {
  const ChannelGroups g = channel_groups({"V_lv@f00", "V_lv@f01", "V_lv@f02", "P_lv@f00", "P_lv@f01", "EDV"});
  EXPECT_EQ(g.names, (std::vector<std::string>{"V_lv", "P_lv", "EDV"}));
  EXPECT_EQ(g.of, (std::vector<int>{0, 0, 0, 1, 1, 2}));
  const NoiseScalePrior prior{3.0, 4.0};
  Eigen::VectorXd r(6);
  r << 1, 2, 2, 3, 0, 0.5;
  // V: a = 3 + 3/2 = 4.5, b = 4 + 9/2 = 8.5; P: a = 3 + 1 = 4, b = 8.5; EDV: a = 3.5, b = 4.125.
  const NoiseScalePosterior post = noise_scale_posterior(prior, g, r);
  EXPECT_DOUBLE_EQ(post.shape(0), 4.5);
  EXPECT_DOUBLE_EQ(post.scale(0), 8.5);
  EXPECT_DOUBLE_EQ(post.shape(1), 4.0);
  EXPECT_DOUBLE_EQ(post.scale(2), 4.125);
  EXPECT_DOUBLE_EQ(post.weight()(0), 4.5 / 8.5);
  EXPECT_DOUBLE_EQ(post.mode()(1), 8.5 / 5.0);
  EXPECT_DOUBLE_EQ(post.mean()(1), 8.5 / 3.0);
  const double phi = 4.5 * std::log(1 + 9.0 / 8.0) + 4.0 * std::log(1 + 9.0 / 8.0) +
                     3.5 * std::log(1 + 0.25 / 8.0);
  EXPECT_NEAR(marginal_misfit(prior, g, r), phi, 1e-14);
  EXPECT_TRUE(std::isnan(marginal_misfit(prior, g, Eigen::VectorXd::Constant(6, NAN))));
  EXPECT_FALSE((NoiseScalePrior{0.0, 1.0}.validate().empty()));
}

// z = H theta + c, 2 parameters, channels V (8 frames) and P (8 frames). P's data carry a
// discrepancy (a bump the model cannot make): with the plain noise model it drags theta; with the
// hierarchical one its weight falls.
struct TwoChannelProblem {
  static constexpr int m = 16;
  Eigen::MatrixXd H{m, 2};
  Eigen::VectorXd c{m}, y{m}, sd{m};
  Eigen::Vector2d m0{1.0, -0.5}, s0{0.5, 0.5};
  std::vector<model::Channel> outputs;
  TwoChannelProblem() {
    for (int k = 0; k < 8; ++k) {
      const double x = 0.1 * k;
      H.row(k) << 1.0 + x, 0.5 * x;
      H.row(8 + k) << 0.3, 2.0 - x;
      c(k) = 0.1 * k;
      c(8 + k) = 1.0;
      outputs.push_back({"V@f0" + std::to_string(k), "1", ""});
    }
    for (int k = 0; k < 8; ++k) outputs.push_back({"P@f0" + std::to_string(k), "1", ""});
    const Eigen::Vector2d truth(1.2, -0.3);
    y = H * truth + c;
    for (int k = 0; k < 8; ++k) {
      y(k) += 0.05 * std::sin(3.0 * k);                              // V: noise-level scatter
      y(8 + k) += 0.8 * std::exp(-0.5 * std::pow((k - 4) / 1.2, 2));  // P: a bump, 8 noise std
    }
    sd = Eigen::VectorXd::Constant(m, 0.1);
  }
  FunctionModel model() const {
    return FunctionModel({"t0", "t1"}, outputs, [H = H, c = c](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
      z = H * t + c;
      return model::Status::Ok();
    });
  }
  observers::ObservationSet observations() const {
    observers::ObservationSet obs;
    for (const auto& o : outputs) {
      obs.names.push_back(o.name);
      obs.units.push_back("1");
    }
    obs.y = y;
    obs.R = sd.array().square().matrix().asDiagonal();
    return obs;
  }
  Prior prior(double scale = 1.0) const {
    Prior p;
    for (int j = 0; j < 2; ++j) {
      p.parameters.push_back(PriorParameter::gaussian("t" + std::to_string(j), "1", m0(j), scale * s0(j),
                                                      SpreadKind::kEta, {}));
    }
    return p;
  }
  // The Gaussian posterior with channel weights w (R_c / w_c), information form.
  void exact(const Eigen::Vector2d& w, const Prior& p, Eigen::VectorXd& mean, Eigen::MatrixXd& P) const {
    Eigen::VectorXd wi(m);
    for (int i = 0; i < m; ++i) wi(i) = w(i < 8 ? 0 : 1) / (sd(i) * sd(i));
    const Eigen::MatrixXd P0inv = p.covariance_eta().inverse();
    P = (P0inv + H.transpose() * wi.asDiagonal() * H).inverse();
    mean = P * (P0inv * p.mean_eta() + H.transpose() * wi.asDiagonal() * (y - c));
  }
};

UtOptions hierarchical_options() {
  UtOptions o;
  o.ensemble.backend = Backend::kSerial;
  o.mode = UtMode::kMap;
  o.sigma.rule = SigmaRule::kCanonical;
  o.max_iterations = 200;
  o.tolerance = 1e-9;
  o.objective_tolerance = 0.0;  // the closed form to 1e-8: stop on the step only
  o.noise_scale = NoiseScalePrior{3.0, 4.0};
  return o;
}

TEST(NoiseScale, HierarchicalUtCalibrationEqualsTheClosedFormOfALinearGaussianProblem) {
  const TwoChannelProblem lp;
  const Prior prior = lp.prior();
  const UtSummary s = UtCalibration(lp.model(), prior, lp.observations(), hierarchical_options()).run();
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  ASSERT_TRUE(s.noise_scale.has_value());
  // At the fixed point, each channel's weight is E[1/s_c^2] of its conjugate posterior given the
  // estimate's residuals, and the estimate is the Gaussian posterior mean with R_c / w_c.
  const Eigen::VectorXd r = (lp.y - (lp.H * s.eta_mean + lp.c)).cwiseQuotient(lp.sd);
  const Eigen::Vector2d w((3.0 + 4.0) / (4.0 + 0.5 * r.head(8).squaredNorm()),
                          (3.0 + 4.0) / (4.0 + 0.5 * r.tail(8).squaredNorm()));
  EXPECT_NEAR(s.noise_scale->weight()(0), w(0), 1e-12);
  EXPECT_NEAR(s.noise_scale->weight()(1), w(1), 1e-12);
  Eigen::VectorXd mean;
  Eigen::MatrixXd P;
  lp.exact(w, prior, mean, P);
  EXPECT_LT((s.eta_mean - mean).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((s.eta_covariance - P).cwiseAbs().maxCoeff(), 1e-6 * P.cwiseAbs().maxCoeff());
  // The discrepant channel lost weight (its scale is estimated > 2x the stated noise), V kept ~1.
  EXPECT_LT(w(1), 0.25);
  EXPECT_GT(w(0), 0.7);
  // Against the plain noise model: the estimate moves less far from the truth's V-only fit and the
  // posterior is wider.
  UtOptions plain = hierarchical_options();
  plain.noise_scale.reset();
  const UtSummary g = UtCalibration(lp.model(), prior, lp.observations(), plain).run();
  ASSERT_EQ(g.termination, UtTermination::kConverged) << g.message;
  EXPECT_GT(s.eta_std(1), 1.5 * g.eta_std(1));
}

TEST(NoiseScale, WithOneChannelAndAFlatPriorTheEstimateIsLeastSquaresAndTheScaleItsClosedForm) {
  const TwoChannelProblem lp;
  // V alone: theta_LS = (H^T H)^-1 H^T (y - c) (equal noise), RSS in noise units, and
  // w = (a0 + n/2) / (b0 + RSS/2) from the conjugate posterior.
  const Eigen::MatrixXd H = lp.H.topRows(8);
  const Eigen::VectorXd yv = lp.y.head(8) - lp.c.head(8);
  const Eigen::VectorXd ls = (H.transpose() * H).ldlt().solve(H.transpose() * yv);
  const double rss = ((yv - H * ls) / 0.1).squaredNorm();
  const double w = (3.0 + 4.0) / (4.0 + 0.5 * rss);
  std::vector<model::Channel> outs(lp.outputs.begin(), lp.outputs.begin() + 8);
  FunctionModel fm({"t0", "t1"}, outs, [H, c = Eigen::VectorXd(lp.c.head(8))](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z = H * t + c;
    return model::Status::Ok();
  });
  observers::ObservationSet obs;
  for (const auto& o : outs) {
    obs.names.push_back(o.name);
    obs.units.push_back("1");
  }
  obs.y = lp.y.head(8);
  obs.R = Eigen::MatrixXd::Identity(8, 8) * 0.01;
  const UtSummary s = UtCalibration(fm, lp.prior(1e4), obs, hierarchical_options()).run();
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  EXPECT_LT((s.eta_mean - ls).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_NEAR(s.noise_scale->weight()(0), w, 1e-6 * w);
  const Eigen::MatrixXd P_ls = (w * H.transpose() * H / 0.01).inverse();
  EXPECT_LT((s.eta_covariance - P_ls).cwiseAbs().maxCoeff(), 1e-6 * P_ls.cwiseAbs().maxCoeff());
}

}  // namespace
}  // namespace sigmaheart::estimation
