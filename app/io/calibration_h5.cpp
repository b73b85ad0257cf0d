#include "app/io/calibration_h5.h"
#include "app/io/fit_report_io.h"

#include "app/io/hdf5_writer.h"
#include "model/units.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

namespace sigmaheart::app::io {

ObservationDisplay observation_display(const observers::ObservationSet& obs) {
  ObservationDisplay d;
  d.factor.resize(obs.size());
  for (int i = 0; i < obs.size(); ++i) {
    const auto& si = obs.units[static_cast<size_t>(i)];
    std::string shown = i < static_cast<int>(obs.display_units.size())
                            ? obs.display_units[static_cast<size_t>(i)] : std::string{};
    double f = 1.0;
    if (!shown.empty() && model::units::compatible(shown, si)) {
      f = model::units::convert(1.0, si, shown);
    } else {
      const auto du = display_unit(si);
      shown = du.unit;
      f = du.from_si;
    }
    d.units.push_back(shown);
    d.factor(i) = f;
  }
  return d;
}

void write_calibration_h5(const std::filesystem::path& path, const CalibrationResults& results,
                          Provenance prov) {
  const CalibrationProblem& problem = *results.problem;
  const estimation::UtSummary& summary = *results.summary;
  const observers::ObservationSet& obs = problem.observations;
  const ObservationDisplay disp = observation_display(obs);
  const std::vector<std::string>& names = summary.names;
  const int m = obs.size();
  auto shown = [&](const std::optional<estimation::UtFit>& f) {
    Eigen::VectorXd z = Eigen::VectorXd::Constant(m, std::nan(""));
    if (f && f->z.size() == m) z = f->z.cwiseProduct(disp.factor);
    return z;
  };

  Hdf5Writer h5(path);
  write_parameters(h5, "/parameters", *results.space, results.estimated_theta);
  h5.set_attribute("/parameters", "description",
                   "every simulator parameter; estimated ones at the calibrated value");

  // Observations, in display units.
  const std::string obs_units = "see /observations/units";
  h5.write_strings("/observations/names", obs.names);
  h5.write_strings("/observations/units", disp.units);
  h5.write_strings("/observations/si_units", obs.units);
  h5.write_vector("/observations/y", obs.y.cwiseProduct(disp.factor), obs_units);
  h5.write_vector("/observations/noise_std",
                  obs.R.diagonal().cwiseSqrt().cwiseProduct(disp.factor), obs_units);
  if (obs.frame_times.size() > 0) h5.write_vector("/observations/frame_times", obs.frame_times, "s");
  if (problem.curve_sampling) {
    // Frame j was measured at frame_origin + frame_times(j) on the data file's clock.
    h5.set_attribute("/observations", "frame_origin", problem.frame_origin);
    h5.set_attribute("/observations", "alignment",
                     problem.curve_sampling->alignment_channel.empty() ? "ecg" : "end-diastole");
  }
  if (!problem.observation_file.empty()) {
    h5.set_attribute("/observations", "file", problem.observation_file.string());
  }
  // Dimension scales (H5DS): the observation and parameter name lists label the axes they index.
  const std::string obs_axis = "/observations/names", par_axis = "/estimate/names";
  h5.attach_scale("/observations/y", 0, obs_axis, "observation");
  h5.attach_scale("/observations/noise_std", 0, obs_axis, "observation");

  // Estimate.
  const std::string per = "per parameter, see /estimate/units";
  h5.write_strings("/estimate/names", names);
  h5.write_strings("/estimate/units", problem.prior.units());
  std::vector<std::string> transforms;
  for (const auto& c : problem.prior.parameters) transforms.emplace_back(estimation::to_string(c.transform.kind));
  h5.write_strings("/estimate/transform", transforms);
  h5.write_vector("/estimate/prior_mean", summary.theta_prior, per);
  h5.write_vector("/estimate/prior_std", summary.theta_prior_std, per);
  h5.write_vector("/estimate/mean", summary.theta_of_eta_mean, per);
  h5.set_attribute("/estimate/mean", "description", "T(eta mean): the point estimate, where the fit runs");
  h5.write_vector("/estimate/sigma_mean", summary.theta_sigma_mean, per);
  h5.set_attribute("/estimate/sigma_mean", "description", "sigma-point estimate of E[theta]");
  h5.write_vector("/estimate/std", summary.theta_std, per);
  h5.write_vector("/estimate/eta_prior_mean", summary.eta_prior_mean, "1");
  h5.write_vector("/estimate/eta_prior_std", summary.eta_prior_std, "1");
  h5.write_vector("/estimate/eta_mean", summary.eta_mean, "1");
  h5.write_matrix("/estimate/eta_covariance", summary.eta_covariance, "1", names, names);
  if (const auto& c = results.prior_conflict) {
    h5.write_vector("/estimate/prior_z", c->prior_z, "1");
    h5.set_attribute("/estimate/prior_z", "description",
                     "(eta - eta prior mean) / eta prior std: distance from the prior in prior std");
    std::vector<std::int64_t> in_range(c->in_range.begin(), c->in_range.end());
    h5.write_ints("/estimate/in_range", in_range);
    h5.set_attribute("/estimate/in_range", "description", "1 inside the physiological range, 0 outside, -1 none");
    h5.write_vector("/estimate/range_lower", Eigen::Map<const Eigen::VectorXd>(c->range_lower.data(), static_cast<Eigen::Index>(c->range_lower.size())), per);
    h5.write_vector("/estimate/range_upper", Eigen::Map<const Eigen::VectorXd>(c->range_upper.data(), static_cast<Eigen::Index>(c->range_upper.size())), per);
    h5.write_strings("/estimate/range_source", c->range_source);
    h5.set_attribute("/estimate", "prior_conflict", c->describe());
  }
  for (const char* v : {"prior_mean", "prior_std", "mean", "sigma_mean", "std", "eta_prior_mean",
                        "eta_prior_std", "eta_mean"}) {
    h5.attach_scale(std::string("/estimate/") + v, 0, par_axis, "parameter");
  }
  h5.attach_scale("/estimate/eta_covariance", 0, par_axis, "parameter");
  h5.attach_scale("/estimate/eta_covariance", 1, par_axis, "parameter");

  // Fit before and after, per observation.
  h5.write_vector("/fit/before", shown(summary.fit_before), obs_units);
  h5.write_vector("/fit/after", shown(summary.fit_after), obs_units);
  h5.write_vector("/fit/relative_error_before", summary.metrics_before.relative_error_percent, "%");
  h5.write_vector("/fit/relative_error_after", summary.metrics_after.relative_error_percent, "%");
  h5.attach_scale("/fit/before", 0, obs_axis, "observation");
  h5.attach_scale("/fit/after", 0, obs_axis, "observation");
  if (summary.metrics_before.relative_error_percent.size() == m) {
    h5.attach_scale("/fit/relative_error_before", 0, obs_axis, "observation");
  }
  if (summary.metrics_after.relative_error_percent.size() == m) {
    h5.attach_scale("/fit/relative_error_after", 0, obs_axis, "observation");
  }

  // The model beats as the sampler reads them, on the data's clock (frame j of the data at
  // frame_origin + frame_times(j)), channels in the display unit of their observations.
  const auto write_aligned = [&](const std::string& which, const std::optional<observers::AlignedBeat>& beat) {
    if (!beat || !problem.curve_sampling) return;
    const std::string g = "/fit/curves/" + which;
    h5.write_vector(g + "/time", beat->times.array() + problem.frame_origin, "s");
    const auto& channels = problem.curve_sampling->channels;
    for (size_t c = 0; c < channels.size(); ++c) {
      const auto first = std::find_if(obs.names.begin(), obs.names.end(), [&](const std::string& n) {
        return n.rfind(channels[c] + "@", 0) == 0;
      });
      if (first == obs.names.end()) continue;
      const auto i = static_cast<size_t>(first - obs.names.begin());
      h5.write_vector(g + "/" + channels[c],
                      beat->values.col(static_cast<Eigen::Index>(c)) * disp.factor(static_cast<Eigen::Index>(i)),
                      disp.units[i]);
    }
    h5.set_attribute(g, "period", beat->period);
    h5.set_attribute(g, "time_offset", problem.frame_origin - beat->origin);
    h5.set_attribute(g, "description",
                     "the model beat as the frames are read from it, on the data's time axis: "
                     "model time + time_offset (periodic, linear between samples)");
  };
  write_aligned("prior", results.prior_aligned);
  write_aligned("calibrated", results.calibrated_aligned);

  // Every iteration's ensemble, zero-padded so the groups sort ("/ensemble/07" < "/ensemble/12").
  int last_iteration = 0;
  for (const auto& it : summary.iterations) last_iteration = std::max(last_iteration, it.iteration);
  for (const auto& it : summary.iterations) {
    const std::string g = "/ensemble/" + padded_number(it.iteration, last_iteration);
    h5.write_matrix(g + "/theta", it.theta_members, per, {}, names);
    Eigen::MatrixXd z = it.Z;
    for (Eigen::Index r = 0; r < z.rows(); ++r) z.row(r) = z.row(r).cwiseProduct(disp.factor.transpose());
    h5.write_matrix(g + "/z", z, obs_units, {}, obs.names);
    h5.attach_scale(g + "/theta", 1, par_axis, "parameter");
    h5.attach_scale(g + "/z", 1, obs_axis, "observation");
    std::vector<std::int64_t> codes;
    std::vector<std::string> messages;
    for (const auto& s : it.status) {
      codes.push_back(static_cast<std::int64_t>(s.code));
      messages.push_back(s.ok() ? std::string("ok") : std::string(model::to_string(s.code)) + ": " + s.message);
    }
    h5.write_ints(g + "/status", codes);
    h5.write_strings(g + "/status_message", messages);
    h5.write_vector(g + "/eta_center", it.eta_center, "1");
    h5.write_vector(g + "/eta_mean", it.eta_mean, "1");
    h5.write_matrix(g + "/eta_covariance", it.P, "1", names, names);
    h5.attach_scale(g + "/eta_center", 0, par_axis, "parameter");
    h5.attach_scale(g + "/eta_mean", 0, par_axis, "parameter");
    h5.attach_scale(g + "/eta_covariance", 0, par_axis, "parameter");
    h5.attach_scale(g + "/eta_covariance", 1, par_axis, "parameter");
    h5.set_attribute(g, "attempts", it.attempts);
    h5.set_attribute(g, "spread_factor", it.spread_factor);
    h5.set_attribute(g, "step", it.step);
    h5.set_attribute(g, "nis", it.nis);
    h5.set_attribute(g, "objective", it.objective);
    h5.set_attribute(g, "lambda", it.lambda);
    h5.set_attribute(g, "secant", it.secant ? 1 : 0);  // linearised by the secant update: no members
    h5.set_attribute(g, "rejected", it.rejected);
  }
  if (!summary.starts.empty()) {
    const auto n = static_cast<Eigen::Index>(summary.starts.size());
    const auto p = static_cast<Eigen::Index>(names.size());
    Eigen::MatrixXd start(n, p), estimate(n, p);
    Eigen::VectorXd screen(n), final_objective(n);
    std::vector<std::string> status;
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto& st = summary.starts[static_cast<size_t>(k)];
      start.row(k) = st.theta_start.transpose();
      estimate.row(k) = st.theta.transpose();
      screen(k) = st.screen_objective;
      final_objective(k) = st.objective;
      status.emplace_back(estimation::to_string(st.termination));
    }
    h5.write_matrix("/global_start/theta_start", start, per, {}, names);
    h5.write_matrix("/global_start/theta", estimate, per, {}, names);
    h5.write_vector("/global_start/screen_objective", screen, "1");
    h5.write_vector("/global_start/objective", final_objective, "1");
    h5.write_strings("/global_start/status", status);
    h5.attach_scale("/global_start/theta_start", 1, par_axis, "parameter");
    h5.attach_scale("/global_start/theta", 1, par_axis, "parameter");
  }
  std::vector<std::string> actions;
  for (const auto& a : summary.actions) actions.push_back(a.describe());
  h5.write_strings("/failures/actions", actions);
  std::vector<std::string> failed;
  for (const auto& f : summary.failed) {
    std::ostringstream s;
    s << "iteration " << f.iteration << " attempt " << f.attempt << " member " << f.member
      << " theta [" << f.theta.transpose() << "]: " << model::to_string(f.status.code) << ": "
      << f.status.message;
    failed.push_back(s.str());
  }
  h5.write_strings("/failures/members", failed);

