#include "model/simulator.h"

#include "model/enum_names.h"

#include <algorithm>
#include <cctype>
#include <limits>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model {

constexpr std::array<EnumName<StatusCode>, 10> kStatusCodeNames{{
    {StatusCode::kOk, "ok"}, {StatusCode::kDiverged, "diverged"},
    {StatusCode::kNonFinite, "non-finite"}, {StatusCode::kOutOfBounds, "out-of-bounds"},
    {StatusCode::kNotPeriodic, "not-periodic"}, {StatusCode::kProcessFailed, "process-failed"},
    {StatusCode::kTimeout, "timeout"}, {StatusCode::kBadOutput, "bad-output"},
    {StatusCode::kInvalidArgument, "invalid-argument"}, {StatusCode::kCancelled, "cancelled"},
}};
const char* to_string(StatusCode code) { return enum_to_string(kStatusCodeNames, code); }

ParameterSpace::ParameterSpace(std::vector<Parameter> params) : params_(std::move(params)) {
  for (size_t i = 0; i < params_.size(); ++i) {
    const auto& p = params_[i];
    if (!(p.lower <= p.nominal && p.nominal <= p.upper)) {
      throw std::invalid_argument("parameter '" + p.name + "': nominal value outside its bounds");
    }
    for (size_t j = 0; j < i; ++j) {
      if (params_[j].name == p.name) {
        throw std::invalid_argument("parameter '" + p.name + "' declared twice");
      }
    }
  }
}

std::vector<std::string> ParameterSpace::names() const {
  std::vector<std::string> out;
  out.reserve(params_.size());
  for (const auto& p : params_) out.push_back(p.name);
  return out;
}

std::optional<int> ParameterSpace::index(const std::string& name) const {
  for (size_t i = 0; i < params_.size(); ++i) {
    if (params_[i].name == name) return static_cast<int>(i);
  }
  return std::nullopt;
}

std::optional<int> ParameterSpace::find(const std::string& family, int segment) const {
  for (size_t i = 0; i < params_.size(); ++i) {
    if (params_[i].family == family && params_[i].segment == segment) return static_cast<int>(i);
  }
  return std::nullopt;
}

std::vector<int> ParameterSpace::regional(const std::string& family) const {
  std::vector<int> out;
  for (size_t i = 0; i < params_.size(); ++i) {
    if (params_[i].family == family && params_[i].segment > 0) out.push_back(static_cast<int>(i));
  }
  std::stable_sort(out.begin(), out.end(), [&](int a, int b) {
    return params_[static_cast<size_t>(a)].segment < params_[static_cast<size_t>(b)].segment;
  });
  return out;
}

int ParameterSpace::index_or_throw(const std::string& name) const {
  if (auto i = index(name)) return *i;
  std::string msg = "unknown parameter '" + name + "'";
  const std::string guess = closest_match(name, names());
  if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
  throw std::invalid_argument(msg);
}

Eigen::VectorXd ParameterSpace::nominal() const {
  Eigen::VectorXd v(size());
  for (int i = 0; i < size(); ++i) v(i) = params_[static_cast<size_t>(i)].nominal;
  return v;
}

void ParameterSpace::set_nominal(const std::string& name, double value) {
  auto& p = params_[static_cast<size_t>(index_or_throw(name))];
  if (!std::isfinite(value) || value < p.lower || value > p.upper) {
    std::ostringstream s;
    s << "parameter '" << name << "' = " << value << " " << p.unit << " is outside its bounds ["
      << p.lower << ", " << p.upper << "] " << p.unit;
    throw std::invalid_argument(s.str());
  }
  p.nominal = value;
}

std::string ParameterSpace::check(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (theta.size() != size()) {
    std::ostringstream s;
    s << "parameter vector has " << theta.size() << " entries, expected " << size();
    return s.str();
  }
  for (int i = 0; i < size(); ++i) {
    const auto& p = params_[static_cast<size_t>(i)];
    if (!std::isfinite(theta(i)) || theta(i) < p.lower || theta(i) > p.upper) {
      std::ostringstream s;
      s << "parameter '" << p.name << "' = " << theta(i) << " " << p.unit
        << " is outside its bounds [" << p.lower << ", " << p.upper << "] " << p.unit;
      return s.str();
    }
  }
  return {};
}

std::optional<int> Trajectory::channel_index(const std::string& name) const {
  for (size_t i = 0; i < channels.size(); ++i) {
    if (channels[i].name == name) return static_cast<int>(i);
  }
  return std::nullopt;
}

Eigen::VectorXd Trajectory::channel(const std::string& name) const {
  if (auto i = channel_index(name)) return values.col(*i);
  std::vector<std::string> names;
  for (const auto& c : channels) names.push_back(c.name);
  std::string msg = "trajectory has no channel '" + name + "'";
  const std::string guess = closest_match(name, names);
  if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
  throw std::invalid_argument(msg);
}

namespace {
size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t sub = prev[j - 1] + (std::tolower(a[i - 1]) == std::tolower(b[j - 1]) ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}
}  // namespace

std::string closest_match(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_d = std::numeric_limits<size_t>::max();
  for (const auto& c : candidates) {
    const size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  // Accept a guess only when it is reasonably close: at most a third of the word's letters off.
  const size_t limit = std::max<size_t>(2, word.size() / 3);
  return best_d <= limit ? best : std::string{};
}

RunResult Simulator::run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                              const Eigen::VectorXd& from, Eigen::VectorXd* produce) {
  (void)from;
  if (produce) *produce = Eigen::VectorXd::Zero(warm_start_size());
  return run(theta);
}

std::unique_ptr<SteppableSimulator> into_steppable(std::unique_ptr<Simulator> simulator) {
  SteppableSimulator* steppable = simulator ? simulator->steppable() : nullptr;
  if (steppable == nullptr) return nullptr;
  simulator.release();
  return std::unique_ptr<SteppableSimulator>(steppable);
}

}  // namespace sigmaheart::model
