#include "estimation/channel_noise_scale.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace sigmaheart::estimation {

namespace {
// |r_c|^2 and n_c per channel.
void channel_sums(const std::vector<int>& channel_of, int channels, const Eigen::Ref<const Eigen::VectorXd>& r,
                  Eigen::VectorXd& squares, Eigen::VectorXd& counts) {
  if (static_cast<Eigen::Index>(channel_of.size()) != r.size()) {
    throw std::invalid_argument("channel noise scale: one channel per residual entry expected");
  }
  squares = Eigen::VectorXd::Zero(channels);
  counts = Eigen::VectorXd::Zero(channels);
  for (Eigen::Index e = 0; e < r.size(); ++e) {
    const int c = channel_of[static_cast<size_t>(e)];
    if (c < 0 || c >= channels) throw std::invalid_argument("channel noise scale: channel index out of range");
    squares(c) += r(e) * r(e);
    counts(c) += 1.0;
  }
}
}  // namespace

NoiseScalePosterior channel_noise_posterior(const NoiseScalePrior& prior, const std::vector<int>& channel_of,
                                            int channels, const Eigen::Ref<const Eigen::VectorXd>& r) {
  Eigen::VectorXd squares, counts;
  channel_sums(channel_of, channels, r, squares, counts);
  NoiseScalePosterior out;
  out.shape = (prior.shape + 0.5 * counts.array()).matrix();
  out.scale = (prior.scale + 0.5 * squares.array()).matrix();
  return out;
}

double channel_marginal_misfit(const NoiseScalePrior& prior, const std::vector<int>& channel_of, int channels,
                               const Eigen::Ref<const Eigen::VectorXd>& r) {
  if (!r.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd squares, counts;
  channel_sums(channel_of, channels, r, squares, counts);
  double phi = 0.0;
  for (int c = 0; c < channels; ++c) {
    phi += (2.0 * prior.shape + counts(c)) * std::log1p(squares(c) / (2.0 * prior.scale));
  }
  return phi;
}

}  // namespace sigmaheart::estimation
