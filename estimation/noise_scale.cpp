#include "estimation/noise_scale.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {

std::string NoiseScalePrior::validate() const {
  std::ostringstream m;
  if (!(shape > 0) || !std::isfinite(shape)) m << "shape must be > 0, got " << shape;
  else if (!(scale > 0) || !std::isfinite(scale)) m << "scale must be > 0, got " << scale;
  return m.str();
}

ChannelGroups channel_groups(const std::vector<std::string>& observation_names) {
  ChannelGroups g;
  for (const std::string& name : observation_names) {
    const auto at = name.rfind("@f");
    const bool framed = at != std::string::npos && at + 2 < name.size() &&
                        name.find_first_not_of("0123456789", at + 2) == std::string::npos;
    const std::string channel = framed ? name.substr(0, at) : name;
    int index = -1;
    for (size_t c = 0; c < g.names.size(); ++c) {
      if (g.names[c] == channel) index = static_cast<int>(c);
    }
    if (index < 0) {
      index = static_cast<int>(g.names.size());
      g.names.push_back(channel);
    }
    g.of.push_back(index);
  }
  return g;
}

Eigen::VectorXd ChannelGroups::counts() const {
  Eigen::VectorXd n = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(names.size()));
  for (int c : of) n(c) += 1.0;
  return n;
}

Eigen::VectorXd NoiseScalePosterior::weight() const { return shape.cwiseQuotient(scale); }
Eigen::VectorXd NoiseScalePosterior::mode() const { return scale.array() / (shape.array() + 1.0); }
Eigen::VectorXd NoiseScalePosterior::mean() const {
  return (shape.array() > 1.0)
      .select(scale.array() / (shape.array() - 1.0), std::numeric_limits<double>::infinity());
}

NoiseScalePosterior noise_scale_posterior(const NoiseScalePrior& prior, const ChannelGroups& groups,
                                          const Eigen::Ref<const Eigen::VectorXd>& r) {
  if (r.size() != static_cast<Eigen::Index>(groups.of.size())) {
    throw std::invalid_argument("noise scale: " + std::to_string(r.size()) + " residuals for " +
                                std::to_string(groups.of.size()) + " observations");
  }
  NoiseScalePosterior post;
  post.channels = groups.names;
  post.shape = prior.shape + 0.5 * groups.counts().array();
  post.scale = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(groups.names.size()), prior.scale);
  for (Eigen::Index i = 0; i < r.size(); ++i) post.scale(groups.of[static_cast<size_t>(i)]) += 0.5 * r(i) * r(i);
  return post;
}

double marginal_misfit(const NoiseScalePrior& prior, const ChannelGroups& groups,
                       const Eigen::Ref<const Eigen::VectorXd>& r) {
  if (!r.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  const NoiseScalePosterior post = noise_scale_posterior(prior, groups, r);
  double phi = 0.0;
  for (Eigen::Index c = 0; c < post.shape.size(); ++c) {
    phi += post.shape(c) * std::log1p((post.scale(c) - prior.scale) / prior.scale);
  }
  return phi;
}

Eigen::VectorXd observation_weights(const NoiseScalePosterior& posterior, const ChannelGroups& groups) {
  const Eigen::VectorXd w = posterior.weight();
  Eigen::VectorXd out(static_cast<Eigen::Index>(groups.of.size()));
  for (size_t i = 0; i < groups.of.size(); ++i) out(static_cast<Eigen::Index>(i)) = w(groups.of[i]);
  return out;
}

}  // namespace sigmaheart::estimation
