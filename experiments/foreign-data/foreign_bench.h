// The common harness of the foreign-data bench: a minimal LV-simulator interface, the periodic
// steady state, one recorded beat starting at end-diastole, and the clinical indices of a beat.
// Physics lives in elastance_lv.* and one_fibre_lv.*, which share nothing but this file and
// foreign_ode.h. Nothing here includes or links sigmaheart (model/, observers/, estimation/, app/).
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

#include <string>
#include <vector>

namespace foreign {

/// What a bench simulator reports at one instant (clinical units: s, mL, mmHg, mL/s).
struct Sample {
  double t = 0.0;     ///< [s]
  double V_lv = 0.0;  ///< [mL] LV cavity volume
  double P_lv = 0.0;  ///< [mmHg] LV cavity pressure
  double V_la = 0.0;  ///< [mL] left-atrial volume
  double P_la = 0.0;  ///< [mmHg] left-atrial pressure
  double P_ao = 0.0;  ///< [mmHg] aortic root pressure (upstream of Zc)
  double Q_pv = 0.0;  ///< [mL/s] pulmonary-venous inflow to the atrium
  double Q_mv = 0.0;  ///< [mL/s] mitral flow (>= 0: diode valve)
  double Q_av = 0.0;  ///< [mL/s] aortic-valve flow (>= 0: diode valve)
  double Q_per = 0.0; ///< [mL/s] peripheral outflow of the Windkessel through R
};

/// A Sample at time t [s] with the LV and atrial volumes [mL] set; the pressures and flows are
/// the circuit's to fill.
inline Sample sample_with_volumes(double t, double V_lv, double V_la) {
  Sample s;
  s.t = t;
  s.V_lv = V_lv;
  s.V_la = V_la;
  return s;
}

/// An LV + atrium + valves + Windkessel circuit with ventricular activation onset at t = 0 mod T.
/// Contract: rhs and observe are pure functions of (t, y) (no hidden state), so a simulator can be
/// shared read-only between threads; sizes of y and dy equal initial_state().size().
class LvCircuit {
 public:
  virtual ~LvCircuit() = default;
  virtual double period() const = 0;  ///< [s]
  virtual Eigen::VectorXd initial_state() const = 0;
  virtual void rhs(double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) const = 0;
  virtual Sample observe(double t, const Eigen::VectorXd& y) const = 0;
};

struct PeriodicOptions {
  double tolerance = 1e-6;  ///< max over states of |y(nT+T) - y(nT)| / max(|y(nT)|, 1)
  int min_beats = 3;
  int max_beats = 400;
  double rtol = 1e-10, atol = 1e-10;  ///< Dormand-Prince tolerances
};

/// One periodic beat, recorded from end-diastole (t = 0) to the next end-diastole.
struct Beat {
  double period = 0.0;        ///< [s]
  double t_ed_cycle = 0.0;    ///< [s] end-diastole in cycle time (activation onset = 0)
  int beats_to_periodic = 0;  ///< beats run before the beat-to-beat change met the tolerance
  double periodic_change = 0.0;  ///< the last beat-to-beat relative change
  std::vector<Sample> dense;     ///< noise-free samples every dt_dense, t in [0, T]
  std::vector<Sample> frames;    ///< noise-free samples at t_k = k T / n_frames (+ frame_offset), k < n_frames
};

/// Runs beats from initial_state() until periodic, finds end-diastole (the instant of mitral
/// closure before ejection = the maximum volume, since both valves are then closed) and records
/// one beat from there. Throws std::runtime_error when no periodic state is reached.
/// frame_offset [s], in [0, T): the frames are taken that long after end-diastole (an ECG trigger
/// late on the R wave) and stamped from 0 on the file's clock (t_k = k T / n_frames).
Beat run_beat(const LvCircuit& sim, double dt_dense = 1e-3, int n_frames = 30,
              const PeriodicOptions& opt = {}, double frame_offset = 0.0);

/// Clinical indices of a recorded beat (computed from Beat::dense).
struct Indices {
  double heart_rate = 0.0;  ///< [bpm]
  double EDV = 0.0, ESV = 0.0, SV = 0.0;  ///< [mL] at t = 0, minimum, EDV - ESV
  double EF = 0.0;          ///< [%]
  double P_peak = 0.0;      ///< [mmHg] peak LV pressure
  double EDP = 0.0;         ///< [mmHg] LV pressure at t = 0
  double dPdt_max = 0.0;    ///< [mmHg/s] by central differences of the dense samples
  double P_ao_sys = 0.0, P_ao_dia = 0.0;  ///< [mmHg] aortic max / min
  double CO = 0.0;          ///< [L/min] SV * HR
};
Indices indices_of(const Beat& beat);

/// The circuit around a ventricle whose pressure is a function of (t, V_lv) (elastance_lv.h,
/// mooney_rivlin_lv.h): state y = [V_lv, V_la, P_c]; an elastance atrium with a raised-cosine
/// twitch 0.5 (1 - cos(2 pi s / T_la)) starting t_la_onset before ventricular onset, diode
/// valves, a three-element Windkessel and the pulmonary-venous inflow (equations: README, "The
/// simulators"). P holds the fields E_la_min, E_la_max, V0_la, kick, t_la_onset, T_la, P_pv,
/// R_pv, R_mv, R_av, Zc, R_sys, C_sys, P_ven (same names and units in both parameter structs).
template <class P>
double raised_cosine_atrium(double t, double period, const P& p) {
  double s = t + p.t_la_onset;  // time since atrial onset
  s -= period * std::floor(s / period);
  if (s >= p.T_la) return 0.0;
  return 0.5 * (1.0 - std::cos(2.0 * 3.141592653589793 * s / p.T_la));
}

template <class P>
Sample three_state_sample(double t, const Eigen::VectorXd& y, double P_lv, double atrial, const P& p) {
  Sample s = sample_with_volumes(t, y(0), y(1));
  const double P_c = y(2);
  s.P_lv = P_lv;
  const double E_la = p.E_la_min + p.kick * atrial * (p.E_la_max - p.E_la_min);
  s.P_la = E_la * (s.V_la - p.V0_la);
  s.Q_pv = (p.P_pv - s.P_la) / p.R_pv;
  s.Q_mv = std::max(s.P_la - s.P_lv, 0.0) / p.R_mv;
  s.Q_av = std::max(s.P_lv - P_c, 0.0) / (p.R_av + p.Zc);
  s.P_ao = P_c + p.Zc * s.Q_av;
  s.Q_per = (P_c - p.P_ven) / p.R_sys;
  return s;
}

template <class P>
void three_state_rhs(const Sample& s, const P& p, Eigen::VectorXd& dy) {
  dy(0) = s.Q_mv - s.Q_av;
  dy(1) = s.Q_pv - s.Q_mv;
  dy(2) = (s.Q_av - s.Q_per) / p.C_sys;
}

/// An LV circuit of the three states (V_lv, V_la, P_c) and the shared circulation above whose
/// ventricle is one pressure law: Derived provides lv_pressure(t, V) [mmHg] and
/// atrial_activation(t) in [0, 1]; P is its parameter struct (with heart_rate [bpm]).
template <class Derived, class P>
class ThreeStateLv : public LvCircuit {
 public:
  explicit ThreeStateLv(const P& p) : p_(p) {}
  double period() const override { return 60.0 / p_.heart_rate; }
  Eigen::VectorXd initial_state() const override {
    Eigen::VectorXd y(3);
    y << 120.0, 60.0, 80.0;  // [mL], [mL], [mmHg]
    return y;
  }
  Sample observe(double t, const Eigen::VectorXd& y) const override {
    const Derived& d = static_cast<const Derived&>(*this);
    return three_state_sample(t, y, d.lv_pressure(t, y(0)), d.atrial_activation(t), p_);
  }
  void rhs(double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) const override {
    three_state_rhs(observe(t, y), p_, dy);
  }
  const P& parameters() const { return p_; }

 protected:
  P p_;
};

}  // namespace foreign
