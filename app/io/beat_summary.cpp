#include "app/io/beat_summary.h"

#include "app/io/display.h"
#include "observers/global_indices.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <stdexcept>

namespace sigmaheart::app::io {

std::vector<Indicator> beat_indicators(const model::RunResult& result, const std::vector<model::Channel>& channels) {
  std::vector<Indicator> out;
  try {
    const observers::GlobalIndices indices({}, channels);
    Eigen::VectorXd z(indices.size());
    const model::Status status = indices.observe(result.trajectory, z);
    if (status.ok()) {
      const auto outputs = indices.outputs();
      for (size_t i = 0; i < outputs.size(); ++i) {
        const double si = z(static_cast<Eigen::Index>(i));
        if (outputs[i].name == "EF") {
          out.push_back({"EF", 100.0 * si, "%", "ejection fraction SV / EDV"});
          continue;
        }
        const DisplayUnit d = display_unit(outputs[i].unit);
        out.push_back({outputs[i].name, si * d.from_si, d.unit, outputs[i].doc});
      }
    } else {
      spdlog::warn("indices of the simulated beat: {}", status.message);
    }
  } catch (const std::invalid_argument& e) {
    spdlog::warn("indices of the simulated beat: {}", e.what());
  }
  out.push_back({"period", result.info.period, "s", "heart period"});
  out.push_back({"beats", static_cast<double>(result.info.beats), "1",
                 "beats integrated: until the beat was periodic, or all allowed (status not-periodic)"});
  out.push_back({"periodicity_change", result.info.periodicity_change, "1",
                 "distance of the last beat's start state from periodic, relative to each entry's scale "
                 "(the shooting's last Newton correction, or lv-3d's beat-to-beat change)"});
  return out;
}

std::vector<Indicator> failed_beat_facts(const model::RunResult& result, const model::Trajectory& beat) {
  return {{"period", result.info.period, "s", "heart period"},
          {"beats", static_cast<double>(result.info.beats), "1", "beats begun; the last one failed"},
          {"time_reached", beat.times(beat.samples() - 1), "s",
           "time of the last sample written, from the start of the failing beat"}};
}

Eigen::Index finite_rows(const model::Trajectory& tr) {
  Eigen::Index k = 0;
  while (k < tr.values.rows() && k < tr.times.size() && tr.values.row(k).allFinite() && std::isfinite(tr.times(k))) ++k;
  return k;
}

}  // namespace sigmaheart::app::io