  // Curves.
  if (problem.measured) write_trajectory(h5, "/trajectories/observed", *problem.measured);
  if (results.prior_curves) write_trajectory(h5, "/trajectories/prior", *results.prior_curves);
  if (results.calibrated_curves) write_trajectory(h5, "/trajectories/calibrated", *results.calibrated_curves);

  h5.create_group("/summary");
  h5.set_attribute("/summary", "termination", estimation::to_string(summary.termination));
  h5.set_attribute("/summary", "status", estimation::to_string(summary.termination));
  h5.set_attribute("/summary", "ok", summary.ok() ? 1 : 0);
  h5.set_attribute("/summary", "retries", summary.retries);
  h5.set_attribute("/summary", "rejected_steps", summary.rejected_steps);
  h5.set_attribute("/summary", "objective_prior", summary.objective_prior);
  h5.set_attribute("/summary", "objective", summary.objective);
  h5.set_attribute("/summary", "message", summary.message);
  h5.set_attribute("/summary", "report", summary.brief_report());
  h5.set_attribute("/summary", "mode", estimation::to_string(summary.mode));
  h5.set_attribute("/summary", "sigma_points", estimation::to_string(summary.rule));
  h5.set_attribute("/summary", "failure_policy", estimation::to_string(results.failure_policy));
  h5.set_attribute("/summary", "iterations", static_cast<int>(summary.iterations.size()));
  h5.set_attribute("/summary", "simulations", summary.simulations);
  h5.set_attribute("/summary", "failures", summary.failures);
  h5.set_attribute("/summary", "mean_relative_error_before", summary.metrics_before.mean_relative_error_percent);
  h5.set_attribute("/summary", "mean_relative_error_after", summary.metrics_after.mean_relative_error_percent);
  h5.set_attribute("/summary", "rms_normalised_residual_before", summary.metrics_before.rms_normalised_residual);
  h5.set_attribute("/summary", "rms_normalised_residual_after", summary.metrics_after.rms_normalised_residual);
  if (const auto& ns = summary.noise_scale) {
    h5.write_strings("/noise_scale/channels", ns->channels);
    h5.write_vector("/noise_scale/factor", ns->weight().cwiseInverse().cwiseSqrt(), "1");
    h5.write_vector("/noise_scale/shape", ns->shape, "1");
    h5.write_vector("/noise_scale/scale", ns->scale, "1");
    h5.set_attribute("/noise_scale", "description",
                     "per channel: inverse-gamma posterior of the variance multiplier s^2; factor = "
                     "1 / sqrt(E[1/s^2]) times the stated noise std");
  }
  if (results.fit_report) write_fit_report_h5(h5, "/fit_report", *results.fit_report);
  if (results.map) write_least_squares_h5(h5, "/map", *results.map, problem.prior.units());
  prov.end_utc = utc_now();
  write_provenance(h5, prov);
  h5.commit();
}

}  // namespace sigmaheart::app::io
