#include "observers/global_indices.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::observers {
namespace {

using model::Status;
using model::StatusCode;

enum class Needs { kVolume, kPressure, kArterial };

struct IndexDef {
  model::Channel channel;
  Needs needs;
};

const std::vector<IndexDef>& definitions() {
  static const std::vector<IndexDef> defs = {
      {{"EDV", "m^3", "end-diastolic volume: maximum of V_lv"}, Needs::kVolume},
      {{"ESV", "m^3", "end-systolic volume: minimum of V_lv"}, Needs::kVolume},
      {{"EF", "1", "ejection fraction (EDV - ESV) / EDV, a fraction"}, Needs::kVolume},
      {{"SV", "m^3", "stroke volume EDV - ESV"}, Needs::kVolume},
      {{"dVdt_min", "m^3/s", "peak ejection flow: minimum of dV_lv/dt (negative)"}, Needs::kVolume},
      {{"dVdt_max", "m^3/s", "peak filling flow: maximum of dV_lv/dt"}, Needs::kVolume},
      {{"t_ES", "s", "time of end-systole (end of ejection) after end-diastole (onset of the ED plateau)"}, Needs::kVolume},
      {{"ejection_duration", "s",
        "duration of ejection: V falling from EDV - eps SV to ESV + eps SV"},
       Needs::kVolume},
      {{"P_max", "Pa", "peak LV pressure: maximum of P_lv"}, Needs::kPressure},
      {{"dPdt_max", "Pa/s", "maximum of dP_lv/dt"}, Needs::kPressure},
      {{"dPdt_min", "Pa/s", "minimum of dP_lv/dt"}, Needs::kPressure},
      {{"EDP", "Pa", "end-diastolic pressure: P_lv at end-diastole (onset of the ED plateau)"}, Needs::kPressure},
      {{"P_ar_sys", "Pa", "arterial systolic pressure: maximum of P_ar"}, Needs::kArterial},
      {{"P_ar_dia", "Pa", "arterial diastolic pressure: minimum of P_ar"}, Needs::kArterial},
  };
  return defs;
}

bool has(const std::vector<model::Channel>& channels, const std::string& name) {
  return std::any_of(channels.begin(), channels.end(),
                     [&](const model::Channel& c) { return c.name == name; });
}

}  // namespace

std::string GlobalIndicesOptions::validate() const {
  if (volume_channel.empty()) return "global indices: volume_channel must not be empty";
  return beat.validate();
}

const std::vector<model::Channel>& GlobalIndices::catalog() {
  static const std::vector<model::Channel> list = [] {
    std::vector<model::Channel> out;
    for (const auto& d : definitions()) out.push_back(d.channel);
    return out;
  }();
  return list;
}

