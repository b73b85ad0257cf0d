#include "observers/pump_work.h"

#include <array>
#include <cmath>
#include <stdexcept>

namespace sigmaheart::observers {

namespace {

constexpr std::array<int, 5> kSeptal = {2, 3, 8, 9, 14};
constexpr std::array<int, 5> kLateral = {5, 6, 11, 12, 16};

// -closed integral of P dV over the samples (trapezoidal rule, closed from the last sample back to
// the first: the beat is periodic).
double loop_work(const Eigen::VectorXd& P, const Eigen::VectorXd& V) {
  const Eigen::Index n = P.size();
  double w = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index j = (k + 1) % n;
    w -= 0.5 * (P(k) + P(j)) * (V(j) - V(k));
  }
  return w;
}

}  // namespace

PumpWork::PumpWork(const std::vector<model::Channel>& available) {
  bool v = false, p = false;
  std::vector<std::string> seg(17);
  int found = 0;
  for (const auto& c : available) {
    v = v || c.name == "V_lv";
    p = p || c.name == "P_lv";
    if (c.family == "regional_volume" && c.segment >= 1 && c.segment <= 17 && seg[static_cast<size_t>(c.segment - 1)].empty()) {
      seg[static_cast<size_t>(c.segment - 1)] = c.name;
      ++found;
    }
  }
  if (!v || !p) throw std::invalid_argument("pump work needs the channels V_lv and P_lv");
  if (found == 17) segment_channels_ = seg;
}

std::vector<model::Channel> PumpWork::outputs() const {
  std::vector<model::Channel> out = {{"stroke_work", "J", "area of the pressure-volume loop, -closed integral P_lv dV_lv"}};
  if (regional()) {
    out.push_back({"septal_work", "J", "mean regional stroke work -closed integral P_lv dV_seg of segments 2, 3, 8, 9, 14"});
    out.push_back({"lateral_work", "J", "mean regional stroke work of segments 5, 6, 11, 12, 16"});
    out.push_back({"work_difference", "J", "lateral_work - septal_work (septal-to-lateral work difference)"});
  }
  return out;
}

model::Status PumpWork::observe(const model::Trajectory& t, Eigen::Ref<Eigen::VectorXd> z) const {
  const size_t m = regional() ? 4 : 1;
  if (auto s = check_z_size("pump work", z.size(), m); !s.ok()) return s;
  if (t.samples() < 3) return model::Status::Error(model::StatusCode::kInvalidArgument, "pump work: fewer than 3 samples");
  const auto iv = t.channel_index("V_lv"), ip = t.channel_index("P_lv");
  if (!iv || !ip) return model::Status::Error(model::StatusCode::kInvalidArgument, "pump work: no V_lv or P_lv");
  const Eigen::VectorXd P = t.values.col(*ip);
  z(0) = loop_work(P, t.values.col(*iv));
  if (regional()) {
    auto mean_work = [&](const auto& segments) {
      double w = 0.0;
      for (int s : segments) {
        const auto c = t.channel_index(segment_channels_[static_cast<size_t>(s - 1)]);
        if (!c) return std::nan("");
        w += loop_work(P, t.values.col(*c));
      }
      return w / static_cast<double>(segments.size());
    };
    z(1) = mean_work(kSeptal);
    z(2) = mean_work(kLateral);
    z(3) = z(2) - z(1);
  }
  if (!z.allFinite()) return model::Status::Error(model::StatusCode::kNonFinite, "pump work: a work is not finite");
  return model::Status::Ok();
}

}  // namespace sigmaheart::observers
