#include "model/regional_volume_shares.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model {

std::vector<int> RegionalVolumeShares::regional_channels(const std::vector<Channel>& channels) {
  std::vector<std::pair<int, int>> found;  // (segment, position)
  for (size_t i = 0; i < channels.size(); ++i) {
    if (channels[i].family == "regional_volume") found.emplace_back(channels[i].segment, static_cast<int>(i));
  }
  std::sort(found.begin(), found.end());
  std::vector<int> out;
  for (const auto& [segment, position] : found) out.push_back(position);
  return out;
}

namespace {
// AHA level of a 0-based segment index: 0 basal (1-6), 1 mid (7-12), 2 apical and apex (13-17).
int aha_level(Eigen::Index p) { return p < 6 ? 0 : p < 12 ? 1 : 2; }
const char* const kLevelNames[3] = {"vshare_basal", "vshare_mid", "vshare_apical"};
const char* const kLevelDocs[3] = {"basal segments 1-6", "mid segments 7-12", "apical segments 13-17"};
const char* const kGammaName = "vshare_gamma";
}  // namespace

RegionalVolumeShares::RegionalVolumeShares(std::unique_ptr<SteppableSimulator> inner, Eigen::VectorXd shares,
                                           Eigen::VectorXd reference, double reference_volume,
                                           bool level_exponents)
    : inner_(std::move(inner)), shares_(std::move(shares)), reference_(std::move(reference)),
      reference_volume_(reference_volume), level_exponents_(level_exponents) {
  if (!inner_) throw std::invalid_argument("RegionalVolumeShares: no inner simulator");
  regional_ = regional_channels(inner_->channels());
  const auto n = static_cast<Eigen::Index>(regional_.size());
  if (n == 0) throw std::invalid_argument("model " + inner_->name() + " has no regional volume channels");
  if (shares_.size() != n || reference_.size() != n) {
    std::ostringstream s;
    s << "volume shares: " << shares_.size() << " shares and " << reference_.size()
      << " reference shares for " << n << " regional volume channels";
    throw std::invalid_argument(s.str());
  }
  if (!shares_.allFinite() || shares_.minCoeff() < 0.0 || std::abs(shares_.sum() - 1.0) > 1e-9) {
    throw std::invalid_argument("volume shares must be >= 0 and sum to 1");
  }
  if (!reference_.allFinite() || reference_.minCoeff() <= 0.0) {
    throw std::invalid_argument("reference shares must be positive");
  }
  if (level_exponents_) {
    if (n != 17) throw std::invalid_argument("volume share exponents per AHA level need the 17 segments");
    if (!(reference_volume_ > 0.0 && std::isfinite(reference_volume_))) {
      throw std::invalid_argument("volume share exponents need a positive reference volume");
    }
  }
  space_ = shares_space(inner_->parameters(), level_exponents_);
}

ParameterSpace RegionalVolumeShares::shares_space(const ParameterSpace& inner, bool level_exponents) {
  if (!level_exponents) return inner;
  std::vector<Parameter> params = inner.all();
  for (int l = 0; l < 3; ++l) {
    if (inner.index(kLevelNames[l])) throw std::invalid_argument(std::string(kLevelNames[l]) + " is already a parameter");
    params.push_back({kLevelNames[l], "1", 0.0, -3.0, 3.0,
                      std::string("exponent b of the volume share law omega (V / V_ref)^b of the ") + kLevelDocs[l] +
                          " (model/regional_volume_shares.h)",
                      "geometry", 0});
  }
  if (inner.index(kGammaName)) throw std::invalid_argument(std::string(kGammaName) + " is already a parameter");
  params.push_back({kGammaName, "1", 1.0, 0.5, 3.0,
                    "exponent gamma of a segment's area change in its volume share, r_p^gamma: 1 a cone, 2 a wedge "
                    "that bulges outward at a fixed height (model/regional_volume_shares.h)",
                    "geometry", 0});
  return ParameterSpace(std::move(params));
}

Eigen::VectorXd RegionalVolumeShares::inner_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (!level_exponents_ || theta.size() != space_.size()) return theta;
  return theta.head(inner_->parameters().size());
}

