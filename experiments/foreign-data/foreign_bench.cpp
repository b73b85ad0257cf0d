#include "foreign_bench.h"

#include "foreign_ode.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace foreign {
namespace {

Rhs as_rhs(const LvCircuit& sim) {
  return [&sim](double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) { sim.rhs(t, y, dy); };
}

// Integrates through the sorted times `ts` (all >= t0), recording a Sample at each.
std::vector<Sample> record(const LvCircuit& sim, double t0, Eigen::VectorXd y,
                           const std::vector<double>& ts, const Dopri5Options& o) {
  std::vector<Sample> out;
  out.reserve(ts.size());
  const Rhs f = as_rhs(sim);
  double t = t0, h = 0.0;
  for (double tk : ts) {
    if (tk > t) dopri5(f, t, tk, y, h, o);
    t = std::max(t, tk);
    out.push_back(sim.observe(tk, y));
  }
  return out;
}

}  // namespace

Beat run_beat(const LvCircuit& sim, double dt_dense, int n_frames, const PeriodicOptions& opt,
              double frame_offset) {
  const double T = sim.period();
  Dopri5Options o;
  o.rtol = opt.rtol;
  o.atol = opt.atol;
  o.h_max = 2e-3;
  const Rhs f = as_rhs(sim);

  // 1. periodic steady state, sampled at activation onsets t = n T
  Beat beat;
  beat.period = T;
  Eigen::VectorXd y = sim.initial_state();
  double h = 0.0;
  for (int n = 1;; ++n) {
    const Eigen::VectorXd y0 = y;
    dopri5(f, 0.0, T, y, h, o);  // the circuits depend on t only through t mod T
    double change = 0.0;
    for (Eigen::Index i = 0; i < y.size(); ++i) {
      change = std::max(change, std::abs(y(i) - y0(i)) / std::max(std::abs(y0(i)), 1.0));
    }
    beat.periodic_change = change;
    beat.beats_to_periodic = n;
    if (n >= opt.min_beats && change < opt.tolerance) break;
    if (n >= opt.max_beats) throw std::runtime_error("foreign bench: no periodic state reached");
  }

  // 2. end-diastole: scanning back (cyclically) from aortic opening, the first sample after the
  //    last one with mitral flow, on a 0.1 ms grid.
  const int m = static_cast<int>(std::lround(T / 1e-4));
  std::vector<double> grid(static_cast<size_t>(m));
  for (int k = 0; k < m; ++k) grid[static_cast<size_t>(k)] = T * k / m;
  const auto fine = record(sim, 0.0, y, grid, o);
  int k_ao = -1;
  for (int k = 1; k < m && k_ao < 0; ++k) {
    if (fine[static_cast<size_t>(k)].Q_av > 0.0 && fine[static_cast<size_t>(k - 1)].Q_av <= 0.0) k_ao = k;
  }
  if (k_ao < 0) throw std::runtime_error("foreign bench: the aortic valve never opens");
  int k_ed = -1;
  for (int j = 1; j <= m && k_ed < 0; ++j) {
    const int k = ((k_ao - j) % m + m) % m;
    if (fine[static_cast<size_t>(k)].Q_mv > 0.0) k_ed = (k + 1) % m;
  }
  if (k_ed < 0) throw std::runtime_error("foreign bench: the mitral valve never opens");
  beat.t_ed_cycle = grid[static_cast<size_t>(k_ed)];

  // 3. one beat from end-diastole, dense samples and frames merged in one pass
  Eigen::VectorXd y_ed = y;
  double h2 = 0.0;
  if (beat.t_ed_cycle > 0.0) dopri5(f, 0.0, beat.t_ed_cycle, y_ed, h2, o);
  const int n_dense = static_cast<int>(std::lround(T / dt_dense));
  std::vector<double> ts;
  for (int k = 0; k <= n_dense; ++k) ts.push_back(beat.t_ed_cycle + std::min(k * dt_dense, T));
  // Frame k at end-diastole + frame_offset + k T / n (wrapped into the beat), stamped k T / n.
  auto frame_time = [&](int k) {
    const double t = frame_offset + T * k / n_frames;
    return t >= T ? t - T : t;
  };
  for (int k = 0; k < n_frames; ++k) ts.push_back(beat.t_ed_cycle + frame_time(k));
  std::sort(ts.begin(), ts.end());
  ts.erase(std::unique(ts.begin(), ts.end()), ts.end());
  auto all = record(sim, beat.t_ed_cycle, y_ed, ts, o);
  for (auto& s : all) s.t -= beat.t_ed_cycle;
  auto at = [&all](double tk) {  // the recorded sample at time tk (ts holds every such time)
    const auto it = std::lower_bound(all.begin(), all.end(), tk - 1e-12,
                                     [](const Sample& s, double v) { return s.t < v; });
    if (it == all.end() || std::abs(it->t - tk) > 1e-12) {
      throw std::logic_error("foreign bench: output time not recorded");
    }
    Sample s = *it;
    s.t = tk;  // the nominal time, not (t_ed + tk) - t_ed
    return s;
  };
  for (int k = 0; k <= n_dense; ++k) beat.dense.push_back(at(std::min(k * dt_dense, T)));
  for (int k = 0; k < n_frames; ++k) {
    beat.frames.push_back(at(frame_time(k)));
    beat.frames.back().t = T * k / n_frames;
  }
  return beat;
}

Indices indices_of(const Beat& beat) {
  Indices x;
  const auto& d = beat.dense;
  x.heart_rate = 60.0 / beat.period;
  x.EDV = d.front().V_lv;
  x.EDP = d.front().P_lv;
  x.ESV = x.EDV;
  x.P_peak = -1e300;
  x.P_ao_sys = -1e300;
  x.P_ao_dia = 1e300;
  for (const auto& s : d) {
    x.ESV = std::min(x.ESV, s.V_lv);
    x.P_peak = std::max(x.P_peak, s.P_lv);
    x.P_ao_sys = std::max(x.P_ao_sys, s.P_ao);
    x.P_ao_dia = std::min(x.P_ao_dia, s.P_ao);
  }
  for (size_t k = 1; k + 1 < d.size(); ++k) {
    x.dPdt_max = std::max(x.dPdt_max, (d[k + 1].P_lv - d[k - 1].P_lv) / (d[k + 1].t - d[k - 1].t));
  }
  x.SV = x.EDV - x.ESV;
  x.EF = 100.0 * x.SV / x.EDV;
  x.CO = x.SV * x.heart_rate / 1000.0;
  return x;
}

}  // namespace foreign
