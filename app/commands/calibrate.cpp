// `sigmaheart calibrate CONFIG`: Unscented-Transform calibration of global parameters from LV
// volume (and pressure) curves or typed-in indices (Marchesseau et al. 2013, Biomech Model
// Mechanobiol 12:815; ESTIMATION.md s.3). Sections of the config: app/calibration_setup.h.
#include "app/calibration_setup.h"
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/results.h"
#include "app/progress.h"
#include "estimation/forward_model.h"
#include "estimation/mpi.h"
#include "model/units.h"

#include <nlohmann/json.hpp>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app {

namespace {

// Display unit and factor (display = SI * factor) of each observation.
struct ObservationDisplay {
  std::vector<std::string> units;
  Eigen::VectorXd factor;
};

ObservationDisplay observation_display(const observers::ObservationSet& obs) {
  ObservationDisplay d;
  d.factor.resize(obs.size());
  for (int i = 0; i < obs.size(); ++i) {
    const auto si = obs.units[static_cast<size_t>(i)];
    std::string shown = i < static_cast<int>(obs.display_units.size())
                            ? obs.display_units[static_cast<size_t>(i)] : std::string{};
    double f = 1.0;
    if (!shown.empty() && model::units::compatible(shown, si)) {
      f = model::units::convert(1.0, si, shown);
    } else {
      const auto du = io::display_unit(si);
      shown = du.unit;
      f = du.from_si;
    }
    d.units.push_back(shown);
    d.factor(i) = f;
  }
  return d;
}

std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

struct CalibrateOptions {
  std::filesystem::path config;
  std::filesystem::path output;
  std::filesystem::path summary;
  int threads = 0;
  std::vector<std::string> overrides;
};

int run_calibrate(const CalibrateOptions& o, CommandContext& ctx) {
  const bool root_rank = ctx.root();
  io::Provenance prov;
  prov.start_utc = io::utc_now();
  const Config config = load_config(o.config, o.overrides);
  CalibrationProblem problem = parse_calibration_problem(config);
  const std::filesystem::path output =
      !o.output.empty() ? o.output : default_output_path(o.config, "calibrate");

  auto simulator = config.simulator.make();
  std::vector<std::string> names;
  for (const auto& p : problem.parameters) names.push_back(p.name);
  estimation::SimulatorForwardModel forward(*simulator, *problem.observer, names);

  estimation::UtOptions options = problem.options;
  if (o.threads > 0) options.ensemble.threads = o.threads;
  options.ensemble.communicator = ctx.comm;  // members spread over the ranks, if several
  if (options.ensemble.threads == 1) {
    options.ensemble.backend = estimation::Backend::kSerial;
  }

  ProgressLine progress(ctx.err, "calibrate", root_rank);
  int stage_iteration = -1, stage_attempt = -1;
  options.progress = [&](const estimation::UtProgress& p) {
    if (p.iteration != stage_iteration || p.attempt != stage_attempt) {
      if (stage_iteration >= 0) progress.finish();
      stage_iteration = p.iteration;
      stage_attempt = p.attempt;
      // A batch of one run is a centre run (a backtracking step, or the fit at the estimate).
      std::string stage = "iteration " + std::to_string(p.iteration + 1) +
                          (p.total == 1 ? std::string(" (centre run)") : std::string());
      if (p.attempt > 0) stage += " (retry " + std::to_string(p.attempt) + ", smaller spread)";
      progress.start(stage, p.total);
    }
    progress.update(p.done);
  };

  estimation::UtCalibration calibration(forward, problem.parameters, problem.observations, options);
  const std::string invalid = calibration.validate();
  if (!invalid.empty()) {
    throw InputError(config.file.root()["calibration"].location(), invalid);
  }
  if (root_rank) {
    spdlog::info("calibrating {} parameter(s) of {} against {} observation(s) ({}, {}, {} threads)",
                 names.size(), simulator->name(), problem.observations.size(),
                 estimation::to_string(options.mode), estimation::to_string(options.sigma.rule),
                 options.ensemble.threads > 0 ? options.ensemble.threads : omp_get_max_threads());
  }
  const estimation::UtSummary summary = calibration.run();
  progress.finish();

  // Curves at the prior and at the estimate, for the plots.
  Eigen::VectorXd prior_theta(static_cast<Eigen::Index>(names.size()));
  for (size_t j = 0; j < names.size(); ++j) prior_theta(static_cast<Eigen::Index>(j)) = problem.parameters[j].prior_mean;
  const model::RunResult prior_run = simulator->run(forward.full_theta(prior_theta));
  const model::RunResult post_run = simulator->run(forward.full_theta(summary.theta_of_eta_mean));

  if (!root_rank) return summary.ok() ? kExitOk : kExitRuntimeFailure;

  const ObservationDisplay disp = observation_display(problem.observations);
  const int m = problem.observations.size();
  const int p = static_cast<int>(names.size());
  Eigen::VectorXd y_disp = problem.observations.y.cwiseProduct(disp.factor);
  Eigen::VectorXd noise_disp(m);
  for (int i = 0; i < m; ++i) noise_disp(i) = std::sqrt(problem.observations.R(i, i)) * disp.factor(i);
  auto fit_disp = [&](const std::optional<estimation::UtFit>& f) {
    Eigen::VectorXd z = Eigen::VectorXd::Constant(m, std::nan(""));
    if (f && f->z.size() == m) z = f->z.cwiseProduct(disp.factor);
    return z;
  };
  const Eigen::VectorXd before = fit_disp(summary.fit_before);
  const Eigen::VectorXd after = fit_disp(summary.fit_after);
  auto rel_err = [&](const Eigen::VectorXd& z) {
    Eigen::VectorXd e(m);
    for (int i = 0; i < m; ++i) e(i) = 100.0 * std::abs(z(i) - y_disp(i)) / std::max(std::abs(y_disp(i)), 1e-300);
    return e;
  };
  const Eigen::VectorXd err_before = rel_err(before), err_after = rel_err(after);
  // Root-mean-square residual in units of the noise std: 1 means a fit at the noise level.
  auto rms_normalised = [&](const std::optional<estimation::UtFit>& f) {
    return f && f->normalised.size() == m ? std::sqrt(f->normalised.squaredNorm() / m) : std::nan("");
  };
  const double rms_before = rms_normalised(summary.fit_before);
  const double rms_after = rms_normalised(summary.fit_after);
  Eigen::VectorXd prior_std(p);
  for (int j = 0; j < p; ++j) {
    const auto& c = problem.parameters[static_cast<size_t>(j)];
    prior_std(j) = std::abs(c.transform.dtheta_deta(c.eta_mean())) * c.eta_std();
  }

  fill_provenance(prov, config, ctx, "calibrate", options.ensemble.threads > 0 ? options.ensemble.threads : omp_get_max_threads(), ctx.ranks);
  {
    io::Hdf5Writer h5(output);
    io::write_parameters(h5, "/parameters", config.simulator.parameters,
                         forward.full_theta(summary.theta_of_eta_mean));
    h5.set_attribute("/parameters", "description",
                     "every simulator parameter; estimated ones at the calibrated value");

    // Observations, in display units.
    h5.write_strings("/observations/names", problem.observations.names);
    h5.write_strings("/observations/units", disp.units);
    h5.write_strings("/observations/si_units", problem.observations.units);
    h5.write_vector("/observations/y", y_disp, "see /observations/units");
    h5.write_vector("/observations/noise_std", noise_disp, "see /observations/units");
    if (problem.observations.frame_times.size() > 0) {
      h5.write_vector("/observations/frame_times", problem.observations.frame_times, "s");
    }
    if (!problem.observation_file.empty()) {
      h5.set_attribute("/observations", "file", problem.observation_file.string());
    }

    // Estimate.
    h5.write_strings("/estimate/names", names);
    h5.write_strings("/estimate/units", problem.parameter_units);
    std::vector<std::string> transforms;
    for (const auto& c : problem.parameters) transforms.emplace_back(estimation::to_string(c.transform.kind));
    h5.write_strings("/estimate/transform", transforms);
    const std::string per = "per parameter, see /estimate/units";
    h5.write_vector("/estimate/prior_mean", prior_theta, per);
    h5.write_vector("/estimate/prior_std", prior_std, per);
    h5.write_vector("/estimate/mean", summary.theta_of_eta_mean, per);
    h5.set_attribute("/estimate/mean", "description", "T(eta mean): the point estimate, where the fit runs");
    h5.write_vector("/estimate/sigma_mean", summary.theta_sigma_mean, per);
    h5.set_attribute("/estimate/sigma_mean", "description", "sigma-point estimate of E[theta]");
    h5.write_vector("/estimate/std", summary.theta_std, per);
    h5.write_vector("/estimate/eta_prior_mean", summary.eta_prior_mean, "1");
    h5.write_vector("/estimate/eta_prior_std", summary.eta_prior_std, "1");
    h5.write_vector("/estimate/eta_mean", summary.eta_mean, "1");
    h5.write_matrix("/estimate/eta_covariance", summary.eta_covariance, "1", names, names);

    // Fit before and after, per observation.
    h5.write_vector("/fit/before", before, "see /observations/units");
    h5.write_vector("/fit/after", after, "see /observations/units");
    h5.write_vector("/fit/relative_error_before", err_before, "%");
    h5.write_vector("/fit/relative_error_after", err_after, "%");

    // Every iteration's ensemble.
    for (const auto& it : summary.iterations) {
      const std::string g = "/ensemble/" + std::to_string(it.iteration);
      h5.write_matrix(g + "/theta", it.theta_members, per, {}, names);
      Eigen::MatrixXd z = it.Z;
      for (Eigen::Index r = 0; r < z.rows(); ++r) z.row(r) = z.row(r).cwiseProduct(disp.factor.transpose());
      h5.write_matrix(g + "/z", z, "see /observations/units", {}, problem.observations.names);
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
      h5.set_attribute(g, "attempts", it.attempts);
      h5.set_attribute(g, "spread_factor", it.spread_factor);
      h5.set_attribute(g, "step", it.step);
      h5.set_attribute(g, "nis", it.nis);
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
    if (problem.measured) io::write_trajectory(h5, "/trajectories/observed", *problem.measured);
    if (prior_run.status.ok()) io::write_trajectory(h5, "/trajectories/prior", prior_run.trajectory);
    if (post_run.status.ok()) io::write_trajectory(h5, "/trajectories/calibrated", post_run.trajectory);

    h5.create_group("/summary");
    h5.set_attribute("/summary", "termination", estimation::to_string(summary.termination));
    h5.set_attribute("/summary", "message", summary.message);
    h5.set_attribute("/summary", "report", summary.brief_report());
    h5.set_attribute("/summary", "mode", estimation::to_string(summary.mode));
    h5.set_attribute("/summary", "sigma_points", estimation::to_string(summary.rule));
    h5.set_attribute("/summary", "failure_policy", estimation::to_string(options.failure_policy));
    h5.set_attribute("/summary", "iterations", static_cast<int>(summary.iterations.size()));
    h5.set_attribute("/summary", "simulations", summary.simulations);
    h5.set_attribute("/summary", "failures", summary.failures);
    h5.set_attribute("/summary", "mean_relative_error_before", err_before.mean());
    h5.set_attribute("/summary", "mean_relative_error_after", err_after.mean());
    h5.set_attribute("/summary", "rms_normalised_residual_before", rms_before);
    h5.set_attribute("/summary", "rms_normalised_residual_after", rms_after);
    prov.end_utc = io::utc_now();
    io::write_provenance(h5, prov);
    h5.commit();
  }

  // Terminal report.
  std::ostringstream t;
  t << summary.brief_report() << "\n\n";
  t << std::left << std::setw(14) << "parameter" << std::right << std::setw(12) << "prior"
    << std::setw(14) << "estimate" << std::setw(12) << "+- std" << "  unit\n";
  for (int j = 0; j < p; ++j) {
    t << std::left << std::setw(14) << names[static_cast<size_t>(j)] << std::right << std::setw(12)
      << fmt(prior_theta(j)) << std::setw(14) << fmt(summary.theta_of_eta_mean(j)) << std::setw(12)
      << fmt(summary.theta_std(j), 2) << "  " << problem.parameter_units[static_cast<size_t>(j)] << "\n";
  }
  t << "\n" << std::left << std::setw(14) << "observation" << std::right << std::setw(11) << "observed"
    << std::setw(11) << "prior" << std::setw(11) << "calibrated" << std::setw(9) << "error" << "  unit\n";
  const int shown = std::min(m, 24);
  for (int i = 0; i < shown; ++i) {
    t << std::left << std::setw(14) << problem.observations.names[static_cast<size_t>(i)] << std::right
      << std::setw(11) << fmt(y_disp(i)) << std::setw(11) << fmt(before(i)) << std::setw(11)
      << fmt(after(i)) << std::setw(8) << fmt(err_after(i), 2) << "%  " << disp.units[static_cast<size_t>(i)] << "\n";
  }
  if (m > shown) t << "... (" << m - shown << " more in the results file)\n";
  t << "mean relative error: " << fmt(err_before.mean(), 3) << " % (prior) -> "
    << fmt(err_after.mean(), 3) << " % (calibrated)\n"
    << "RMS residual in noise standard deviations: " << fmt(rms_before, 3) << " (prior) -> "
    << fmt(rms_after, 3) << " (calibrated); 1 = at the noise level\n";
  ctx.out << t.str() << "wrote " << output.string() << "\n";

  if (!o.summary.empty()) {
    nlohmann::ordered_json j;
    j["kind"] = "calibrate";
    j["name"] = config.name;
    j["termination"] = estimation::to_string(summary.termination);
    j["message"] = summary.message;
    j["mode"] = estimation::to_string(summary.mode);
    j["iterations"] = summary.iterations.size();
    j["simulations"] = summary.simulations;
    j["failures"] = summary.failures;
    for (int k = 0; k < p; ++k) {
      const auto& n = names[static_cast<size_t>(k)];
      j["parameters"][n] = {{"value", summary.theta_of_eta_mean(k)},
                            {"std", summary.theta_std(k)},
                            {"prior", prior_theta(k)},
                            {"prior_std", prior_std(k)},
                            {"unit", problem.parameter_units[static_cast<size_t>(k)]}};
    }
    for (int i = 0; i < m; ++i) {
      const auto& n = problem.observations.names[static_cast<size_t>(i)];
      j["fit"][n] = {{"observed", y_disp(i)},
                     {"noise_std", noise_disp(i)},
                     {"prior", before(i)},
                     {"calibrated", after(i)},
                     {"relative_error_prior_percent", err_before(i)},
                     {"relative_error_percent", err_after(i)},
                     {"unit", disp.units[static_cast<size_t>(i)]}};
    }
    j["mean_relative_error_prior_percent"] = err_before.mean();
    j["mean_relative_error_percent"] = err_after.mean();
    j["rms_normalised_residual_prior"] = rms_before;
    j["rms_normalised_residual"] = rms_after;
    io::write_text_file(o.summary, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
    ctx.out << "wrote " << o.summary.string() << "\n";
  }

  if (!summary.ok()) {
    throw RunFailure("calibration ended early (" + std::string(estimation::to_string(summary.termination)) +
                     "): " + summary.message + "; what was done is in " + output.string());
  }
  return kExitOk;
}

}  // namespace

void register_calibrate(CLI::App& app, CommandContext& ctx) {
  register_calibration_sections();
  auto opts = std::make_shared<CalibrateOptions>();
  CLI::App* sub = app.add_subcommand(
      "calibrate", "Calibrate global parameters from volume/pressure curves (Unscented Transform)");
  sub->add_option("config", opts->config, "Config file (YAML) with observations:, estimate:, calibration:")
      ->required();
  sub->add_option("-o,--output", opts->output, "Results file (HDF5); default results/<config>-calibrate.h5");
  sub->add_option("--summary", opts->summary, "Also write the estimates and the fit as JSON");
  sub->add_option("--threads", opts->threads, "Threads for the ensemble (default: all cores)")
      ->check(CLI::PositiveNumber);
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx] { ctx.run = [opts, &ctx] { return run_calibrate(*opts, ctx); }; });
}

}  // namespace sigmaheart::app
