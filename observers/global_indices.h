// Global indices of one beat of LV volume (and pressure) curves: the observations of the global
// Unscented-Transform calibration (Marchesseau et al. 2013, Biomech Model Mechanobiol 12:815;
// docs/estimation.md s.5). The same code reads a simulated beat (fine time grid) and a measured curve
// (about 30 cine frames per beat), so both sides of the comparison are defined identically.
//
// Definitions (x' by the centred differences of beat.h; extrema are sample extrema unless
// BeatOptions::refine_extrema; eps = BeatOptions::plateau_tolerance, 5 % of SV by default):
//   EDV   [m^3]  maximum of V_lv
//   ESV   [m^3]  minimum of V_lv
//   SV    [m^3]  EDV - ESV
//   EF    [1]    SV / EDV (a fraction, not a percentage)
//   dVdt_min [m^3/s]  minimum of dV/dt: peak ejection flow (negative)
//   dVdt_max [m^3/s]  maximum of dV/dt: peak filling flow
//   t_ES  [s]    time from end-diastole to end-systole, modulo the period. End-diastole (ED) is
//                the onset of the ED plateau (V last rises through EDV - eps SV), end-systole (ES)
//                the end of ejection (V falls through ESV + eps SV): the volume is flat during the
//                isovolumic phases, so the instants of max / min volume themselves are ill-defined.
//                With eps = 0 they are the times of the extrema.
//   ejection_duration [s]  from V falling through EDV - eps SV to V falling through ESV + eps SV
//                (volume decreasing beyond the threshold; eps = 0: from ED to ES). Volume levels
//                rather than a dV/dt threshold: centred differences smear the valve openings over
//                two frames, which at 30 frames per beat lengthened the duration by ~20 %.
//   P_max [Pa]   maximum of P_lv
//   dPdt_max, dPdt_min [Pa/s]  extrema of dP_lv/dt. At cine rates (30 frames per beat) they are
//                strongly biased towards 0 (the isovolumic phases last one or two frames: on the
//                lumped sphere dPdt_max comes out 29 % and dPdt_min 55 % too small, dV/dt extrema
//                4-11 %); compare them only between curves sampled densely (catheter, simulation).
//   EDP   [Pa]   P_lv at ED (linear interpolation)
//   P_ar_sys, P_ar_dia [Pa]  maximum and minimum of P_ar (aortic / arterial pressure)
// A trajectory without a volume range or without negative dV/dt ("no ejection found"), with a
// missing channel, NaN, or fewer than 3 samples gives a non-ok Status (never an exception).
// observe() keeps no state: one object may serve several threads.
#pragma once

#include "observers/beat.h"
#include "observers/observer.h"

#include <string>
#include <vector>

namespace sigmaheart::observers {

struct GlobalIndicesOptions {
  // Output names, in this order; empty = every index the available channels allow (volume
  // indices; pressure indices when the pressure channel exists; arterial when P_ar exists).
  std::vector<std::string> indices;
  std::string volume_channel = "V_lv";      // [m^3]
  std::string pressure_channel = "P_lv";    // [Pa]
  std::string arterial_channel = "P_ar";    // [Pa]
  BeatOptions beat;  // closed simulated beat by default; measured_frames() for cine frames

  std::string validate() const;  // empty when valid
};

class GlobalIndices : public Observer {
 public:
  // Every index name with its SI unit and a one-line definition, in the canonical order.
  static const std::vector<model::Channel>& catalog();

  // available: the channels the trajectories will carry (Simulator::channels(), or those of a
  // measured curve). Throws std::invalid_argument for invalid options, an unknown index name
  // (with a did-you-mean) or an index whose channel is not available.
  GlobalIndices(GlobalIndicesOptions options, const std::vector<model::Channel>& available);

  std::vector<model::Channel> outputs() const override { return outputs_; }
  model::Status observe(const model::Trajectory& trajectory,
                        Eigen::Ref<Eigen::VectorXd> z) const override;
  std::unique_ptr<Observer> clone() const override;

  const GlobalIndicesOptions& options() const { return options_; }

 private:
  GlobalIndicesOptions options_;
  std::vector<model::Channel> outputs_;
  bool need_pressure_ = false;
  bool need_arterial_ = false;
};

}  // namespace sigmaheart::observers
