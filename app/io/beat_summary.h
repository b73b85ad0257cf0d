// What `simulate` reports of one beat: its global indices in display units, the run's beat-level
// facts, and for a beat that failed midway the part that was computed (docs/architecture.md s.6).
#pragma once

#include "app/io/results.h"
#include "model/simulator.h"

#include <vector>

namespace sigmaheart::app::io {

// The beat's global indices (observers/global_indices.h) in display units (EF in %), then the
// period, beats and periodicity change. An index the observer cannot compute is logged and left out.
std::vector<Indicator> beat_indicators(const model::RunResult& result, const std::vector<model::Channel>& channels);

// A run that failed inside a beat (diverged, non-finite): no indices (a part of a beat has no EDV
// or EF), only the period, the beats begun and the time reached in `beat`.
std::vector<Indicator> failed_beat_facts(const model::RunResult& result, const model::Trajectory& beat);

// The number of leading samples whose time and values are all finite.
Eigen::Index finite_rows(const model::Trajectory& trajectory);

}  // namespace sigmaheart::app::io
