// Tests of estimation/channel_noise_scale.h against hand-computed values: the conjugate posterior
// of each channel's variance scale, the marginal data term and its gradient (the IRLS weight).
#include "estimation/channel_noise_scale.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::estimation {
namespace {

TEST(ChannelNoiseScale, PosteriorIsTheConjugateInverseGammaOfEachChannel) {
  const NoiseScalePrior prior;  // a0 = 3, b0 = 4
  // Channel 0: residuals 1, 2 (|r|^2 = 5, n = 2); channel 1: 3 (9, 1); channel 2: none.
  const std::vector<int> of = {0, 1, 0};
  const Eigen::Vector3d r(1.0, 3.0, 2.0);
  const NoiseScalePosterior post = channel_noise_posterior(prior, of, 3, r);
  EXPECT_DOUBLE_EQ(post.shape(0), 3.0 + 1.0);
  EXPECT_DOUBLE_EQ(post.scale(0), 4.0 + 2.5);
  EXPECT_DOUBLE_EQ(post.shape(1), 3.5);
  EXPECT_DOUBLE_EQ(post.scale(1), 8.5);
  EXPECT_DOUBLE_EQ(post.shape(2), 3.0);  // no entries: the prior
  EXPECT_DOUBLE_EQ(post.scale(2), 4.0);
  EXPECT_DOUBLE_EQ(post.mode()(0), 6.5 / 5.0);
  EXPECT_DOUBLE_EQ(post.mode()(2), 1.0);   // the prior's mode: the stated noise
  EXPECT_DOUBLE_EQ(post.weight()(1), 3.5 / 8.5);
}

TEST(ChannelNoiseScale, MarginalMisfitHasTheWeightedGaussianGradient) {
  const NoiseScalePrior prior{2.5, 3.0};
  const std::vector<int> of = {0, 0, 1, 1, 1};
  Eigen::VectorXd r(5);
  r << 0.3, -1.2, 2.0, 0.7, -0.4;
  const double phi = channel_marginal_misfit(prior, of, 2, r);
  // By hand: (2 a0 + n_c) log(1 + |r_c|^2 / (2 b0)).
  const double expected = (5.0 + 2.0) * std::log1p((0.09 + 1.44) / 6.0) + (5.0 + 3.0) * std::log1p((4.0 + 0.49 + 0.16) / 6.0);
  EXPECT_NEAR(phi, expected, 1e-14);
  // d phi / d r_e = 2 w_c r_e, w_c = E[1 / s_c^2 | r]: central differences.
  const Eigen::VectorXd w = channel_noise_posterior(prior, of, 2, r).weight();
  for (int e = 0; e < 5; ++e) {
    Eigen::VectorXd rp = r, rm = r;
    rp(e) += 1e-6;
    rm(e) -= 1e-6;
    const double g = (channel_marginal_misfit(prior, of, 2, rp) - channel_marginal_misfit(prior, of, 2, rm)) / 2e-6;
    EXPECT_NEAR(g, 2.0 * w(of[static_cast<size_t>(e)]) * r(e), 1e-7) << "entry " << e;
  }
  // Small residuals: the Gaussian misfit with weight (a0 + n_c / 2) / b0.
  const Eigen::VectorXd small = 1e-4 * r;
  EXPECT_NEAR(channel_marginal_misfit(prior, of, 2, small),
              (3.5 / 3.0) * small.head(2).squaredNorm() + (4.0 / 3.0) * small.tail(3).squaredNorm(), 1e-15);
  EXPECT_TRUE(std::isnan(channel_marginal_misfit(prior, of, 2, Eigen::VectorXd::Constant(5, NAN))));
}

TEST(ChannelNoiseScale, BadPriorsAreNamed) {
  EXPECT_NE(NoiseScalePrior({0.0, 1.0}).validate().find("shape"), std::string::npos);
  EXPECT_NE(NoiseScalePrior({1.0, -1.0}).validate().find("scale"), std::string::npos);
  EXPECT_TRUE(NoiseScalePrior{}.validate().empty());
}

}  // namespace
}  // namespace sigmaheart::estimation
