#include "model/zoned_simulator.h"

#include <algorithm>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model {

ParameterSpace ZonedSimulator::zoned_space(const ParameterSpace& in, const std::vector<ParameterZone>& zones,
                                           std::vector<int>* source) {
  std::vector<int> zone_of(static_cast<size_t>(in.size()), -1);
  for (size_t z = 0; z < zones.size(); ++z) {
    const ParameterZone& zone = zones[z];
    if (zone.members.empty()) throw std::invalid_argument("zone '" + zone.name + "' has no members");
    if (in.index(zone.name)) throw std::invalid_argument("zone name '" + zone.name + "' is already a parameter name");
    for (size_t y = 0; y < z; ++y)
      if (zones[y].name == zone.name) throw std::invalid_argument("zone name '" + zone.name + "' is used twice");
    for (int m : zone.members) {
      if (m < 0 || m >= in.size()) throw std::invalid_argument("zone '" + zone.name + "': member index out of range");
      if (zone_of[static_cast<size_t>(m)] >= 0) {
        throw std::invalid_argument("parameter '" + in[m].name + "' is in zones '" +
                                    zones[static_cast<size_t>(zone_of[static_cast<size_t>(m)])].name + "' and '" +
                                    zone.name + "'");
      }
      const Parameter& first = in[zone.members.front()];
      if (in[m].unit != first.unit) {
        throw std::invalid_argument("zone '" + zone.name + "' mixes units (" + in[m].name + " [" + in[m].unit +
                                    "], " + first.name + " [" + first.unit + "])");
      }
      zone_of[static_cast<size_t>(m)] = static_cast<int>(z);
    }
  }
  std::vector<Parameter> params;
  std::vector<int> src(static_cast<size_t>(in.size()), -1);
  for (int i = 0; i < in.size(); ++i) {
    if (zone_of[static_cast<size_t>(i)] >= 0) continue;
    src[static_cast<size_t>(i)] = static_cast<int>(params.size());
    params.push_back(in[i]);
  }
  for (const ParameterZone& zone : zones) {
    Parameter p = in[zone.members.front()];
    p.name = zone.name;
    p.segment = 0;
    double sum = 0.0;
    std::ostringstream doc;
    doc << "one value for";
    for (int m : zone.members) {
      p.lower = std::max(p.lower, in[m].lower);
      p.upper = std::min(p.upper, in[m].upper);
      sum += in[m].nominal;
      doc << ' ' << in[m].name;
      src[static_cast<size_t>(m)] = static_cast<int>(params.size());
    }
    if (!(p.lower <= p.upper)) throw std::invalid_argument("zone '" + zone.name + "': the members' bounds do not overlap");
    p.nominal = std::clamp(sum / static_cast<double>(zone.members.size()), p.lower, p.upper);
    p.doc = doc.str() + " (zone of the " + in[zone.members.front()].family + " family)";
    params.push_back(std::move(p));
  }
  if (source) *source = std::move(src);
  return ParameterSpace(std::move(params));
}

ZonedSimulator::ZonedSimulator(std::unique_ptr<SteppableSimulator> inner, std::vector<ParameterZone> zones)
    : WrappedSimulator(std::move(inner), "ZonedSimulator"), zones_(std::move(zones)) {
  space_ = zoned_space(inner_->parameters(), zones_, &source_);
}

Eigen::VectorXd ZonedSimulator::expand(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  if (theta.size() != space_.size()) {
    // The inner simulator reports the size mismatch in its own words.
    return Eigen::VectorXd::Constant(inner_->parameters().size(), std::numeric_limits<double>::quiet_NaN());
  }
  Eigen::VectorXd out(static_cast<Eigen::Index>(source_.size()));
  for (size_t i = 0; i < source_.size(); ++i) out(static_cast<Eigen::Index>(i)) = theta(source_[i]);
  return out;
}

RunResult ZonedSimulator::run(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  if (theta.size() != space_.size()) {
    RunResult r;
    r.trajectory.channels = channels();
    r.status = Status::Error(StatusCode::kInvalidArgument, "theta has " + std::to_string(theta.size()) +
                                                               " entries, expected " + std::to_string(space_.size()));
    return r;
  }
  return inner_->run(expand(theta));
}

State ZonedSimulator::initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) {
  return inner_->initial_state(expand(theta));
}

Status ZonedSimulator::advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end) {
  if (theta.size() != space_.size()) {
    return Status::Error(StatusCode::kInvalidArgument, "theta has " + std::to_string(theta.size()) +
                                                           " entries, expected " + std::to_string(space_.size()));
  }
  return inner_->advance(state, expand(theta), t_end);
}

Eigen::VectorXd ZonedSimulator::sample(const State& state, const Eigen::Ref<const Eigen::VectorXd>& theta) const {
  return inner_->sample(state, expand(theta));
}

}  // namespace sigmaheart::model
