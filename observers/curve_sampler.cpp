#include "observers/curve_sampler.h"

#include "model/units.h"

#include <algorithm>
#include <stdexcept>

namespace sigmaheart::observers {
namespace {

using model::Status;
using model::StatusCode;

// SI unit of an available channel: from its unit, or from its name (V_* volume, P_* pressure)
// when the unit is empty.
std::string si_unit_of(const model::Channel& c) {
  if (!c.unit.empty()) {
    const auto conv = model::units::to_si(c.unit);
    if (!conv) {
      throw std::invalid_argument("channel '" + c.name + "' has the unknown unit '" + c.unit + "'");
    }
    return conv->si_unit;
  }
  if (c.name.rfind("V_", 0) == 0) return "m^3";
  if (c.name.rfind("P_", 0) == 0) return "Pa";
  return "1";
}

}  // namespace

std::string CurveSamplerOptions::validate() const {
  if (channels.empty()) return "curve sampler: no channel to sample";
  if (frame_times.size() == 0) return "curve sampler: no frame times";
  if (!frame_times.allFinite()) return "curve sampler: a frame time is not finite";
  for (size_t i = 0; i < channels.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (channels[i] == channels[j]) return "curve sampler: channel '" + channels[i] + "' twice";
    }
  }
  return beat.validate();
}

std::string frame_name(const std::string& channel, int frame, int frames) {
  int width = 2;
  for (int m = std::max(frames - 1, 0); m >= 100; m /= 10) ++width;
  std::string digits = std::to_string(frame);
  if (static_cast<int>(digits.size()) < width) {
    digits.insert(0, static_cast<size_t>(width) - digits.size(), '0');
  }
  return channel + "@f" + digits;
}

CurveSampler::CurveSampler(CurveSamplerOptions options,
                           const std::vector<model::Channel>& available)
    : options_(std::move(options)) {
  if (auto msg = options_.validate(); !msg.empty()) throw std::invalid_argument(msg);
  std::vector<std::string> names;
  for (const auto& c : available) names.push_back(c.name);
  auto find = [&](const std::string& name) -> const model::Channel& {
    for (const auto& c : available) {
      if (c.name == name) return c;
    }
    std::string msg = "curve sampler: no channel '" + name + "'";
    const auto guess = model::closest_match(name, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    throw std::invalid_argument(msg);
  };
  if (!options_.alignment_channel.empty()) find(options_.alignment_channel);
  const int frames = static_cast<int>(options_.frame_times.size());
  for (const auto& ch : options_.channels) {
    const std::string si = si_unit_of(find(ch));
    si_units_.push_back(si);
    for (int k = 0; k < frames; ++k) {
      outputs_.push_back({frame_name(ch, k, frames), si, ch + " at frame " + std::to_string(k)});
    }
  }
}

std::unique_ptr<Observer> CurveSampler::clone() const {
  return std::make_unique<CurveSampler>(*this);
}

// The grid of the trajectory (its own clock), the unique samples of each sampled channel (SI) and
// the frame origin: what observe() interpolates and aligned_beat() hands out.
Status CurveSampler::read_beat(const model::Trajectory& trajectory, BeatGrid& grid,
                               Eigen::MatrixXd& values, double& origin) const {
  const size_t nc = options_.channels.size();
  const bool align = !options_.alignment_channel.empty();
  Eigen::MatrixXd columns(trajectory.times.size(), static_cast<Eigen::Index>(nc + (align ? 1 : 0)));
  for (size_t c = 0; c < nc; ++c) {
    Eigen::VectorXd col;
    if (auto s = channel_in_si(trajectory, options_.channels[c], si_units_[c], col); !s.ok()) {
      return s;
    }
    if (col.size() != columns.rows()) {
      return Status::Error(StatusCode::kInvalidArgument, "curve sampler: ragged trajectory");
    }
    columns.col(static_cast<Eigen::Index>(c)) = col;
  }
  if (align) {
    Eigen::VectorXd col;
    if (auto s = channel_in_si(trajectory, options_.alignment_channel, "m^3", col); !s.ok()) {
      return s;
    }
    columns.col(static_cast<Eigen::Index>(nc)) = col;
  }
  if (auto s = make_beat_grid(trajectory.times, columns, options_.beat, grid); !s.ok()) {
    s.message = "curve sampler: " + s.message;
    return s;
  }
  origin = align ? volume_landmarks(grid, grid.unique_samples(columns.col(static_cast<Eigen::Index>(nc))),
                                    options_.beat)
                       .ed_time
                 : grid.times(0);
  values.resize(grid.samples(), static_cast<Eigen::Index>(nc));
  for (size_t c = 0; c < nc; ++c) {
    values.col(static_cast<Eigen::Index>(c)) = grid.unique_samples(columns.col(static_cast<Eigen::Index>(c)));
  }
  return Status::Ok();
}

Status CurveSampler::aligned_beat(const model::Trajectory& trajectory, AlignedBeat& out) const {
  BeatGrid grid;
  if (auto s = read_beat(trajectory, grid, out.values, out.origin); !s.ok()) return s;
  out.period = grid.periodic ? grid.period : 0.0;
  out.times = grid.times.array() - out.origin;
  return Status::Ok();
}

Status CurveSampler::observe(const model::Trajectory& trajectory,
                             Eigen::Ref<Eigen::VectorXd> z) const {
  if (auto status = check_z_size("curve sampler", z.size(), outputs_.size()); !status.ok()) {
    return status;
  }
  BeatGrid grid;
  Eigen::MatrixXd values;
  double t_ed = 0.0;
  if (auto s = read_beat(trajectory, grid, values, t_ed); !s.ok()) return s;
  const Eigen::Index frames = options_.frame_times.size();
  for (Eigen::Index c = 0; c < values.cols(); ++c) {
    const Eigen::VectorXd x = values.col(c);
    Eigen::VectorXd dxdt;
    if (options_.interpolation == Interpolation::kCubic) dxdt = derivative(grid, x);
    for (Eigen::Index k = 0; k < frames; ++k) {
      const auto value = interpolate(grid, x, &dxdt, t_ed + options_.frame_times(k),
                                     options_.interpolation);
      if (!value) {
        return Status::Error(StatusCode::kBadOutput,
                             "curve sampler: frame " + std::to_string(k) +
                                 " falls outside the non-periodic record");
      }
      z(c * frames + k) = *value;
    }
  }
  return Status::Ok();
}

}  // namespace sigmaheart::observers
