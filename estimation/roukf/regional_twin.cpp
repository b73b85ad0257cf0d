#include "estimation/roukf/regional_twin.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::estimation {
namespace {

// Standard normal numbers by Box-Muller on mt19937_64 (std::normal_distribution differs between
// standard libraries; this stream does not).
class Normal {
 public:
  explicit Normal(std::uint64_t seed) : engine_(seed) {}
  double operator()() {
    const double u1 = (static_cast<double>(engine_() >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = (static_cast<double>(engine_() >> 11) + 0.5) * 0x1.0p-53;
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

model::State periodic_state(model::lumped::RegionalVentricle& sim, const Eigen::VectorXd& theta,
                            int beats, double period, const char* who) {
  model::State s = sim.initial_state(theta);
  const model::Status st = sim.advance(s, theta, beats * period);
  if (!st.ok()) throw std::runtime_error(std::string("regional twin: the ") + who + " failed: " + st.message);
  return s;
}

}  // namespace

std::string RegionalTwinOptions::validate() const {
  if (const std::string e = model.validate(); !e.empty()) return "model: " + e;
  const int n = model.patches();
  for (int s : infarct_segments) {
    if (s < 1 || s > n) return "infarct_segments must lie in 1.." + std::to_string(n);
  }
  if (!(infarct_fraction > 0.0)) return "infarct_fraction must be positive";
  if (frames_per_beat < 2) return "frames_per_beat must be >= 2";
  if (!(noise_std > 0.0)) return "noise_std must be positive";
  if (warmup_beats < 1 || beats < 1) return "warmup_beats and beats must be >= 1";
  if (!(prior_std_eta > 0.0)) return "prior_std_eta must be positive";
  if (!(r_factor > 0.0)) return "r_factor must be positive";
  if (!(forgetting > 0.0 && forgetting <= 1.0)) return "forgetting must lie in (0, 1]";
  return {};
}

RegionalTwin make_regional_twin(const model::lumped::RegionalVentricle& model,
                                const RegionalTwinOptions& o) {
  if (const std::string e = o.validate(); !e.empty()) {
    throw std::invalid_argument("regional twin: " + e);
  }
  model::lumped::RegionalVentricle sim = model;
  const model::ParameterSpace& space = sim.parameters();
  const Eigen::VectorXd nominal = space.nominal();
  const std::optional<int> period_index = space.find("period");
  const std::vector<int> sigma0 = space.regional("contractility");
  const int n = sim.options().patches();
  if (!period_index || static_cast<int>(sigma0.size()) != n) {
    throw std::invalid_argument("regional twin: the model needs a 'period' parameter and one "
                                "'contractility' parameter per patch (tags)");
  }
  const double period = nominal(*period_index);

  RegionalTwin twin;
  twin.nominal_sigma0 = nominal(sigma0.front());
  twin.truth_theta = nominal;
  for (int s : o.infarct_segments) twin.truth_theta(sigma0[static_cast<size_t>(s - 1)]) *= o.infarct_fraction;
  twin.truth_sigma0.resize(n);
  for (int s = 1; s <= n; ++s) twin.truth_sigma0(s - 1) = twin.truth_theta(sigma0[static_cast<size_t>(s - 1)]);

  // Truth: periodic beat, regional volumes at the frames, Gaussian noise.
  twin.truth_periodic = periodic_state(sim, twin.truth_theta, o.warmup_beats, period, "truth");
  const auto channels = sim.channels();
  std::vector<int> seg_channels(static_cast<size_t>(n), -1);
  for (size_t c = 0; c < channels.size(); ++c) {
    const int s = channels[c].segment;
    if (channels[c].family == "regional_volume" && s >= 1 && s <= n) seg_channels[static_cast<size_t>(s - 1)] = static_cast<int>(c);
  }
  for (int c : seg_channels) {
    if (c < 0) throw std::invalid_argument("regional twin: the model lacks a 'regional_volume' channel");
    twin.data.channels.push_back(channels[static_cast<size_t>(c)].name);
  }
  const int F = o.frames_per_beat;
  twin.data.times.resize(F);
  twin.data.values.resize(F, n);
  Normal normal(o.seed);
  model::State s = twin.truth_periodic;
  for (int k = 0; k < F; ++k) {
    twin.data.times(k) = period * (o.warmup_beats + static_cast<double>(k + 1) / F);
    const model::Status st = sim.advance(s, twin.truth_theta, twin.data.times(k));
    if (!st.ok()) throw std::runtime_error("regional twin: the truth failed: " + st.message);
    const Eigen::VectorXd z = sim.sample(s, twin.truth_theta);
    for (int c = 0; c < n; ++c) twin.data.values(k, c) = z(seg_channels[static_cast<size_t>(c)]) + o.noise_std * normal();
  }

  // Filter: uniform prior contractility, log transform. Every member starts from the model's
  // initial state for its own parameters and is spun up over the warm-up beats by the first
  // prediction, so that the ensemble carries how the periodic state depends on sigma0.
  RoukfOptions& f = twin.filter;
  for (int i : sigma0) {
    const model::Parameter& q = space[i];
    twin.prior.parameters.push_back(PriorParameter::gaussian(
        q.name, q.unit, twin.nominal_sigma0, o.prior_std_eta, SpreadKind::kEta,
        Transform{TransformKind::kLog, twin.nominal_sigma0}, 0.0));
  }
  f.truth = twin.truth_sigma0;
  f.R = Eigen::MatrixXd::Identity(n, n) * std::pow(o.r_factor * o.noise_std, 2);
  f.forgetting = o.forgetting;
  f.tempering = o.tempering;
  f.sigma_scale = o.sigma_scale;
  f.pass_mode = o.pass_mode;
  f.first_fraction = o.first_fraction;
  f.beats = o.beats;
  f.period = period;
  f.base_theta = nominal;
  f.initial_state_per_member = true;
  f.refine = refine_by_time_step;
  return twin;
}

Eigen::MatrixXd per_beat_relative_errors(const RoukfSummary& summary,
                                         const Eigen::VectorXd& truth_sigma0) {
  int beats = 0;
  for (const auto& st : summary.steps) beats = std::max(beats, st.beat + 1);
  return pass_errors_percent(summary, truth_sigma0, beats) / 100.0;
}

}  // namespace sigmaheart::estimation
