// Hierarchical observation noise: an unknown scale per channel (docs/estimation.md s.3.10).
//
// The observations of channel c (all frames of V_lv, say; n_c entries) have the covariance
// s_c^2 R_c, R_c the stated noise and s_c^2 ~ InvGamma(a0, b0) a priori. Given the whitened
// residual r_c = L_c^-1 (y_c - z_c), the scale's posterior is conjugate (Gelman et al. 2013,
// Bayesian Data Analysis, 3rd ed., s.2.6 / s.3.3):
//   s_c^2 | r_c ~ InvGamma(a0 + n_c / 2, b0 + |r_c|^2 / 2),
// and marginalising s_c^2 out leaves, up to a constant, the data term
//   Phi_c = (a0 + n_c / 2) log(1 + |r_c|^2 / (2 b0))       (a multivariate Student t),
// whose gradient is that of the Gaussian term with weight w_c = E[1 / s_c^2 | r_c] =
// (a0 + n_c / 2) / (b0 + |r_c|^2 / 2): Gauss-Newton on the marginal is the Gaussian step with R_c
// replaced by R_c / w_c (iteratively reweighted least squares, the EM algorithm for the scale;
// Dempster, Laird & Rubin 1977; Lange, Little & Taylor 1989, J Am Stat Assoc 84:881, s.4). When
// the model cannot fit a channel, w_c falls, the channel's pull on the parameters weakens and
// the posterior widens instead of moving parameters to absorb the discrepancy (Kennedy & O'Hagan
// 2001, J R Stat Soc B 63:425; Brynjarsdottir & O'Hagan 2014, Inverse Problems 30:114007).
// Library code: no I/O. Used by the UT calibration (kMap) and reusable by the ROUKF.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sigmaheart::estimation {

// InvGamma(shape, scale) prior on every channel's variance multiplier s^2 (1 = the stated noise).
// The defaults put the prior mode b0 / (a0 + 1) at 1 and the prior mean b0 / (a0 - 1) at 2: the
// stated noise is the most likely value, and 2-4x larger variances stay plausible.
struct NoiseScalePrior {
  double shape = 3.0;  // a0 > 0
  double scale = 4.0;  // b0 > 0
  std::string validate() const;  // empty when valid
};

// Which channel each observation belongs to: observations named "<channel>@f<k>" share their
// channel; any other name is a channel of its own.
struct ChannelGroups {
  std::vector<std::string> names;  // channels, in order of first appearance
  std::vector<int> of;             // per observation: index into names
  Eigen::VectorXd counts() const;  // n_c
};
ChannelGroups channel_groups(const std::vector<std::string>& observation_names);

// The conjugate posterior of each channel's s_c^2 given whitened residuals (one per observation).
struct NoiseScalePosterior {
  std::vector<std::string> channels;
  Eigen::VectorXd shape, scale;        // a0 + n_c / 2, b0 + |r_c|^2 / 2
  Eigen::VectorXd weight() const;      // E[1 / s_c^2] = shape / scale
  Eigen::VectorXd mode() const;        // of s_c^2: scale / (shape + 1)
  Eigen::VectorXd mean() const;        // of s_c^2: scale / (shape - 1) (inf when shape <= 1)
};
NoiseScalePosterior noise_scale_posterior(const NoiseScalePrior& prior, const ChannelGroups& groups,
                                          const Eigen::Ref<const Eigen::VectorXd>& whitened_residual);

// sum_c (a0 + n_c / 2) log(1 + |r_c|^2 / (2 b0)): the data term of the marginal (a misfit that
// is 0 at r = 0 and |r|^2 / 2 * (a0 + n_c / 2) / b0 for small r). NaN when r is not finite.
double marginal_misfit(const NoiseScalePrior& prior, const ChannelGroups& groups,
                       const Eigen::Ref<const Eigen::VectorXd>& whitened_residual);

// Per observation, the weight of its channel (expands NoiseScalePosterior::weight() over groups).
Eigen::VectorXd observation_weights(const NoiseScalePosterior& posterior, const ChannelGroups& groups);

}  // namespace sigmaheart::estimation
