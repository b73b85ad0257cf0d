// Registration of the lumped models (lumped-sphere, lumped-regional) and the parsing of their
// `numerics:` sections (model/registry.h).
#pragma once

#include "model/lumped/regional.h"
#include "model/lumped/sphere.h"
#include "model/registry.h"

#include <string>
#include <vector>

namespace sigmaheart::model::lumped {

void register_lumped_models(ModelRegistry& registry);

// `numerics:` of the sphere -> SphereOptions (defaults from the struct); `extra` names further
// keys a model adds to the section (parsed by its own function). Errors go through the reader.
SphereOptions read_sphere_options(const OptionReader& numerics,
                                  const std::vector<std::string>& extra = {});
// `numerics:` of the regional ventricle: the sphere's keys plus
//   activation: lbbb                 # synchronous | lbbb | pacing | times
//   activation: {pattern: lbbb, duration: 140 ms}
//   activation: {pattern: pacing, segment: 17, conduction_velocity: 0.6 m/s}
//   activation: {pattern: times, times: [0, 12 ms, ...]}   # one per segment
//   area_shares: [0.25, 0.75]        # optional: N patches instead of the 17 AHA segments
// The activation pattern sets the nominal Td_XX, so `parameters:` (and --set Td_05=...) can still
// change single segments.
RegionalOptions read_regional_options(const OptionReader& numerics);

}  // namespace sigmaheart::model::lumped