Eigen::VectorXd RegionalVolumeShares::reference_shares(SteppableSimulator& inner,
                                                       const Eigen::Ref<const Eigen::VectorXd>& theta) {
  const std::vector<int> regional = regional_channels(inner.channels());
  if (regional.empty()) throw std::invalid_argument("model " + inner.name() + " has no regional volume channels");
  const Eigen::VectorXd z = inner.sample(inner.initial_state(theta), theta);
  Eigen::VectorXd v(static_cast<Eigen::Index>(regional.size()));
  for (size_t p = 0; p < regional.size(); ++p) v(static_cast<Eigen::Index>(p)) = z(regional[p]);
  const Eigen::VectorXd s = v / v.sum();
  if (!s.allFinite() || s.minCoeff() <= 0.0) {
    throw std::invalid_argument("the regional volumes of model " + inner.name() +
                                " in its initial state are not all positive: no reference shares");
  }
  return s;
}

std::vector<Channel> RegionalVolumeShares::channels() const {
  std::vector<Channel> c = inner_->channels();
  for (int i : regional_) c[static_cast<size_t>(i)].doc += " (re-weighted by the volume shares of the data)";
  return c;
}

void RegionalVolumeShares::reweight(Eigen::Ref<Eigen::VectorXd> values,
                                    const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  const auto n = static_cast<Eigen::Index>(regional_.size());
  Eigen::VectorXd v(n);
  for (Eigen::Index p = 0; p < n; ++p) v(p) = values(regional_[static_cast<size_t>(p)]);
  const double V = v.sum();
  // r_p = (V_p / V) / s_p; the weights omega_p r_p^gamma (V / V_ref)^b_level, normalised.
  Eigen::VectorXd w = v.cwiseQuotient(reference_);
  if (level_exponents_ && theta.size() == space_.size() && V > 0.0) {
    const Eigen::Index first = inner_->parameters().size();
    const double gamma = theta(first + 3);
    for (Eigen::Index p = 0; p < n; ++p) {
      w(p) = std::pow(std::max(w(p) / V, 0.0), gamma) * std::pow(V / reference_volume_, theta(first + aha_level(p)));
    }
  }
  w = shares_.cwiseProduct(w);
  const double sum = w.sum();
  for (Eigen::Index p = 0; p < n; ++p) {
    values(regional_[static_cast<size_t>(p)]) = sum > 0.0 ? V * w(p) / sum : 0.0;
  }
}

Eigen::VectorXd RegionalVolumeShares::sample(const State& state, const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  Eigen::VectorXd z = inner_->sample(state, inner_theta(theta));
  if (z.size() == static_cast<Eigen::Index>(inner_->channels().size())) reweight(z, theta);
  return z;
}

RunResult RegionalVolumeShares::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  RunResult r = inner_->run(inner_theta(theta));
  Eigen::MatrixXd& values = r.trajectory.values;
  if (values.cols() == static_cast<Eigen::Index>(inner_->channels().size())) {
    for (Eigen::Index k = 0; k < values.rows(); ++k) {
      Eigen::VectorXd row = values.row(k).transpose();
      reweight(row, theta);
      values.row(k) = row.transpose();
    }
  }
  r.trajectory.channels = channels();
  return r;
}

std::unique_ptr<Simulator> RegionalVolumeShares::clone() const {
  std::unique_ptr<SteppableSimulator> inner = into_steppable(inner_->clone());
  if (!inner) throw std::logic_error("RegionalVolumeShares: the inner clone is not steppable");
  return std::make_unique<RegionalVolumeShares>(std::move(inner), shares_, reference_, reference_volume_,
                                                level_exponents_);
}

std::unique_ptr<SteppableSimulator> RegionalVolumeShares::with_time_step_factor(double factor) const {
  std::unique_ptr<SteppableSimulator> finer = inner_->with_time_step_factor(factor);
  if (!finer) return nullptr;
  return std::make_unique<RegionalVolumeShares>(std::move(finer), shares_, reference_, reference_volume_,
                                                level_exponents_);
}

}  // namespace sigmaheart::model
