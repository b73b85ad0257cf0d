// The results file of `sigmaheart observe` (kind "observe", docs/architecture.md s.6): the curves
// written to the observation CSV, the checks and what was found, and the provenance, so that
// scripts/plot draws the figure (global and regional curves, the regional EF bull's-eye).
//
//   /observed             time [s], V_lv [mL], V_seg01..17 [mL] (and P_lv [mmHg]) as write_trajectory
//   /checks               attributes edv, esv [mL], ef [1], end_diastole, end_systole (frames),
//                         max_sum_error [1], status; datasets regional_ef [1] (17), findings (text)
//   /frames               notes (text), quality attributes (worst_quality, worst_frame, inverted)
#pragma once

#include "app/io/results.h"
#include "app/observe_frames.h"
#include "model/simulator.h"
#include "observers/volume_curves.h"

#include <filesystem>

namespace sigmaheart::app::io {

void write_observe_h5(const std::filesystem::path& path, const Provenance& provenance, const model::Trajectory& observed,
                      const observers::VolumeChecks& checks, const ObservedFrames& frames);

}  // namespace sigmaheart::app::io
