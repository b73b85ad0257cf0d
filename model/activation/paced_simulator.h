// A model run under a pacing plan (pacing.h): the simulator a therapy evaluates.
//
// Two routes, chosen by asking the model (never by its type):
//  - the model has the Pacing capability (Simulator::pacing(), lv-3d): the plan is handed to it
//    once, here; every run and every clone then uses the paced activation;
//  - the model has per-segment activation times (17 parameters tagged activation_time, e.g. Td_XX of
//    lumped-regional): every run(theta) reads the intrinsic sequence from theta's activation times,
//    fuses it with the plan on the 17-segment graph (segment_pacing) and runs the model with the
//    result, each time wrapped into [0, period) (the activation window is periodic, so a stimulus
//    before the intrinsic onset, at a negative time, is the same beat).
// A model with neither is refused (std::invalid_argument naming it).
#pragma once

#include "model/activation/pacing.h"
#include "model/simulator.h"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::model::activation {

class PacedSimulator final : public Simulator {
 public:
  // Throws std::invalid_argument when the model cannot be paced or the plan is invalid for it (a
  // site outside the mesh, in no segment; a point on the segment graph).
  PacedSimulator(const Simulator& base, PacingPlan plan, GraphPacingOptions graph = {});

  // Whether a model can be paced, and how (for messages): "pacing capability", "segment activation
  // times", or empty when it cannot.
  static std::string route(const Simulator& base);

  std::string name() const override { return base_->name(); }
  const ParameterSpace& parameters() const override { return base_->parameters(); }
  std::vector<Channel> channels() const override { return base_->channels(); }
  // kInvalidArgument when a segment is never activated (enclosed by scar with no intrinsic wave).
  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<Simulator> clone() const override;
  // The base model's warm starts (Simulator::run_warm), on the paced parameters: a warm start is
  // only worth handing on between runs of the same plan (the activation times set the beat).
  int warm_start_size() const override { return base_->warm_start_size(); }
  RunResult run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta, const Eigen::VectorXd& from,
                     Eigen::VectorXd* produce) override;

  const PacingPlan& plan() const { return plan_; }
  // The activation of the last run (segment route: it depends on theta), or of the plan
  // (capability route).
  const PacingOutcome& outcome() const { return outcome_; }
  // The full parameter vector the segment route runs for theta (theta itself on the other route).
  Eigen::VectorXd paced_theta(const Eigen::Ref<const Eigen::VectorXd>& theta, PacingOutcome* outcome = nullptr) const;

 private:
  PacedSimulator(const PacedSimulator& other, int);  // clone

  std::unique_ptr<Simulator> base_;
  PacingPlan plan_;
  GraphPacingOptions graph_;
  std::vector<int> td_;  // indices of the 17 activation times (segment route), else empty
  int period_ = -1;      // index of the parameter tagged period (segment route)
  PacingOutcome outcome_;
};

}  // namespace sigmaheart::model::activation
