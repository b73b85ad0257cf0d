#include "observers/observation_builder.h"

#include "model/units.h"

#include <Eigen/Cholesky>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::observers {
namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::string si_unit_or_throw(const std::string& unit, const std::string& what) {
  const auto conv = model::units::to_si(unit);
  if (!conv) throw std::invalid_argument(what + ": " + unknown_unit_message(unit));
  return conv->si_unit;
}

// The unit a user reads an index in, given the units of the curves it came from.
std::string index_display_unit(const std::string& index, const std::string& si_unit,
                               const std::string& volume_unit, const std::string& pressure_unit) {
  auto known = [](const std::string& u) { return model::units::to_si(u).has_value(); };
  if (index == "EF") return "%";
  if (si_unit == "s") return "ms";
  if (si_unit == "m^3") return volume_unit.empty() ? si_unit : volume_unit;
  if (si_unit == "Pa") return pressure_unit.empty() ? si_unit : pressure_unit;
  if (si_unit == "m^3/s" && !volume_unit.empty() && known(volume_unit + "/s")) return volume_unit + "/s";
  if (si_unit == "Pa/s" && !pressure_unit.empty() && known(pressure_unit + "/s")) return pressure_unit + "/s";
  return si_unit;
}

std::string display_unit_of(const model::Trajectory& t, const std::vector<std::string>& display,
                            const std::string& channel) {
  const auto idx = t.channel_index(channel);
  if (!idx) return {};
  if (display.size() == t.channels.size()) return display[static_cast<size_t>(*idx)];
  return t.channels[static_cast<size_t>(*idx)].unit;
}

void fill_noise(ObservationSet& set, const NoiseModel& noise) {
  const Eigen::Index m = set.size();
  set.R = Eigen::MatrixXd::Zero(m, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    const auto& name = set.names[static_cast<size_t>(i)];
    const double sd = noise_std_si(noise.for_name(name), name, set.y(i), set.units[static_cast<size_t>(i)]);
    set.R(i, i) = sd * sd;
  }
}

}  // namespace

const std::vector<std::string>& known_units() {
  static const std::vector<std::string> list = [] {
    const std::vector<std::string> candidates = {
        "m^3", "L", "l", "mL", "ml", "cm^3", "Pa", "kPa", "mmHg", "s", "ms", "m^3/s", "mL/s",
        "ml/s", "L/min", "Pa/s", "kPa/s", "mmHg/s", "1/s", "Hz", "s^-1", "m", "mm", "cm",
        "1", "-", "%"};
    std::vector<std::string> out;
    for (const auto& c : candidates) {
      if (model::units::to_si(c)) out.push_back(c);
    }
    return out;
  }();
  return list;
}

std::string unknown_unit_message(const std::string& unit) {
  std::string msg = "unknown unit '" + unit + "'";
  const auto guess = model::closest_match(unit, known_units());
  if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
  msg += "; known units: ";
  for (size_t i = 0; i < known_units().size(); ++i) msg += (i ? ", " : "") + known_units()[i];
  return msg;
}

std::string Noise::describe() const {
  std::ostringstream s;
  s << value << (kind == Kind::kRelative ? " %" : (unit.empty() ? "" : " " + unit));
  return s.str();
}

Noise parse_noise(const std::string& text) {
  const std::string t = trim(text);
  const char* begin = t.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end == begin) {
    throw std::invalid_argument("noise '" + text + "': expected a number and a unit, e.g. '5 mL' or '10 %'");
  }
  if (!std::isfinite(v) || !(v > 0.0)) {
    throw std::invalid_argument("noise '" + text + "': expected a positive finite number");
  }
  const std::string unit = trim(std::string(end));
  if (unit == "%") return Noise::relative(v);
  si_unit_or_throw(unit, "noise '" + text + "'");
  return Noise::absolute(v, unit);
}

