#include "observers/volume_curves.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::observers {

namespace {

std::string ml(double m3) {
  std::ostringstream s;
  s << std::setprecision(4) << m3 * 1e6 << " mL";
  return s.str();
}

std::string seg_name(int s) {
  std::ostringstream o;
  o << "V_seg" << std::setw(2) << std::setfill('0') << s;
  return o.str();
}

}  // namespace

std::string VolumeCheckOptions::validate() const {
  if (!(jump_fraction > 0)) return "jump_fraction must be > 0";
  if (!(sum_tolerance > 0)) return "sum_tolerance must be > 0";
  if (end_diastole < -1) return "end_diastole must be a frame index >= 0 (or -1: the largest volume)";
  return {};
}

std::string VolumeChecks::report() const {
  std::ostringstream s;
  for (const auto& f : findings)
    s << "frame " << f.frame << ": " << (f.segment == 0 ? std::string("V_lv") : seg_name(f.segment)) << ": " << f.what
      << "\n";
  return s.str();
}

VolumeChecks check_volume_curves(const VolumeCurves& c, const VolumeCheckOptions& o) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("VolumeCheckOptions: " + m);
  const Eigen::Index n = c.times.size();
  if (n < 1 || c.cavity.size() != n || c.regional.rows() != n || c.regional.cols() != kAhaSegments)
    throw std::invalid_argument("check_volume_curves: times, cavity and regional (frames x 17) must have one row per frame");
  if (o.end_diastole >= n)
    throw std::invalid_argument("end_diastole is frame " + std::to_string(o.end_diastole) + " of " + std::to_string(n) +
                                " (frames count from 0)");
  VolumeChecks out;
  auto add = [&](Eigen::Index k, int s, std::string what) {
    out.findings.push_back({static_cast<int>(k), s, std::move(what)});
  };
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!std::isfinite(c.cavity(k)) || !(c.cavity(k) > 0)) add(k, 0, "cavity volume " + ml(c.cavity(k)) + " (expected > 0)");
    for (int s = 1; s <= kAhaSegments; ++s) {
      const double v = c.regional(k, s - 1);
      if (!std::isfinite(v) || v < 0) add(k, s, "volume " + ml(v) + " (negative or not finite: a tracking failure)");
    }
    const double sum = c.regional.row(k).sum();
    const double err = std::abs(sum - c.cavity(k)) / std::abs(c.cavity(k));
    if (err > out.max_sum_error || k == 0) {
      out.max_sum_error = err;
      out.max_sum_error_frame = static_cast<int>(k);
    }
  }
  if (out.max_sum_error > o.sum_tolerance) {
    std::ostringstream s;
    s << "the regional volumes sum to within " << std::setprecision(3) << 100 * out.max_sum_error
      << " % of V_lv (at most " << 100 * o.sum_tolerance << " % expected: is the base ring flat and normal to the axis?)";
    add(out.max_sum_error_frame, 0, s.str());
  }
  Eigen::Index ed = 0, es = 0;
  if (o.end_diastole >= 0) {
    ed = o.end_diastole;
  } else {
    c.cavity.maxCoeff(&ed);
  }
  c.cavity.minCoeff(&es);
  out.end_diastole = static_cast<int>(ed);
  out.end_systole = static_cast<int>(es);
  out.edv = c.cavity(ed);
  out.esv = c.cavity(es);
  out.ef = (out.edv - out.esv) / out.edv;
  // A jump is measured against the segment's largest volume, or the mean segment volume at ED when
  // that is larger (a nearly empty segment, 17, toggling by a voxel is no tracking failure).
  const double typical = out.edv / kAhaSegments;
  for (int s = 1; s <= kAhaSegments; ++s) {
    const Eigen::VectorXd v = c.regional.col(s - 1);
    const double vref = std::max(v.maxCoeff(), typical);
    for (Eigen::Index k = 0; k + 1 < n && vref > 0; ++k) {
      const double jump = std::abs(v(k + 1) - v(k));
      if (jump > o.jump_fraction * vref) {
        std::ostringstream m;
        m << "jumps by " << ml(jump) << " to frame " << k + 1 << ", " << std::setprecision(3) << 100 * jump / vref
          << " % of its largest volume (at most " << 100 * o.jump_fraction << " % expected: a tracking failure)";
        add(k, s, m.str());
      }
    }
  }
  for (int s = 0; s < kAhaSegments; ++s) {
    const double ved = c.regional(ed, s);
    out.regional_ef[static_cast<size_t>(s)] =
        ved > 0 ? (ved - c.regional(es, s)) / ved : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

model::Trajectory volume_trajectory(const VolumeCurves& c) {
  model::Trajectory t;
  t.times = c.times;
  t.channels.push_back({"V_lv", "m^3", "LV cavity volume (docs/models.md s.5)"});
  for (int s = 1; s <= kAhaSegments; ++s)
    t.channels.push_back({seg_name(s), "m^3", "cavity volume of AHA segment " + std::to_string(s) + " (docs/models.md s.5)",
                          "regional_volume", s});
  t.values.resize(c.times.size(), 1 + kAhaSegments);
  t.values.col(0) = c.cavity;
  t.values.rightCols(kAhaSegments) = c.regional;
  return t;
}

}  // namespace sigmaheart::observers
