// `sigmaheart synthesize CONFIG -o OUT.csv`: measurement-like curves from a simulation, for twin
// experiments and the bundled synthetic cohort. The periodic beat of the configured simulator is
// sampled at `--frames` equally spaced frames (cine MRI gives about 30 per beat), starting
// `--offset` after the beat start, and Gaussian noise of a given standard deviation is added per
// channel. The CSV has the observation-file format (app/io/observation_file.h) and its comment
// lines record the config, the overrides, the seed and the noise, so the file documents itself.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/observation_file.h"
#include "app/io/results.h"
#include "model/units.h"

#include <cmath>
#include <cstdint>
#include <random>
#include <sstream>

namespace sigmaheart::app {

namespace {

struct SynthesizeOptions {
  std::filesystem::path config;
  std::filesystem::path output;
  int frames = 30;
  double offset_ms = 0.0;
  std::vector<std::string> channels = {"V_lv", "P_lv"};
  std::vector<std::string> noise;  // "V_lv=2 mL"
  std::uint64_t seed = 1;
  std::vector<std::string> overrides;
};

// Standard normal deviates from a 64-bit Mersenne twister by Box-Muller, written out so the
// numbers are the same with any standard library (std::normal_distribution is not specified
// bit-for-bit). One stream per (seed, channel).
class Normal {
 public:
  Normal(std::uint64_t seed, std::uint64_t stream)
      : engine_(seed * 0x9E3779B97F4A7C15ULL + stream * 0xBF58476D1CE4E5B9ULL + 1) {}
  double operator()() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    const double u1 = uniform_open();
    const double u2 = uniform_open();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    have_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  double uniform_open() {  // in (0, 1)
    return (static_cast<double>(engine_() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  }
  std::mt19937_64 engine_;
  bool have_spare_ = false;
  double spare_ = 0.0;
};

double interpolate_periodic(const Eigen::VectorXd& t, const Eigen::VectorXd& x, double period,
                            double at) {
  const double t0 = t(0);
  double s = std::fmod(at - t0, period);
  if (s < 0) s += period;
  s += t0;
  const Eigen::Index n = t.size();
  if (s >= t(n - 1)) {  // between the last sample and the first of the next beat
    const double span = t0 + period - t(n - 1);
    const double w = span > 0 ? (s - t(n - 1)) / span : 0.0;
    return (1 - w) * x(n - 1) + w * x(0);
  }
  Eigen::Index k = static_cast<Eigen::Index>(std::upper_bound(t.data(), t.data() + n, s) - t.data()) - 1;
  k = std::clamp<Eigen::Index>(k, 0, n - 2);
  const double w = (s - t(k)) / (t(k + 1) - t(k));
  return (1 - w) * x(k) + w * x(k + 1);
}

constexpr int kMaxFrames = 100000;  // a 1 s beat at 10 us: far beyond any measurement

int run_synthesize(const SynthesizeOptions& o, CommandContext& ctx) {
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  // Frames are interpolated from the simulated beat: more than one per output sample adds
  // nothing, and 2e9 of them ran out of memory (issue 12).
  if (o.frames < 3 || o.frames > kMaxFrames) {
    throw InputError(Location{"--frames"}, "expected 3 to " + std::to_string(kMaxFrames) +
                                               " frames per beat (cine MRI gives about 30), got " +
                                               std::to_string(o.frames));
  }
  auto simulator = config.simulator.make();
  const auto sim_channels = simulator->channels();

  // Noise per channel, in the channel's display unit.
  std::vector<double> noise_si(o.channels.size(), 0.0);
  std::vector<std::string> display(o.channels.size());
  std::vector<std::string> si_units(o.channels.size());
  for (size_t c = 0; c < o.channels.size(); ++c) {
    bool found = false;
    for (const auto& ch : sim_channels) {
      if (ch.name == o.channels[c]) {
        found = true;
        si_units[c] = ch.unit;
        display[c] = io::display_unit(ch.unit).unit;
      }
    }
    if (!found) {
      std::vector<std::string> names;
      for (const auto& ch : sim_channels) names.push_back(ch.name);
      std::string msg = "model " + simulator->name() + " has no channel '" + o.channels[c] + "'";
      const auto guess = model::closest_match(o.channels[c], names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      throw InputError(Location{"--channels"}, msg);
    }
  }
  for (const auto& spec : o.noise) {
    const auto eq = spec.find('=');
    const Location where{"--noise " + spec};
    if (eq == std::string::npos) throw InputError(where, "expected CHANNEL=STD UNIT, e.g. V_lv='2 mL'");
    const std::string name = spec.substr(0, eq);
    std::istringstream in(spec.substr(eq + 1));
    double value = 0;
    std::string unit;
    if (!(in >> value) || value < 0) throw InputError(where, "expected a non-negative standard deviation");
    in >> unit;
    size_t c = 0;
    while (c < o.channels.size() && o.channels[c] != name) ++c;
    if (c == o.channels.size()) throw InputError(where, "channel '" + name + "' is not in --channels");
    try {
      noise_si[c] = unit.empty() ? value : model::units::convert(value, unit, si_units[c]);
    } catch (const std::invalid_argument& e) {
      throw InputError(where, e.what());
    }
  }

  const model::RunResult run = simulator->run(config.simulator.parameters.nominal());
  if (!run.status.ok()) {
    throw RunFailure("simulation failed (" + std::string(model::to_string(run.status.code)) + "): " +
                     run.status.message);
  }
  const auto& tr = run.trajectory;
  const double period = run.info.period > 0 ? run.info.period
                                            : tr.times(tr.samples() - 1) - tr.times(0);
  model::Trajectory out;
  out.times.resize(o.frames);
  out.values.resize(o.frames, static_cast<Eigen::Index>(o.channels.size()));
  // Frame times are times after the beat's electrical onset (the ECG trigger), as a gated cine
  // acquisition records them: the first frame comes `offset` after the trigger.
  for (int k = 0; k < o.frames; ++k) out.times(k) = o.offset_ms * 1e-3 + period * k / o.frames;
  for (size_t c = 0; c < o.channels.size(); ++c) {
    out.channels.push_back({o.channels[c], si_units[c], ""});
    const Eigen::VectorXd x = tr.channel(o.channels[c]);
    Normal normal(o.seed, c);
    for (int k = 0; k < o.frames; ++k) {
      const double t = tr.times(0) + out.times(k);
      out.values(k, static_cast<Eigen::Index>(c)) =
          interpolate_periodic(tr.times, x, period, t) + noise_si[c] * normal();
    }
  }

  std::vector<std::string> comment = {
      "synthetic observation curves made by sigmaheart " + io::version() + " (" + io::git_describe() + ")",
      "config: " + config.file.file() + " ('" + config.name + "', model " + simulator->name() + ")",
      "frames: " + std::to_string(o.frames) + " per beat of " + std::to_string(period) +
          " s, offset " + std::to_string(o.offset_ms) + " ms; seed " + std::to_string(o.seed)};
  for (const auto& s : config.file.overrides()) comment.push_back("override: " + s);
  for (size_t c = 0; c < o.channels.size(); ++c) {
    std::ostringstream s;
    s << "noise " << o.channels[c] << ": Gaussian, std "
      << noise_si[c] * io::display_unit(si_units[c]).from_si << " " << display[c];
    comment.push_back(s.str());
  }
  io::write_observation_csv(o.output, out, "ms", display, comment);
  ctx.out << "wrote " << o.output.string() << " (" << o.frames << " frames, "
          << o.channels.size() << " channels)\n";
  return kExitOk;
}

}  // namespace

void register_synthesize(CLI::App& app, CommandContext& ctx) {
  auto [sub, opts] = add_config_command(
      app, ctx, "synthesize", "Sample a simulated beat at image frames with noise (twin experiments, test data)",
      run_synthesize);
  sub->add_option("-o,--output", opts->output, "Observation CSV to write")->required();
  sub->add_option("--frames", opts->frames, "Frames per beat")->capture_default_str();
  sub->add_option("--offset", opts->offset_ms, "Time of frame 0 after the beat start [ms]")
      ->capture_default_str();
  sub->add_option("--channels", opts->channels, "Channels to sample")->delimiter(',')
      ->capture_default_str();
  sub->add_option("--noise", opts->noise, "Noise std per channel, e.g. --noise 'V_lv=2 mL'");
  sub->add_option("--seed", opts->seed, "Seed of the noise")->capture_default_str();
}

}  // namespace sigmaheart::app