double noise_std_si(const Noise& noise, const std::string& name, double value_si,
                    const std::string& si_unit) {
  double sd = 0.0;
  if (noise.kind == Noise::Kind::kRelative) {
    sd = noise.value / 100.0 * std::abs(value_si);
    if (!(sd > 0.0) || !std::isfinite(sd)) {
      throw std::invalid_argument("observation '" + name + "': relative noise " + noise.describe() +
                                  " of a zero value is zero; give an absolute noise with a unit");
    }
    return sd;
  }
  const auto conv = model::units::to_si(noise.unit);
  if (!conv) {
    throw std::invalid_argument("observation '" + name + "': noise " +
                                unknown_unit_message(noise.unit));
  }
  if (conv->si_unit != si_unit) {
    throw std::invalid_argument("observation '" + name + "' is in " + si_unit + " but its noise " +
                                noise.describe() + " is in " + conv->si_unit);
  }
  sd = noise.value * conv->factor;
  if (!(sd > 0.0) || !std::isfinite(sd)) {
    throw std::invalid_argument("observation '" + name + "': noise " + noise.describe() +
                                " must be positive and finite");
  }
  return sd;
}

const Noise& NoiseModel::for_name(const std::string& name) const {
  if (auto it = by_name.find(name); it != by_name.end()) return it->second;
  if (const auto at = name.find("@f"); at != std::string::npos) {
    if (auto it = by_name.find(name.substr(0, at)); it != by_name.end()) return it->second;
  }
  if (fallback) return *fallback;
  throw std::invalid_argument("no noise given for observation '" + name + "'");
}

