// Pressure-volume work of one beat, global and regional (docs/estimation.md s.12.2): the acute
// responses of a therapy besides the global indices.
//
//   stroke_work   [J]  -closed integral of P_lv dV_lv over the beat (the area of the PV loop; the
//                      trapezoidal rule on the samples, closed from the last sample to the first)
//   septal_work   [J]  the mean over the septal segments 2, 3, 8, 9, 14 of -closed integral of
//                      P_lv dV_seg (regional stroke work of the lumped and 3D models' segment
//                      volumes: the cavity pressure times the segment's volume change)
//   lateral_work  [J]  the same over the lateral segments 5, 6, 11, 12, 16
//   work_difference [J]  lateral_work - septal_work: the septal-to-lateral regional work
//                      difference, large in LBBB (the late lateral wall does the work, the early
//                      septum little or negative). Koopsen et al. 2024 (Europace 26:euae009) found
//                      its change under virtual pacing of CircAdapt digital twins (MW_LW-S, from
//                      segment strain and pressure) correlated with 6-month reverse remodelling
//                      (r = 0.62), the simulated dP/dt max change only weakly (r = -0.34).
// Regional outputs need the regional_volume channels of segments 1..17; without them only
// stroke_work is given. The trajectory is one periodic beat.
#pragma once

#include "observers/observer.h"

#include <string>
#include <vector>

namespace sigmaheart::observers {

class PumpWork : public Observer {
 public:
  // available: the channels of the trajectories to come (Simulator::channels()). Throws
  // std::invalid_argument when V_lv or P_lv is missing.
  explicit PumpWork(const std::vector<model::Channel>& available);
  std::vector<model::Channel> outputs() const override;
  model::Status observe(const model::Trajectory& trajectory, Eigen::Ref<Eigen::VectorXd> z) const override;
  std::unique_ptr<Observer> clone() const override { return std::make_unique<PumpWork>(*this); }
  bool regional() const { return !segment_channels_.empty(); }

 private:
  std::vector<std::string> segment_channels_;  // 17 names (segment order), or empty
};

}  // namespace sigmaheart::observers
