// The JSON summary and the terminal report of `calibrate` (declared in calibration_h5.h).
#include "app/io/atomic_file.h"
#include "app/io/calibration_h5.h"
#include "app/io/fit_report_io.h"
#include "app/io/display.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app::io {

namespace {

Eigen::VectorXd shown_fit(const std::optional<estimation::UtFit>& f, const ObservationDisplay& d) {
  const auto m = d.factor.size();
  if (f && f->z.size() == m) return f->z.cwiseProduct(d.factor);
  return Eigen::VectorXd::Constant(m, std::nan(""));
}

// What the JSON summary and the report both show: the summary, the observations with their
// display units, the parameter units and the fits before and after (in display units).
struct Shown {
  const estimation::UtSummary& summary;
  const observers::ObservationSet& obs;
  ObservationDisplay disp;
  std::vector<std::string> units;
  Eigen::VectorXd before;
  Eigen::VectorXd after;
};

Shown shown_values(const CalibrationResults& results) {
  const estimation::UtSummary& summary = *results.summary;
  const observers::ObservationSet& obs = results.problem->observations;
  ObservationDisplay disp = observation_display(obs);
  Eigen::VectorXd before = shown_fit(summary.fit_before, disp);
  Eigen::VectorXd after = shown_fit(summary.fit_after, disp);
  return {summary, obs, std::move(disp), results.problem->prior.units(), std::move(before), std::move(after)};
}

}  // namespace