ObservationSet observations_from_entries(const std::vector<ObservationEntry>& entries,
                                         const std::vector<model::Channel>& expected_in) {
  const auto& expected = expected_in.empty() ? GlobalIndices::catalog() : expected_in;
  std::vector<std::string> expected_names;
  for (const auto& c : expected) expected_names.push_back(c.name);

  ObservationSet set;
  const auto m = static_cast<Eigen::Index>(entries.size());
  set.y.resize(m);
  set.R = Eigen::MatrixXd::Zero(m, m);
  std::set<std::string> seen;
  for (Eigen::Index i = 0; i < m; ++i) {
    const auto& e = entries[static_cast<size_t>(i)];
    const model::Channel* want = nullptr;
    for (const auto& c : expected) {
      if (c.name == e.name) want = &c;
    }
    if (want == nullptr) {
      std::string msg = "unknown observation '" + e.name + "'";
      const auto guess = model::closest_match(e.name, expected_names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      throw std::invalid_argument(msg);
    }
    if (!seen.insert(e.name).second) {
      throw std::invalid_argument("observation '" + e.name + "' is given twice");
    }
    const auto conv = model::units::to_si(e.unit);
    if (!conv) {
      throw std::invalid_argument("observation '" + e.name + "': " + unknown_unit_message(e.unit));
    }
    if (conv->si_unit != want->unit) {
      throw std::invalid_argument("observation '" + e.name + "' is in " + want->unit +
                                  ", but its unit '" + e.unit + "' measures " + conv->si_unit);
    }
    if (!std::isfinite(e.value)) {
      throw std::invalid_argument("observation '" + e.name + "' is not a finite number");
    }
    set.names.push_back(e.name);
    set.units.push_back(want->unit);
    set.display_units.push_back(e.unit);
    set.y(i) = e.value * conv->factor;
    const double sd = noise_std_si(e.noise, e.name, set.y(i), want->unit);
    set.R(i, i) = sd * sd;
  }
  if (auto msg = set.validate(); !msg.empty()) throw std::invalid_argument(msg);
  return set;
}

ObservationSet observations_from_indices(const model::Trajectory& measured,
                                         const GlobalIndicesOptions& options,
                                         const NoiseModel& noise,
                                         const std::vector<std::string>& display_units,
                                         const BeatOptions& measured_beat) {
  GlobalIndicesOptions measured_options = options;
  measured_options.beat = measured_beat;
  const GlobalIndices observer(measured_options, measured.channels);
  Eigen::VectorXd z(observer.size());
  if (auto s = observer.observe(measured, z); !s.ok()) {
    throw std::invalid_argument("measured curves: " + s.message);
  }
  const auto& opt = observer.options();
  const std::string vol = display_unit_of(measured, display_units, opt.volume_channel);
  const std::string pre = display_unit_of(measured, display_units, opt.pressure_channel);
  ObservationSet set;
  set.y = z;
  for (const auto& out : observer.outputs()) {
    set.names.push_back(out.name);
    set.units.push_back(out.unit);
    set.display_units.push_back(index_display_unit(out.name, out.unit, vol, pre));
  }
  set.frame_times = measured.times;
  fill_noise(set, noise);
  if (auto msg = set.validate(); !msg.empty()) throw std::invalid_argument(msg);
  return set;
}

CurveObservations observations_from_curves(const model::Trajectory& measured,
                                           const MeasuredCurveOptions& options,
                                           const NoiseModel& noise,
                                           const std::vector<std::string>& display_units) {
  if (options.channels.empty()) throw std::invalid_argument("measured curves: no channel chosen");
  const bool align = !options.alignment_channel.empty();
  const size_t nc = options.channels.size();
  Eigen::MatrixXd columns(measured.times.size(), static_cast<Eigen::Index>(nc + (align ? 1 : 0)));
  std::vector<std::string> si_units;
  auto load = [&](const std::string& name, Eigen::Index col) {
    const auto idx = measured.channel_index(name);
    std::string si = name.rfind("V_", 0) == 0 ? "m^3" : name.rfind("P_", 0) == 0 ? "Pa" : "1";
    if (idx && !measured.channels[static_cast<size_t>(*idx)].unit.empty()) {
      si = si_unit_or_throw(measured.channels[static_cast<size_t>(*idx)].unit,
                            "measured channel '" + name + "'");
    }
    Eigen::VectorXd x;
    if (auto s = channel_in_si(measured, name, si, x); !s.ok()) {
      throw std::invalid_argument("measured curves: " + s.message);
    }
    columns.col(col) = x;
    return si;
  };
  for (size_t c = 0; c < nc; ++c) si_units.push_back(load(options.channels[c], static_cast<Eigen::Index>(c)));
  if (align) load(options.alignment_channel, static_cast<Eigen::Index>(nc));

  BeatGrid grid;
  if (auto s = make_beat_grid(measured.times, columns, options.beat, grid); !s.ok()) {
    throw std::invalid_argument("measured curves: " + s.message);
  }
  const int n = grid.samples();
  long k0 = 0;
  // Without alignment the frames keep the times the file gives (times after the ECG trigger,
  // i.e. after the beat's electrical onset, as cine-MRI headers give them); the sampler then
  // reads the simulated beat at the same times after its own onset (t = 0).
  double t_ed = 0.0;
  if (align) {
    t_ed = volume_landmarks(grid, grid.unique_samples(columns.col(static_cast<Eigen::Index>(nc))),
                            options.beat)
               .ed_time;
    if (grid.periodic) {
      t_ed = grid.wrap(t_ed);
      // Frame 0: the sample nearest to ED (the last sample is nearest when ED lies just before
      // the first sample plus a period).
      double best = std::numeric_limits<double>::infinity();
      for (long k = 0; k <= n; ++k) {
        const double d = std::abs(grid.time(k) - t_ed);
        if (d < best) {
          best = d;
          k0 = k % n;
          if (k == n) t_ed -= grid.period;  // keep frame_times(0) = time(0) - t_ed small
        }
      }
    }
  }
  Eigen::VectorXd frame_times(n);
  for (int j = 0; j < n; ++j) {
    frame_times(j) = grid.time(k0 + j) - t_ed;
  }

  CurveObservations out;
  ObservationSet& set = out.observations;
  set.y.resize(static_cast<Eigen::Index>(nc) * n);
  for (size_t c = 0; c < nc; ++c) {
    const std::string shown = display_unit_of(measured, display_units, options.channels[c]);
    for (int j = 0; j < n; ++j) {
      const long k = (k0 + j) % n;
      set.names.push_back(frame_name(options.channels[c], j, n));
      set.units.push_back(si_units[c]);
      set.display_units.push_back(shown.empty() ? si_units[c] : shown);
      set.y(static_cast<Eigen::Index>(c) * n + j) = columns(k, static_cast<Eigen::Index>(c));
    }
  }
  set.frame_times = frame_times;
  fill_noise(set, noise);
  if (auto msg = set.validate(); !msg.empty()) throw std::invalid_argument(msg);

  out.frame_origin = t_ed;
  out.sampler.channels = options.channels;
  out.sampler.frame_times = frame_times;
  out.sampler.alignment_channel = options.alignment_channel;
  out.sampler.interpolation = options.interpolation;
  out.sampler.beat.refine_extrema = options.beat.refine_extrema;
  out.sampler.beat.plateau_tolerance = options.beat.plateau_tolerance;
  return out;
}

void set_covariance(ObservationSet& set, const Eigen::Ref<const Eigen::MatrixXd>& R,
                    const std::vector<std::string>& units) {
  const Eigen::Index m = set.size();
  if (R.rows() != m || R.cols() != m || static_cast<Eigen::Index>(units.size()) != m) {
    std::ostringstream s;
    s << "covariance: expected a " << m << " x " << m << " matrix and " << m << " units, got "
      << R.rows() << " x " << R.cols() << " and " << units.size();
    throw std::invalid_argument(s.str());
  }
  Eigen::VectorXd f(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    const auto& name = set.names[static_cast<size_t>(i)];
    const auto conv = model::units::to_si(units[static_cast<size_t>(i)]);
    if (!conv) {
      throw std::invalid_argument("covariance of '" + name + "': " +
                                  unknown_unit_message(units[static_cast<size_t>(i)]));
    }
    if (conv->si_unit != set.units[static_cast<size_t>(i)]) {
      throw std::invalid_argument("covariance of '" + name + "': unit '" +
                                  units[static_cast<size_t>(i)] + "' does not measure " +
                                  set.units[static_cast<size_t>(i)]);
    }
    f(i) = conv->factor;
  }
  ObservationSet candidate = set;
  candidate.R = f.asDiagonal() * R * f.asDiagonal();
  if (auto msg = candidate.validate(); !msg.empty()) throw std::invalid_argument(msg);
  set.R = candidate.R;
}

std::string check_consistent(const Observer& observer, const ObservationSet& set) {
  const auto outs = observer.outputs();
  if (auto msg = set.validate(); !msg.empty()) return msg;
  if (static_cast<Eigen::Index>(outs.size()) != set.size()) {
    return "the observer gives " + std::to_string(outs.size()) + " values but " +
           std::to_string(set.size()) + " are observed";
  }
  for (size_t i = 0; i < outs.size(); ++i) {
    if (outs[i].name != set.names[i]) {
      return "entry " + std::to_string(i) + ": the observer gives '" + outs[i].name +
             "' where '" + set.names[i] + "' is observed";
    }
    if (outs[i].unit != set.units[i]) {
      return "observation '" + set.names[i] + "': the observer gives " + outs[i].unit +
             ", the data are in " + set.units[i];
    }
  }
  return {};
}

ObservationSet concatenate(const std::vector<ObservationSet>& sets) {
  ObservationSet out;
  Eigen::Index m = 0;
  for (const auto& s : sets) m += s.size();
  out.y.resize(m);
  out.R = Eigen::MatrixXd::Zero(m, m);
  std::set<std::string> seen;
  Eigen::Index at = 0;
  for (const auto& s : sets) {
    if (auto msg = s.validate(); !msg.empty()) throw std::invalid_argument(msg);
    for (Eigen::Index i = 0; i < s.size(); ++i) {
      const auto& name = s.names[static_cast<size_t>(i)];
      if (!seen.insert(name).second) {
        throw std::invalid_argument("observation '" + name + "' appears in two sets");
      }
      out.names.push_back(name);
      out.units.push_back(s.units[static_cast<size_t>(i)]);
      out.display_units.push_back(s.display_units.size() == s.names.size()
                                      ? s.display_units[static_cast<size_t>(i)]
                                      : s.units[static_cast<size_t>(i)]);
    }
    out.y.segment(at, s.size()) = s.y;
    out.R.block(at, at, s.size(), s.size()) = s.R;
    if (out.frame_times.size() == 0) out.frame_times = s.frame_times;
    at += s.size();
  }
  return out;
}

}  // namespace sigmaheart::observers
