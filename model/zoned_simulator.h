// Zones of a per-segment parameter family: one parameter sets every segment of its zone.
//
// The ROUKF runs p + 1 members (simplex sigma points), so on an expensive model (lv-3d, tens of
// seconds per beat) 17 regional contractilities cost 18 3D runs per step. Tying segments into a few
// zones (e.g. the coronary territories of Cerqueira et al. 2002, Circulation 105:539, fig. 2:
// LAD 1, 2, 7, 8, 13, 14, 17; RCA 3, 4, 9, 10, 15; LCx 5, 6, 11, 12, 16) makes a reduced problem
// that still resolves regional function (docs/estimation.md s.4.5). The zoned simulator wraps any
// steppable simulator: its parameter space is the inner one without the zoned members plus one
// parameter per zone, appended in the given order; every call expands theta and forwards.
#pragma once

#include "model/wrapped_simulator.h"

#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model {

struct ParameterZone {
  std::string name;          // the zone parameter's name, e.g. "sigma0_lad"
  std::vector<int> members;  // indices of the inner parameters it sets (same unit)
};

class ZonedSimulator final : public WrappedSimulator {
 public:
  // Throws std::invalid_argument when a zone is empty, a member index is out of range or in two
  // zones, the members of a zone differ in unit, or a zone name is already a parameter name. The
  // zone parameter takes the unit, family and the widest bounds that fit every member (the
  // intersection), and the mean nominal of its members; segment 0 (it is not one segment).
  ZonedSimulator(std::unique_ptr<SteppableSimulator> inner, std::vector<ParameterZone> zones);

  // The zoned parameter space of `inner` (as the constructor's, same errors); `source`, when
  // given, receives per inner parameter its index in the zoned space.
  static ParameterSpace zoned_space(const ParameterSpace& inner, const std::vector<ParameterZone>& zones,
                                    std::vector<int>* source = nullptr);

  // The inner parameter vector of a zoned one (every member of a zone gets the zone's value).
  Eigen::VectorXd expand(const Eigen::Ref<const Eigen::VectorXd>& theta) const;
  const std::vector<ParameterZone>& zones() const { return zones_; }

  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  SIGMAHEART_STEPPING_OVERRIDES;

 private:
  std::unique_ptr<SteppableSimulator> rewrap(std::unique_ptr<SteppableSimulator> inner) const override {
    return std::make_unique<ZonedSimulator>(std::move(inner), zones_);
  }

  std::vector<ParameterZone> zones_;
  std::vector<int> source_;  // per inner parameter: its index in space_
};

}  // namespace sigmaheart::model