GlobalIndices::GlobalIndices(GlobalIndicesOptions options,
                             const std::vector<model::Channel>& available)
    : options_(std::move(options)) {
  if (auto msg = options_.validate(); !msg.empty()) throw std::invalid_argument(msg);
  auto channel_of = [&](Needs n) -> const std::string& {
    switch (n) {
      case Needs::kPressure: return options_.pressure_channel;
      case Needs::kArterial: return options_.arterial_channel;
      case Needs::kVolume: break;
    }
    return options_.volume_channel;
  };
  if (!has(available, options_.volume_channel)) {
    throw std::invalid_argument("global indices need the volume channel '" +
                                options_.volume_channel + "', which the trajectory lacks");
  }
  std::vector<std::string> names;
  for (const auto& d : definitions()) names.push_back(d.channel.name);

  if (options_.indices.empty()) {
    for (const auto& d : definitions()) {
      if (has(available, channel_of(d.needs))) options_.indices.push_back(d.channel.name);
    }
  }
  for (const auto& wanted : options_.indices) {
    auto it = std::find_if(definitions().begin(), definitions().end(),
                           [&](const IndexDef& d) { return d.channel.name == wanted; });
    if (it == definitions().end()) {
      std::string msg = "unknown global index '" + wanted + "'";
      const auto guess = model::closest_match(wanted, names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      throw std::invalid_argument(msg);
    }
    if (!has(available, channel_of(it->needs))) {
      throw std::invalid_argument("global index '" + wanted + "' needs the channel '" +
                                  channel_of(it->needs) + "', which the trajectory lacks");
    }
    if (has(outputs_, wanted)) {
      throw std::invalid_argument("global index '" + wanted + "' is requested twice");
    }
    need_pressure_ = need_pressure_ || it->needs == Needs::kPressure;
    need_arterial_ = need_arterial_ || it->needs == Needs::kArterial;
    outputs_.push_back(it->channel);
  }
}

std::unique_ptr<Observer> GlobalIndices::clone() const {
  return std::make_unique<GlobalIndices>(*this);
}

Status GlobalIndices::observe(const model::Trajectory& trajectory,
                              Eigen::Ref<Eigen::VectorXd> z) const {
  if (auto status = check_z_size("global indices", z.size(), outputs_.size()); !status.ok()) {
    return status;
  }
  Eigen::VectorXd V, P, Par;
  if (auto s = channel_in_si(trajectory, options_.volume_channel, "m^3", V); !s.ok()) return s;
  if (need_pressure_) {
    if (auto s = channel_in_si(trajectory, options_.pressure_channel, "Pa", P); !s.ok()) return s;
  }
  if (need_arterial_) {
    if (auto s = channel_in_si(trajectory, options_.arterial_channel, "Pa", Par); !s.ok()) return s;
  }
  const Eigen::Index rows = V.size();
  Eigen::MatrixXd columns(rows, 1 + (need_pressure_ ? 1 : 0) + (need_arterial_ ? 1 : 0));
  columns.col(0) = V;
  if (need_pressure_) columns.col(1) = P;
  if (need_arterial_) columns.col(columns.cols() - 1) = Par;

  BeatGrid grid;
  if (auto s = make_beat_grid(trajectory.times, columns, options_.beat, grid); !s.ok()) {
    s.message = "global indices: " + s.message;
    return s;
  }
  const bool refine = options_.beat.refine_extrema;
  const Eigen::VectorXd v = grid.unique_samples(V);

  const VolumeLandmarks lm = volume_landmarks(grid, v, options_.beat);
  const Extremum& ed = lm.max;
  const Extremum& es = lm.min;
  const Eigen::VectorXd dv = derivative(grid, v);
  const Extremum dv_min = find_min(grid, dv, refine);
  const Extremum dv_max = find_max(grid, dv, refine);
  if (!(ed.value > es.value) || !(dv(dv_min.index) < 0.0)) {
    return Status::Error(StatusCode::kBadOutput,
                         "global indices: no ejection found (the volume '" +
                             options_.volume_channel + "' never decreases)");
  }
  if (!(ed.value > 0.0)) {
    return Status::Error(StatusCode::kBadOutput,
                         "global indices: end-diastolic volume is not positive");
  }

  double t_es = lm.es_time - lm.ed_time;
  if (grid.periodic) {
    t_es = std::fmod(t_es, grid.period);
    if (t_es < 0.0) t_es += grid.period;
  } else if (t_es < 0.0) {
    return Status::Error(StatusCode::kBadOutput,
                         "global indices: end-systole precedes end-diastole in a non-periodic "
                         "record (use a periodic beat)");
  }
  const double ejection = lm.es_time - lm.ejection_start;

  double p_max = 0, dp_max = 0, dp_min = 0, edp = 0, par_sys = 0, par_dia = 0;
  if (need_pressure_) {
    const Eigen::VectorXd p = grid.unique_samples(P);
    const Eigen::VectorXd dp = derivative(grid, p);
    p_max = find_max(grid, p, refine).value;
    dp_max = find_max(grid, dp, refine).value;
    dp_min = find_min(grid, dp, refine).value;
    const auto at_ed = interpolate(grid, p, nullptr, lm.ed_time, Interpolation::kLinear);
    edp = at_ed.value_or(p(ed.index));
  }
  if (need_arterial_) {
    const Eigen::VectorXd pa = grid.unique_samples(Par);
    par_sys = find_max(grid, pa, refine).value;
    par_dia = find_min(grid, pa, refine).value;
  }

  for (size_t i = 0; i < outputs_.size(); ++i) {
    const std::string& name = outputs_[i].name;
    double value = 0.0;
    if (name == "EDV") value = ed.value;
    else if (name == "ESV") value = es.value;
    else if (name == "EF") value = (ed.value - es.value) / ed.value;
    else if (name == "SV") value = ed.value - es.value;
    else if (name == "dVdt_min") value = dv_min.value;
    else if (name == "dVdt_max") value = dv_max.value;
    else if (name == "t_ES") value = t_es;
    else if (name == "ejection_duration") value = ejection;
    else if (name == "P_max") value = p_max;
    else if (name == "dPdt_max") value = dp_max;
    else if (name == "dPdt_min") value = dp_min;
    else if (name == "EDP") value = edp;
    else if (name == "P_ar_sys") value = par_sys;
    else if (name == "P_ar_dia") value = par_dia;
    z(static_cast<Eigen::Index>(i)) = value;
  }
  if (!z.allFinite()) {
    return Status::Error(StatusCode::kNonFinite, "global indices: an index is not finite");
  }
  return Status::Ok();
}

}  // namespace sigmaheart::observers
