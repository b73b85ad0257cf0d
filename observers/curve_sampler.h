// Curves sampled at the image frame times, aligned on end-diastole (docs/estimation.md s.5): LV volume
// and pressure at about 30 cine frames per beat for the global calibration, the 17 AHA regional
// volumes V_seg01..V_seg17 for the ROUKF.
//
// Alignment: frame_times are measured from end-diastole t_ED of the observed beat, the onset of the
// end-diastolic plateau of alignment_channel (V_lv), found exactly as in GlobalIndices (beat.h,
// BeatOptions::plateau_tolerance). Entry j of a channel is that channel at t_ED + frame_times(j), wrapped into the beat
// (periodic), by linear or cubic Hermite interpolation (beat.h). frame_times may be negative
// (frame 0 of a measured curve lies within half a frame of its end-diastole): see
// observations_from_curves(), which builds matching frame times from a measured curve.
//
// Output names: "<channel>@f<k>", k the frame index zero-padded to two digits or more (as many as
// the largest index needs): V_lv@f00 ... V_lv@f29, V_seg07@f12; channel-major order (all frames of
// the first channel, then the next). Units: the channel's SI unit (m^3 for V_*, Pa for P_*).
#pragma once

#include "observers/beat.h"
#include "observers/observer.h"

#include <string>
#include <vector>

namespace sigmaheart::observers {

struct CurveSamplerOptions {
  std::vector<std::string> channels = {"V_lv"};  // e.g. V_lv, P_lv, V_seg01 ... V_seg17
  Eigen::VectorXd frame_times;                   // [s] after end-diastole; at least one
  // ED is found on this channel; empty: no alignment (frame_times are then measured from the
  // first sample of the trajectory).
  std::string alignment_channel = "V_lv";
  Interpolation interpolation = Interpolation::kLinear;
  BeatOptions beat;

  std::string validate() const;  // empty when valid
};

// A simulated beat as the sampler reads it: the unique samples of its grid (a closed beat's
// mismatch spread as in BeatGrid::unique_samples), each sampled channel in SI, with times measured
// from the frame origin (t_ED with alignment, else the first sample), so that entry j of the
// observations is the periodic linear interpolation of these at frame_times(j) (kLinear).
struct AlignedBeat {
  Eigen::VectorXd times;   // [s] after the frame origin, increasing, within one period
  Eigen::MatrixXd values;  // samples x channels, SI, channel order of CurveSamplerOptions
  double origin = 0.0;     // [s] the frame origin in the trajectory's own time
  double period = 0.0;     // [s] 0: not periodic
};

// "V_lv@f07" for (V_lv, 7, 30 frames).
std::string frame_name(const std::string& channel, int frame, int frames);

class CurveSampler : public Observer {
 public:
  // available: the channels trajectories will carry (their units give each output's SI unit).
  // Throws std::invalid_argument for invalid options or a channel that is not available.
  CurveSampler(CurveSamplerOptions options, const std::vector<model::Channel>& available);

  std::vector<model::Channel> outputs() const override { return outputs_; }
  model::Status observe(const model::Trajectory& trajectory,
                        Eigen::Ref<Eigen::VectorXd> z) const override;
  std::unique_ptr<Observer> clone() const override;

  const CurveSamplerOptions& options() const { return options_; }
  // The beat the frames are read from (AlignedBeat), for figures that draw the model on the
  // data's time axis; the same grid, alignment and errors as observe().
  model::Status aligned_beat(const model::Trajectory& trajectory, AlignedBeat& out) const;

 private:
  model::Status read_beat(const model::Trajectory& trajectory, BeatGrid& grid,
                          Eigen::MatrixXd& values, double& origin) const;

  CurveSamplerOptions options_;
  std::vector<std::string> si_units_;  // per sampled channel
  std::vector<model::Channel> outputs_;
};

}  // namespace sigmaheart::observers
