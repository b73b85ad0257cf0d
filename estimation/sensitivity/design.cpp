#include "estimation/sensitivity/design.h"

#include "estimation/enum_names.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation::sensitivity {

constexpr std::array<EnumName<StudyStatus>, 3> kStudyStatusNames{{
    {StudyStatus::kOk, "ok"}, {StudyStatus::kFailedRuns, "failed-runs"},
    {StudyStatus::kFailedNominal, "failed-nominal"},
}};
const char* to_string(StudyStatus status) { return enum_to_string(kStudyStatusNames, status); }

std::string validate_prior(const Prior& prior, const ForwardModel& model) {
  if (prior.size() == 0) return "no parameters to study";
  if (prior.size() != model.input_size()) {
    std::ostringstream s;
    s << prior.size() << " parameter ranges for a model with " << model.input_size() << " inputs";
    return s.str();
  }
  const auto names = model.input_names();
  for (int i = 0; i < prior.size(); ++i) {
    const PriorParameter& q = prior[i];
    if (q.kind != PriorKind::kUniform) {
      return "parameter '" + q.name + "': a sensitivity study samples uniform parameters";
    }
    if (const std::string m = q.validate(); !m.empty()) return m;
    const auto k = static_cast<size_t>(i);
    if (k < names.size() && !q.name.empty() && q.name != names[k]) {
      return "parameter range " + std::to_string(i) + " is named '" + q.name +
             "' but the model's input " + std::to_string(i) + " is '" + names[k] + "'";
    }
  }
  return {};
}

void check_study_inputs(const std::string& study, const Prior& prior, const ForwardModel& model,
                        const std::string& options_message) {
  if (const std::string m = validate_prior(prior, model); !m.empty()) {
    throw std::invalid_argument(study + ": " + m);
  }
  if (!options_message.empty()) throw std::invalid_argument(options_message);
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

std::vector<bool> evaluate_design(const ForwardModel& model, const EnsembleOptions& options,
                                  StudySummary& summary) {
  Ensemble ensemble(model, options);
  EnsembleResult result = ensemble.evaluate(summary.thetas);
  summary.Z = std::move(result.Z);
  const auto runs = static_cast<int>(summary.thetas.rows());
  std::vector<bool> ok(static_cast<size_t>(runs), true);
  for (int run = 0; run < runs; ++run) {
    model::Status st = result.status[static_cast<size_t>(run)];
    // The Ensemble already turns non-finite outputs into kNonFinite; kept as an invariant here so
    // that no study ever averages a NaN.
    if (st.ok() && summary.Z.row(run).allFinite()) continue;
    if (st.ok()) st = model::Status::Error(model::StatusCode::kNonFinite, "non-finite output");
    summary.Z.row(run).setConstant(std::numeric_limits<double>::quiet_NaN());
    ok[static_cast<size_t>(run)] = false;
    FailedRun f;
    f.run = run;
    f.block = summary.layout.block.at(static_cast<size_t>(run));
    f.design_row = summary.layout.row.at(static_cast<size_t>(run));
    f.theta = summary.thetas.row(run).transpose();
    f.status = std::move(st);
    summary.failed_runs.push_back(std::move(f));
  }
  return ok;
}

std::vector<int> rank_by(const Eigen::MatrixXd& score, int column) {
  std::vector<int> order(static_cast<size_t>(score.rows()));
  std::iota(order.begin(), order.end(), 0);
  auto key = [&](int i) {
    const double v = std::abs(score(i, column));
    return std::isnan(v) ? -1.0 : v;
  };
  std::stable_sort(order.begin(), order.end(), [&](int i, int j) { return key(i) > key(j); });
  return order;
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

double normal_quantile(double prob) {
  if (!(prob > 0.0 && prob < 1.0)) {
    throw std::invalid_argument("normal_quantile: probability must be in (0, 1), got " + std::to_string(prob));
  }
  // Solve the upper tail Q(x) = erfc(x / sqrt 2) / 2 = q for x >= 0, q = min(prob, 1 - prob):
  // in the tail the difference Q(x) - q keeps its relative precision. Q is convex and decreasing
  // on [0, inf), so Newton from 0 rises monotonically to the root.
  const double q = prob < 0.5 ? prob : 1.0 - prob;
  const double inv_sqrt2 = 1.0 / std::sqrt(2.0), inv_sqrt2pi = 1.0 / std::sqrt(2.0 * std::numbers::pi);
  double x = 0.0;
  for (int it = 0; it < 500; ++it) {
    const double tail = 0.5 * std::erfc(x * inv_sqrt2);
    const double density = inv_sqrt2pi * std::exp(-0.5 * x * x);
    if (!(density > 0.0)) break;
    const double step = (tail - q) / density;
    x += step;
    if (std::abs(step) <= 1e-15 * std::max(1.0, x)) break;
  }
  return prob < 0.5 ? -x : x;
}

double finite_std(const std::vector<double>& samples) {
  double mean = 0.0, m2 = 0.0;
  int n = 0;
  for (double v : samples) {  // Welford, in sample order
    if (!std::isfinite(v)) continue;
    ++n;
    const double d = v - mean;
    mean += d / n;
    m2 += d * (v - mean);
  }
  return n >= 2 ? std::sqrt(m2 / (n - 1)) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace sigmaheart::estimation::sensitivity
