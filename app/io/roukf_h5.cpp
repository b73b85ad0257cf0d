#include "app/io/roukf_h5.h"

#include "app/io/display.h"
#include "app/io/hdf5_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

namespace sigmaheart::app::io {

Eigen::VectorXd RoukfResults::value() const {
  return summary->has_estimate() ? summary->theta : summary->theta_prior;
}

Eigen::VectorXd RoukfResults::std() const {
  return summary->has_estimate() ? summary->theta_std : summary->theta_prior_std;
}

void write_roukf_h5(const std::filesystem::path& path, const RoukfResults& results,
                    Provenance prov) {
  const PersonalizeProblem& problem = *results.problem;
  const estimation::RoukfSummary& summary = *results.summary;
  const std::vector<std::string>& names = summary.parameter_names;
  const std::vector<std::string>& channels = problem.data.channels;
  const int p = static_cast<int>(names.size());
  const int m = static_cast<int>(channels.size());
  const int steps = static_cast<int>(summary.steps.size());
  const Eigen::VectorXd final_theta = results.value();

  Hdf5Writer h5(path);
  Eigen::VectorXd full = problem.filter.base_theta;
  for (int j = 0; j < p; ++j) full(*results.space->index(names[static_cast<size_t>(j)])) = final_theta(j);
  write_parameters(h5, "/parameters", *results.space, full);
  h5.set_attribute("/parameters", "description", "every simulator parameter; estimated ones at the final estimate");

  const std::string per = "per parameter, see /estimate/units";
  h5.write_strings("/estimate/names", names);
  h5.write_strings("/estimate/units", problem.prior.units());
  h5.write_strings("/estimate/family", problem.families);
  std::vector<std::int64_t> segs(problem.segments.begin(), problem.segments.end());
  h5.write_ints("/estimate/segment", segs);
  h5.set_attribute("/estimate/segment", "units", "1-based AHA segment; 0 = global parameter");
  std::vector<std::string> transforms;
  for (const auto& q : problem.prior.parameters) transforms.emplace_back(estimation::to_string(q.transform.kind));
  h5.write_strings("/estimate/transform", transforms);
  h5.write_vector("/estimate/prior", summary.theta_prior, per);
  h5.write_vector("/estimate/prior_std", summary.theta_prior_std, per);
  h5.write_vector("/estimate/value", final_theta, per);
  h5.set_attribute("/estimate/value", "description",
                   summary.map_steps > 0 || summary.map_converged
                       ? "T(eta) at the MAP point of the whole data (Gauss-Newton from the filter's estimate)"
                       : "T(eta mean) after the last step");
  h5.write_vector("/estimate/std", results.std(), per);
  h5.set_attribute("/estimate/std", "description", "|dtheta/deta| sqrt(P_eta) (delta method)");
  if (summary.has_estimate()) {
    h5.write_vector("/estimate/lower", summary.theta_lower, per);
    h5.write_vector("/estimate/upper", summary.theta_upper, per);
    h5.write_vector("/estimate/eta", summary.eta, "1");
    h5.write_matrix("/estimate/eta_covariance", summary.eta_covariance, "1", names, names);
  }
  if (summary.std_ratio.size() == p) {
    // What the data told about each parameter: posterior over prior std (in eta).
    h5.write_vector("/estimate/std_ratio", summary.std_ratio, "1");
    h5.set_attribute("/estimate/std_ratio", "description",
                     "posterior std / prior std of eta; >= " + format_number(estimation::kUninformedStdRatio, 2) +
                         ": not informed by the data");
  }
  if (summary.channel_chi2.size() == m) {
    // Per channel at the estimate: chi-square of the whitened residuals with the stated noise.
    Eigen::VectorXd frames = summary.channel_frames.cast<double>(), lo(m), hi(m);
    for (int c = 0; c < m; ++c) {
      const int f = std::max(1, summary.channel_frames(c));
      lo(c) = estimation::chi_square_quantile(f, 0.025) / f;
      hi(c) = estimation::chi_square_quantile(f, 0.975) / f;
    }
    h5.write_vector("/channels/chi2_per_frame", summary.channel_chi2.cwiseQuotient(frames.cwiseMax(1.0)), "1");
    h5.write_vector("/channels/frames", frames, "1");
    h5.write_vector("/channels/band_lower", lo, "1");
    h5.write_vector("/channels/band_upper", hi, "1");
    h5.write_strings("/channels/names", channels);
    if (summary.noise_scale_mode.size() == m) {
      h5.write_vector("/channels/noise_scale", summary.noise_scale_mode.cwiseSqrt(), "1");
      h5.set_attribute("/channels/noise_scale", "description", "sqrt of the posterior mode of s^2: the noise std in stated noise stds");
    }
  }
  h5.create_group("/setup");
  if (problem.volume_shares.size() > 0) {
    // What `therapy` needs to rebuild the wrapper the fit ran (model/regional_volume_shares.h).
    h5.write_vector("/setup/volume_shares", problem.volume_shares, "1");
    h5.write_vector("/setup/reference_shares", problem.reference_shares, "1");
    h5.set_attribute("/setup", "reference_volume", problem.reference_volume);
    h5.set_attribute("/setup", "share_exponents", problem.share_exponents ? 1.0 : 0.0);
  }
  h5.set_attribute("/setup", "notes", problem.notes);
  h5.set_attribute("/setup", "align", std::string(problem.align_end_diastole ? "end-diastole" : "ecg"));
  h5.set_attribute("/setup", "data_ed_time", problem.data_ed_time);
  h5.set_attribute("/setup", "model_ed_time", problem.model_ed_time);
  h5.set_attribute("/setup", "period", problem.period);
  if (summary.map_runs > 0 && summary.eta_filter.size() == p) {
    // The filter's own estimate and the Gauss-Newton refinement after it (docs/estimation.md s.4.7).
    h5.write_vector("/map_refinement/eta_filter", summary.eta_filter, "1");
    h5.write_matrix("/map_refinement/eta_covariance_filter", summary.eta_covariance_filter, "1", names, names);
    h5.set_attribute("/map_refinement", "steps", summary.map_steps);
    h5.set_attribute("/map_refinement", "converged", summary.map_converged ? 1 : 0);
    h5.set_attribute("/map_refinement", "note", summary.map_note);
    h5.set_attribute("/map_refinement", "shift_filter_std", summary.map_shift_std);
    h5.set_attribute("/map_refinement", "last_step_std", summary.map_last_step_std);
    h5.set_attribute("/map_refinement", "objective_at_filter_estimate", summary.map_statistic_filter);
    h5.set_attribute("/map_refinement", "objective_at_estimate", summary.map_objective);
    h5.set_attribute("/map_refinement", "runs", summary.map_runs);
  }

  // Observations in display units (mL).
  const std::string obs_units = "see /observations/units";
  Eigen::MatrixXd y = problem.data.values;
  for (int j = 0; j < m; ++j) y.col(j) *= problem.display_factor(j);
  h5.write_strings("/observations/names", channels);
  h5.write_strings("/observations/units", problem.display_units);
  h5.write_vector("/observations/time", problem.file_times, "s");
  h5.set_attribute("/observations/time", "description", "frame times as in the file (beat-local)");
  h5.write_matrix("/observations/values", y, obs_units, {}, channels);
  h5.write_vector("/observations/noise_std", problem.noise_si.cwiseProduct(problem.display_factor), obs_units);
  h5.write_vector("/observations/filter_noise_std",
                  problem.r_inflation * problem.noise_si.cwiseProduct(problem.display_factor), obs_units);
  h5.set_attribute("/observations", "file", problem.observation_file.string());
  h5.set_attribute("/observations", "start_beats", problem.start_beats);

  // Every filter step.
  Eigen::VectorXd time(steps), nis(steps), loglik(steps);
  std::vector<std::int64_t> beat(steps), frame(steps), observed(steps), skipped(steps);
  Eigen::MatrixXd th = Eigen::MatrixXd::Constant(steps, p, std::nan("")), lo = th, hi = th, eta = th, eta_std = th;
  Eigen::MatrixXd innov = Eigen::MatrixXd::Constant(steps, m, std::nan("")), fc = innov, fit = innov;
  std::vector<std::string> actions;
  for (int k = 0; k < steps; ++k) {
    const auto& s = summary.steps[static_cast<size_t>(k)];
    const auto kk = static_cast<size_t>(k);
    time(k) = s.time;
    nis(k) = s.nis;
    loglik(k) = s.log_likelihood;
    beat[kk] = s.beat;
    frame[kk] = s.frame;
    observed[kk] = s.observed;
    skipped[kk] = s.analysis_skipped ? 1 : 0;
    if (s.theta.size() == p) {
      th.row(k) = s.theta.transpose();
      lo.row(k) = s.theta_lower.transpose();
      hi.row(k) = s.theta_upper.transpose();
      eta.row(k) = s.eta.transpose();
      eta_std.row(k) = s.eta_std.transpose();
    }
    if (s.innovation.size() == m) {
      innov.row(k) = s.innovation.cwiseProduct(problem.display_factor).transpose();
      fc.row(k) = s.forecast.cwiseProduct(problem.display_factor).transpose();
      fit.row(k) = s.fitted.cwiseProduct(problem.display_factor).transpose();
    }
    for (const auto& a : s.actions) {
      actions.push_back("step " + std::to_string(k) + (a.member >= 0 ? " member " + std::to_string(a.member) : "") +
                        ": " + a.what + (a.status.ok() ? "" : " (" + a.status.message + ")"));
    }
  }
  h5.write_vector("/steps/time", time, "s");
  h5.set_attribute("/steps/time", "description",
                   problem.filter.pass_mode == estimation::RoukfPassMode::kSplit
                       ? "model time of the frame, start_beats x period + frame time (every split pass restarts)"
                       : "model time of the frame (start_beats + pass) x period + frame time");
  h5.write_ints("/steps/beat", beat);
  h5.write_ints("/steps/frame", frame);
  h5.write_ints("/steps/observed", observed);
  h5.write_ints("/steps/analysis_skipped", skipped);
  for (const char* n : {"/steps/beat", "/steps/frame", "/steps/observed", "/steps/analysis_skipped"}) {
    h5.set_attribute(n, "units", "1");
  }
  h5.write_matrix("/steps/theta", th, per, {}, names);
  h5.write_matrix("/steps/theta_lower", lo, per, {}, names);
  h5.set_attribute("/steps/theta_lower", "description", "T(eta - 2 std)");
  h5.write_matrix("/steps/theta_upper", hi, per, {}, names);
  h5.set_attribute("/steps/theta_upper", "description", "T(eta + 2 std)");
  h5.write_matrix("/steps/eta", eta, "1", {}, names);
  h5.write_matrix("/steps/eta_std", eta_std, "1", {}, names);
  h5.write_matrix("/steps/innovation", innov, obs_units, {}, channels);
  h5.write_matrix("/steps/forecast", fc, obs_units, {}, channels);
  h5.write_matrix("/steps/fitted", fit, obs_units, {}, channels);
  h5.set_attribute("/steps/fitted", "description", "linearised posterior fit of the observations");
  h5.write_vector("/steps/nis", nis, "1");
  h5.write_vector("/steps/log_likelihood", loglik, "1");
  h5.write_strings("/failures/actions", actions);

  if (problem.filter.truth) {
    h5.write_vector("/truth/values", *problem.filter.truth, per);
    h5.write_matrix("/truth/pass_error", summary.pass_error_percent, "%", {}, names);
    h5.set_attribute("/truth/pass_error", "description", "|estimate - truth| / truth after each pass");
    if (summary.error_percent.size() == p) {
      h5.write_vector("/truth/error", summary.error_percent, "%");
      h5.set_attribute("/truth/error", "description", "|estimate - truth| / truth of the final estimate");
    }
    h5.set_attribute("/truth", "passes_to_within_10_percent", summary.passes_to_within_10_percent);
    if (summary.truth_z.size() > 0) {  // the spread against the truth (docs/estimation.md s.4.5)
      h5.write_vector("/truth/standardised_error", summary.truth_z, "1");
      h5.set_attribute("/truth/standardised_error", "description", "(eta - eta_truth) / std of eta");
      h5.set_attribute("/truth", "mahalanobis_squared", summary.truth_d2);
      h5.set_attribute("/truth", "mahalanobis_squared_limit_95", summary.truth_d2_limit);
    }
  }

  h5.create_group("/summary");
  h5.set_attribute("/summary", "termination", estimation::to_string(summary.termination));
  h5.set_attribute("/summary", "message", summary.message);
  h5.set_attribute("/summary", "report", summary.brief_report());
  // Counts, then the filter's consistency (normalised innovation squared and its 95 % band).
  for (const auto& [key, count] : {std::pair<const char*, int>{"members", summary.members},
                                   {"member_runs", summary.member_runs}, {"retries", summary.retries},
                                   {"skipped_analyses", summary.skipped_analyses},
                                   {"passes", summary.pass_fractions.empty() ? problem.filter.beats
                                                       : static_cast<int>(summary.pass_fractions.size())}}) {
    h5.set_attribute("/summary", key, count);
  }
  for (const auto& [key, value] : {std::pair<const char*, double>{"nis_mean", summary.nis_mean},
                                   {"nis_band_lower", summary.nis_band_lower},
                                   {"nis_band_upper", summary.nis_band_upper},
                                   {"wall_seconds", summary.wall_seconds}}) {
    h5.set_attribute("/summary", key, value);
  }
  h5.set_attribute("/summary", "pass_mode", std::string(estimation::to_string(problem.filter.pass_mode)));
  h5.set_attribute("/summary", "nis_source", summary.nis_source);
  h5.set_attribute("/summary", "forgetting", problem.filter.forgetting);
  h5.set_attribute("/summary", "r_inflation", problem.r_inflation);
  h5.set_attribute("/summary", "spin_up", problem.spin_up);
  h5.set_attribute("/summary", "failure_policy", estimation::to_string(problem.filter.failure_policy));
  prov.end_utc = utc_now();
  write_provenance(h5, prov);
  h5.commit();
}

}  // namespace sigmaheart::app::io