void write_calibration_json(const std::filesystem::path& path, const std::string& name,
                            const CalibrationResults& results, const Provenance& provenance) {
  const auto& [summary, obs, disp, units, before, after] = shown_values(results);

  nlohmann::ordered_json j;
  j["kind"] = "calibrate";
  j["name"] = name;
  j["status"] = estimation::to_string(summary.termination);
  j["ok"] = summary.ok();
  j["termination"] = estimation::to_string(summary.termination);
  j["message"] = summary.message;
  j["mode"] = estimation::to_string(summary.mode);
  j["iterations"] = summary.iterations.size();
  j["simulations"] = summary.simulations;
  j["failures"] = summary.failures;
  j["retries"] = summary.retries;
  j["rejected_steps"] = summary.rejected_steps;
  j["failure_policy"] = estimation::to_string(results.failure_policy);
  j["objective_prior"] = summary.objective_prior;
  j["objective"] = summary.objective;
  for (const auto& st : summary.starts) {
    nlohmann::ordered_json s;
    for (size_t k = 0; k < summary.names.size(); ++k) {
      s["start"][summary.names[k]] = st.theta_start(static_cast<Eigen::Index>(k));
      s["estimate"][summary.names[k]] = st.theta(static_cast<Eigen::Index>(k));
    }
    s["screen_objective"] = st.screen_objective;
    s["objective"] = st.objective;
    s["status"] = estimation::to_string(st.termination);
    s["iterations"] = st.iterations;
    s["simulations"] = st.simulations;
    s["objective_by_iteration"] = st.objectives;
    s["message"] = st.message;
    j["starts"].push_back(s);
  }
  for (size_t k = 0; k < summary.names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    j["parameters"][summary.names[k]] = {{"value", summary.theta_of_eta_mean(i)},
                                         {"std", summary.theta_std(i)},
                                         {"prior", summary.theta_prior(i)},
                                         {"prior_std", summary.theta_prior_std(i)},
                                         {"unit", units[k]}};
    if (summary.truth_error_percent) {
      j["parameters"][summary.names[k]]["error_percent"] = (*summary.truth_error_percent)(i);
    }
    if (const auto& c = results.prior_conflict) {
      auto& q = j["parameters"][summary.names[k]];
      q["prior_z"] = c->prior_z(i);
      q["in_range"] = c->in_range[k] < 0 ? nlohmann::json(nullptr) : nlohmann::json(c->in_range[k] == 1);
      if (c->in_range[k] >= 0) q["range"] = {c->range_lower[k], c->range_upper[k]};
      if (!c->range_source[k].empty()) q["range_source"] = c->range_source[k];
    }
  }
  if (results.prior_conflict) j["prior_conflict"] = results.prior_conflict->describe();
  if (const auto& ns = summary.noise_scale) {
    // The estimated noise per channel: factor = 1 / sqrt(E[1/s^2]) times the stated std.
    const Eigen::VectorXd w = ns->weight();
    for (size_t c = 0; c < ns->channels.size(); ++c) {
      const auto i = static_cast<Eigen::Index>(c);
      j["noise_scale"][ns->channels[c]] = {{"factor", 1.0 / std::sqrt(w(i))}, {"shape", ns->shape(i)},
                                           {"scale", ns->scale(i)}};
    }
  }
  for (int i = 0; i < obs.size(); ++i) {
    const auto k = static_cast<size_t>(i);
    j["fit"][obs.names[k]] = {
        {"observed", obs.y(i) * disp.factor(i)},
        {"noise_std", std::sqrt(obs.R(i, i)) * disp.factor(i)},
        {"prior", before(i)},
        {"calibrated", after(i)},
        {"relative_error_prior_percent", summary.metrics_before.relative_error_percent(i)},
        {"relative_error_percent", summary.metrics_after.relative_error_percent(i)},
        {"unit", disp.units[k]}};
  }
  j["mean_relative_error_prior_percent"] = summary.metrics_before.mean_relative_error_percent;
  j["mean_relative_error_percent"] = summary.metrics_after.mean_relative_error_percent;
  j["rms_normalised_residual_prior"] = summary.metrics_before.rms_normalised_residual;
  j["rms_normalised_residual"] = summary.metrics_after.rms_normalised_residual;
  if (results.fit_report) add_fit_report_json(j, *results.fit_report);
  if (results.map) add_least_squares_json(j, *results.map, units);
  j["provenance"] = provenance_json(provenance);
  write_text_file(path, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
}

std::string calibration_report(const CalibrationResults& results) {
  const auto& [summary, obs, disp, units, before, after] = shown_values(results);
  const auto& err_after = summary.metrics_after.relative_error_percent;

  std::ostringstream t;
  t << summary.brief_report() << "\n"
    << "status: " << estimation::to_string(summary.termination) << (summary.ok() ? "" : " (not a success)")
    << " -- " << summary.message << "\n\n";
  t << std::left << std::setw(14) << "parameter" << std::right << std::setw(12) << "prior"
    << std::setw(14) << "estimate" << std::setw(12) << "+- std" << "  unit"
    << (results.prior_conflict ? "    prior z  physiological range" : "") << "\n";
  for (size_t k = 0; k < summary.names.size(); ++k) {
    const auto j = static_cast<Eigen::Index>(k);
    t << std::left << std::setw(14) << summary.names[k] << std::right << std::setw(12)
      << format_number(summary.theta_prior(j)) << std::setw(14)
      << format_number(summary.theta_of_eta_mean(j)) << std::setw(12)
      << format_number(summary.theta_std(j), 2) << "  " << std::left << std::setw(10) << units[k];
    if (const auto& c = results.prior_conflict) {
      t << std::right << std::setw(7) << format_number(c->prior_z(j), 2) << "  ";
      if (c->in_range[k] >= 0) {
        t << (c->in_range[k] ? "in " : "OUT ") << format_number(c->range_lower[k], 3) << "-"
          << format_number(c->range_upper[k], 3);
      } else {
        t << "-";
      }
    }
    t << "\n";
  }
  if (results.prior_conflict && !results.prior_conflict->absorbed_by.empty()) {
    t << results.prior_conflict->describe() << "\n";
  }
  t << "\n" << std::left << std::setw(14) << "observation" << std::right << std::setw(11) << "observed"
    << std::setw(11) << "prior" << std::setw(11) << "calibrated" << std::setw(9) << "error" << "  unit\n";
  const int m = obs.size();
  const int shown = std::min(m, 24);
  for (int i = 0; i < shown; ++i) {
    const auto k = static_cast<size_t>(i);
    t << std::left << std::setw(14) << obs.names[k] << std::right << std::setw(11)
      << format_number(obs.y(i) * disp.factor(i)) << std::setw(11) << format_number(before(i))
      << std::setw(11) << format_number(after(i)) << std::setw(8) << format_number(err_after(i), 2)
      << "%  " << disp.units[k] << "\n";
  }
  if (m > shown) t << "... (" << m - shown << " more in the results file)\n";
  if (results.fit_report && !results.fit_report->indices.empty()) {
    // The clinical indices, not a mean relative error that low diastolic pressures inflate.
    t << "clinical indices, observed -> calibrated:";
    for (const auto& ix : results.fit_report->indices) {
      const DisplayUnit u = quantity_display_unit(ix.name, ix.unit);
      t << (&ix == &results.fit_report->indices.front() ? " " : ", ") << ix.name << " "
        << format_number(ix.observed * u.from_si, 3) << " -> " << format_number(ix.fitted * u.from_si, 3) << " "
        << u.unit;
    }
    t << "\n";
  } else {
    t << "mean relative error: " << format_number(summary.metrics_before.mean_relative_error_percent, 3)
      << " % (prior) -> " << format_number(summary.metrics_after.mean_relative_error_percent, 3)
      << " % (calibrated)\n";
  }
  t << "RMS residual in noise standard deviations: "
    << format_number(summary.metrics_before.rms_normalised_residual, 3) << " (prior) -> "
    << format_number(summary.metrics_after.rms_normalised_residual, 3)
    << " (calibrated); 1 = at the noise level\n";
  for (size_t k = 0; k < summary.starts.size(); ++k) {
    const auto& st = summary.starts[k];
    t << "start " << k + 1 << ": objective " << format_number(st.screen_objective, 4) << " -> "
      << format_number(st.objective, 4) << " (" << estimation::to_string(st.termination) << ", "
      << st.iterations << " iterations)\n";
  }
  if (const auto& ns = summary.noise_scale) {
    t << "noise scale (estimated, times the stated std):";
    const Eigen::VectorXd w = ns->weight();
    for (size_t c = 0; c < ns->channels.size(); ++c) {
      t << (c ? ", " : " ") << ns->channels[c] << " " << format_number(1.0 / std::sqrt(w(static_cast<Eigen::Index>(c))), 3);
    }
    t << "\n";
  }
  if (results.fit_report) t << "fit: " << results.fit_report->summary << "\n";
  if (results.map && results.problem->least_squares_reference) {
    // The reference run: how far the UT estimate is from the MAP point of the same objective.
    t << "reference: " << results.map->brief_report() << "\n";
    if (summary.mode == estimation::UtMode::kMap) {
      t << "UT objective / MAP objective: " << format_number(summary.objective / results.map->cost, 4)
        << " (1 = the UT reached the MAP point)\n";
    }
  }
  return t.str();
}

}  // namespace sigmaheart::app::io
