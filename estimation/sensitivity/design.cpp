#include "estimation/sensitivity/design.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation::sensitivity {

std::string ParameterRange::validate() const {
  std::ostringstream s;
  const std::string who = "parameter '" + name + "': ";
  if (!(std::isfinite(lower) && std::isfinite(upper) && lower < upper)) {
    s << who << "needs finite bounds with lower < upper, got [" << lower << ", " << upper << "]";
    return s.str();
  }
  if (!(std::isfinite(nominal) && nominal >= lower && nominal <= upper)) {
    s << who << "nominal " << nominal << " lies outside [" << lower << ", " << upper << "]";
    return s.str();
  }
  if (space == SamplingSpace::kEta) {
    if (const std::string t = transform.validate(); !t.empty()) return who + t;
    try {
      const double a = transform.to_eta(lower);
      const double b = transform.to_eta(upper);
      if (!(std::isfinite(a) && std::isfinite(b) && a < b)) {
        s << who << "the " << estimation::to_string(transform.kind)
          << " transform maps [lower, upper] to a non-finite eta range";
        return s.str();
      }
    } catch (const std::domain_error& e) {
      return who + "[lower, upper] is outside the transform's range: " + e.what();
    }
  }
  return {};
}

double ParameterRange::from_unit(double u) const {
  if (space == SamplingSpace::kPhysical) return lower + u * (upper - lower);
  const double a = transform.to_eta(lower);
  const double b = transform.to_eta(upper);
  return transform.to_theta(a + u * (b - a));
}

double ParameterRange::to_unit(double theta) const {
  if (space == SamplingSpace::kPhysical) return (theta - lower) / (upper - lower);
  const double a = transform.to_eta(lower);
  const double b = transform.to_eta(upper);
  return (transform.to_eta(theta) - a) / (b - a);
}

std::string validate_ranges(const std::vector<ParameterRange>& ranges, const ForwardModel& model) {
  if (ranges.empty()) return "no parameter ranges given";
  if (static_cast<int>(ranges.size()) != model.input_size()) {
    std::ostringstream s;
    s << ranges.size() << " parameter ranges for a model with " << model.input_size() << " inputs";
    return s.str();
  }
  const auto names = model.input_names();
  for (size_t i = 0; i < ranges.size(); ++i) {
    if (const std::string m = ranges[i].validate(); !m.empty()) return m;
    if (i < names.size() && !ranges[i].name.empty() && ranges[i].name != names[i]) {
      return "parameter range " + std::to_string(i) + " is named '" + ranges[i].name +
             "' but the model's input " + std::to_string(i) + " is '" + names[i] + "'";
    }
  }
  return {};
}

Eigen::MatrixXd unit_to_theta(const std::vector<ParameterRange>& ranges, const Eigen::MatrixXd& U) {
  if (U.cols() != static_cast<Eigen::Index>(ranges.size())) {
    throw std::invalid_argument("unit_to_theta: design has " + std::to_string(U.cols()) +
                                " columns for " + std::to_string(ranges.size()) + " parameters");
  }
  Eigen::MatrixXd theta(U.rows(), U.cols());
  for (Eigen::Index j = 0; j < U.cols(); ++j) {
    const ParameterRange& r = ranges[static_cast<size_t>(j)];
    for (Eigen::Index i = 0; i < U.rows(); ++i) theta(i, j) = r.from_unit(U(i, j));
  }
  return theta;
}

std::vector<std::string> range_names(const std::vector<ParameterRange>& ranges) {
  std::vector<std::string> names;
  names.reserve(ranges.size());
  for (const auto& r : ranges) names.push_back(r.name);
  return names;
}

std::vector<std::string> output_names(const ForwardModel& model) {
  std::vector<std::string> names;
  for (const auto& c : model.outputs()) names.push_back(c.name);
  return names;
}

namespace {
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
}  // namespace

std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t index) {
  return splitmix64(splitmix64(seed) ^ (index * 0xd1b54a32d192ed03ULL));
}

std::mt19937_64 make_stream(std::uint64_t seed, std::uint64_t index) {
  return std::mt19937_64(stream_seed(seed, index));
}

EnsembleResult evaluate_design(const ForwardModel& model, const Eigen::MatrixXd& thetas,
                               const EnsembleOptions& options) {
  Ensemble ensemble(model, options);
  EnsembleResult result = ensemble.evaluate(thetas);
  // The Ensemble already turns non-finite outputs into kNonFinite; kept as an invariant here so
  // that no study ever averages a NaN.
  for (Eigen::Index i = 0; i < result.Z.rows(); ++i) {
    auto& st = result.status[static_cast<size_t>(i)];
    if (st.ok() && !result.Z.row(i).allFinite()) {
      st = model::Status::Error(model::StatusCode::kNonFinite, "non-finite output");
    }
    if (!st.ok()) result.Z.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return result;
}

std::pair<double, double> percentile_interval(std::vector<double> samples, double confidence) {
  samples.erase(std::remove_if(samples.begin(), samples.end(),
                               [](double v) { return !std::isfinite(v); }),
                samples.end());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (samples.empty()) return {nan, nan};
  std::sort(samples.begin(), samples.end());
  auto q = [&](double prob) {
    const double h = (static_cast<double>(samples.size()) - 1.0) * prob;
    const auto lo = static_cast<size_t>(std::floor(h));
    const size_t hi = std::min(lo + 1, samples.size() - 1);
    return samples[lo] + (h - static_cast<double>(lo)) * (samples[hi] - samples[lo]);
  };
  const double alpha = 1.0 - confidence;
  return {q(alpha / 2.0), q(1.0 - alpha / 2.0)};
}

}  // namespace sigmaheart::estimation::sensitivity
