// Analytic beats for the observer tests: curves whose indices are known in closed form.
#pragma once

#include "model/simulator.h"

#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

namespace sigmaheart::observers::testing {

inline constexpr double kPi = std::numbers::pi;

// A named curve x(t) in SI.
struct AnalyticChannel {
  std::string name;
  std::string unit;
  std::function<double(double)> x;
};

// Samples the channels at t_k = t_first + k * period / frames. closed = true adds the sample at
// t_first + period (a simulated beat on [0, T]); false stops one frame before (cine frames).
inline model::Trajectory sample_beat(const std::vector<AnalyticChannel>& channels, double period,
                                     int frames, bool closed, double t_first = 0.0) {
  const int n = closed ? frames + 1 : frames;
  model::Trajectory tr;
  tr.times.resize(n);
  tr.values.resize(n, static_cast<Eigen::Index>(channels.size()));
  for (int k = 0; k < n; ++k) {
    const double t = t_first + period * k / frames;
    tr.times(k) = t;
    for (size_t c = 0; c < channels.size(); ++c) {
      tr.values(k, static_cast<Eigen::Index>(c)) = channels[c].x(t);
    }
  }
  if (closed) tr.values.row(n - 1) = tr.values.row(0);  // exactly periodic, as a settled beat
  for (const auto& c : channels) tr.channels.push_back({c.name, c.unit, ""});
  return tr;
}

// V(t) = V0 + A cos(w (t - t_ed)): EDV = V0 + A at t_ed, ESV = V0 - A half a beat later,
// dV/dt extrema -+A w.
struct CosineBeat {
  double period = 0.8;     // [s]
  double v0 = 100e-6;      // [m^3]
  double amplitude = 35e-6;
  double t_ed = 0.123;     // [s]
  double p0 = 6e3;         // [Pa] P(t) = p0 + pa sin(w (t - t_p))
  double pa = 7e3;
  double t_p = 0.05;
  double ar0 = 12e3;       // [Pa] P_ar(t) = ar0 + ara cos(w (t - t_p))
  double ara = 2.5e3;

  double w() const { return 2.0 * kPi / period; }
  // End-diastole as the observers define it (onset of the ED plateau, BeatOptions::
  // plateau_tolerance eps): V = EDV - eps SV, acos(1 - 2 eps) / w before the peak.
  double ed_onset(double eps = 0.05) const { return t_ed - std::acos(1.0 - 2.0 * eps) / w(); }
  // V falls from EDV - eps SV to ESV + eps SV.
  double ejection(double eps = 0.05) const {
    return (kPi - 2.0 * std::acos(1.0 - 2.0 * eps)) / w();
  }
  double volume(double t) const { return v0 + amplitude * std::cos(w() * (t - t_ed)); }
  double pressure(double t) const { return p0 + pa * std::sin(w() * (t - t_p)); }
  std::vector<AnalyticChannel> channels() const {
    const double om = w();
    return {
        {"V_lv", "m^3", [=, *this](double t) { return v0 + amplitude * std::cos(om * (t - t_ed)); }},
        {"P_lv", "Pa", [=, *this](double t) { return p0 + pa * std::sin(om * (t - t_p)); }},
        {"P_ar", "Pa", [=, *this](double t) { return ar0 + ara * std::cos(om * (t - t_p)); }},
    };
  }
};

// An asymmetric, more heart-like volume curve (three harmonics) and a pressure with a sharp rise.
inline std::vector<AnalyticChannel> skewed_beat(double period) {
  const double w = 2.0 * kPi / period;
  return {
      {"V_lv", "m^3",
       [=](double t) {
         const double th = w * (t - 0.1);
         return 1e-6 * (110.0 + 35.0 * std::cos(th) + 9.0 * std::cos(2.0 * th + 0.7) +
                        3.0 * std::sin(3.0 * th));
       }},
      {"P_lv", "Pa",
       [=](double t) {
         const double th = w * (t - 0.1);
         return 133.322 * (8.0 + 55.0 * std::pow(0.5 - 0.5 * std::cos(th - 1.9), 3.0));
       }},
  };
}

}  // namespace sigmaheart::observers::testing
