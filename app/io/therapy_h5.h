// What `therapy` writes: the HDF5 results file (kind "therapy"; read by
// scripts/sigmaplot_therapy.py), the JSON summary and the terminal table, all from the
// TherapySummary. Responses are shown in clinical units: dP/dt in mmHg/s, volumes in mL, EF and
// its change in % (points), work in mJ, activation times in ms, AHR in %.
//
// HDF5 layout (every numeric dataset has `units`):
//   /responses/{raw,change}_{names,units}          the response columns
//   /points/{names, eta, theta, wm, wc}            the propagation points (no posterior: none)
//   /baseline/{raw, raw_mean, raw_std, raw_lower, raw_upper}
//   /map, /sweep: one row per therapy: label, mode, lv_segment (0: a point), lv_surface,
//        av_delay, vv_delay [ms], status, failure, note, captured ("RV,LV" flags);
//        raw_mean/_std/_lower/_upper, change_mean/_std/_lower/_upper (therapies x columns),
//        p_responder, and for /map p_best and /map/ahr (therapies x points: AHR at each point)
//   /best: attributes index (into /map), label, segment, p_best
//   /trajectories/baseline, /trajectories/best      beats at the posterior mean (PV loops)
//   /parameters                                     the model's parameters run (the mean point)
//   /summary: attributes status, message, simulations, failures, method, points, route, scar,
//             personalization, personalization_status, responder_threshold
#pragma once

#include "app/io/results.h"
#include "app/therapy_setup.h"
#include "estimation/therapy/therapy.h"
#include "model/simulator.h"

#include <filesystem>
#include <optional>
#include <string>

namespace sigmaheart::app::io {

struct TherapyResults {
  const TherapyProblem* problem = nullptr;
  const estimation::therapy::TherapySummary* summary = nullptr;
  const model::ParameterSpace* space = nullptr;
  Eigen::VectorXd mean_theta;                   // the parameters at the posterior mean
  std::optional<model::Trajectory> baseline_beat, best_beat;
  std::string status;                           // the command's status in words
};

void write_therapy_h5(const std::filesystem::path& path, const TherapyResults& results, Provenance provenance);
void write_therapy_json(const std::filesystem::path& path, const std::string& name, const TherapyResults& results,
                        const Provenance& provenance);
// The lead-site table and the sweeps for the terminal.
std::string therapy_report(const TherapyResults& results);

}  // namespace sigmaheart::app::io
