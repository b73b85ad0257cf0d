// An unknown noise scale per observed channel (docs/estimation.md s.4.8): the ROUKF's MAP
// refinement with model error said and handled.
//
// The entries of channel c (a regional volume curve: its n_c frames) have the covariance
// s_c^2 R_c, R_c the stated noise, and s_c^2 ~ InvGamma(a0, b0) a priori. Given the whitened
// residual r_c = L_c^-1 (y_c - h_c(eta)), the posterior of s_c^2 is conjugate (Gelman et al. 2013,
// Bayesian Data Analysis, 3rd ed., s.2.6):
//   s_c^2 | r_c ~ InvGamma(a0 + n_c / 2, b0 + |r_c|^2 / 2),
// and integrating s_c^2 out leaves the data term (twice its negative log, up to a constant)
//   Phi_c = (2 a0 + n_c) log(1 + |r_c|^2 / (2 b0))           (a multivariate Student t),
// whose gradient is that of the Gaussian |r_c|^2 with the weight w_c = E[1 / s_c^2 | r_c] =
// (a0 + n_c / 2) / (b0 + |r_c|^2 / 2): a Gauss-Newton step on the marginal is the Gaussian step
// with R_c replaced by R_c / w_c (iteratively reweighted least squares; Lange, Little & Taylor
// 1989, J Am Stat Assoc 84:881, s.4). A channel the model cannot fit gets a small weight, pulls
// less on the parameters and widens the posterior instead of dragging them (Kennedy & O'Hagan
// 2001, J R Stat Soc B 63:425).
//
// The same conjugate model and types as the global calibration's per-channel scale
// (estimation/noise_scale.h); here the channels are given by index (channel_of) rather than by
// observation name, and the misfit is twice noise_scale.h's marginal_misfit.
#pragma once

#include "estimation/noise_scale.h"

#include <Eigen/Core>

#include <vector>

namespace sigmaheart::estimation {

// channel_of: per entry of r, its channel in [0, channels). Channels without entries keep the prior.
// The posterior has no channel names.
NoiseScalePosterior channel_noise_posterior(const NoiseScalePrior& prior, const std::vector<int>& channel_of,
                                            int channels, const Eigen::Ref<const Eigen::VectorXd>& r);

// sum_c (2 a0 + n_c) log(1 + |r_c|^2 / (2 b0)): twice the negative log of the marginal data term,
// 0 at r = 0 and about (a0 + n_c / 2) / b0 |r_c|^2 for small r. NaN when r is not finite.
double channel_marginal_misfit(const NoiseScalePrior& prior, const std::vector<int>& channel_of,
                               int channels, const Eigen::Ref<const Eigen::VectorXd>& r);

}  // namespace sigmaheart::estimation
