// `sigmaheart calibrate CONFIG`: Unscented-Transform calibration of global parameters from LV
// volume (and pressure) curves or typed-in indices (Marchesseau et al. 2013, Biomech Model
// Mechanobiol 12:815; docs/estimation.md s.3). Sections of the config: app/calibration_setup.h; what
// is written: app/io/calibration_h5.h.
#include "app/calibration_setup.h"
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/calibration_h5.h"
#include "app/progress.h"
#include "estimation/fit_report.h"
#include "estimation/forward_model.h"
#include "estimation/least_squares.h"
#include "estimation/mpi.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>

namespace sigmaheart::app {

namespace {

// Progress per iteration (and per shrink retry) of the UT.
std::function<void(const estimation::UtProgress&)> ut_progress(ProgressLine& progress) {
  auto stage = std::make_shared<std::pair<int, int>>(-1, -1);  // iteration, attempt
  return [&progress, stage](const estimation::UtProgress& p) {
    if (p.iteration != stage->first || p.attempt != stage->second) {
      if (stage->first >= 0) progress.finish();
      *stage = {p.iteration, p.attempt};
      // A batch of one run is a centre run (a backtracking step, or the fit at the estimate).
      // Local runs of a global start side by side report each finished local run, not members.
      std::string what = p.iteration == -1   ? std::string("global start screen")
                         : p.iteration == -2 ? std::string("global start: local runs side by side")
                                             : "iteration " + std::to_string(p.iteration + 1) +
                                                   (p.total == 1 ? std::string(" (centre run)") : std::string());
      if (p.attempt > 0) {
        what += p.total == 1 ? " (damped candidate " + std::to_string(p.attempt) + ")"
                             : " (retry " + std::to_string(p.attempt) + ", smaller spread)";
      }
      progress.start(what, p.total);
    }
    progress.update(p.done);
  };
}

int run_calibrate(const StudyOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  const CalibrationProblem problem = parse_calibration_problem(config);
  StudyRun study(o, ctx, config, "calibrate");

  auto simulator = config.simulator.make();
  const std::vector<std::string> names = problem.prior.names();
  estimation::SimulatorForwardModel forward(*simulator, *problem.observer, names);

  const bool root = ctx.root();
  const int ranks = ctx.ranks;
  estimation::UtOptions options = problem.options;
  const int threads = set_up_study_ensemble(o, ctx, options.ensemble);
  study.attach(options.ensemble);
  ProgressLine progress(ctx.err, "calibrate", root);
  options.progress = ut_progress(progress);

  estimation::UtCalibration calibration(forward, problem.prior, problem.observations, options);
  if (const std::string invalid = calibration.validate(); !invalid.empty()) {
    throw InputError(config.file.root()["calibration"].location(), invalid);
  }
  if (root) {
    spdlog::info("calibrating {} parameter(s) of {} against {} observation(s) ({}, {} threads)",
                 names.size(), simulator->name(), problem.observations.size(),
                 problem.least_squares_method ? std::string("MAP least squares, Ceres")
                                              : std::string(estimation::to_string(options.mode)) + ", " +
                                                    estimation::to_string(options.sigma.rule),
                 threads);
  }
  estimation::LeastSquaresOptions lsq = problem.least_squares;
  lsq.ensemble = options.ensemble;
  lsq.ensemble.progress = nullptr;
  lsq.ensemble.checkpoint_scope = "least-squares";
  std::optional<estimation::LeastSquaresSummary> map;
  estimation::UtSummary summary;
  if (problem.least_squares_method) {
    map = estimation::solve_map(forward, problem.prior, problem.observations, lsq);
    summary = estimation::as_calibration_summary(*map);
    summary.theta_prior_std = problem.prior.prior_theta_std();
  } else {
    summary = calibration.run();
  }
  progress.finish();
  if (problem.least_squares_reference) {
    if (root) spdlog::info("reference: the MAP point by least squares (Ceres)");
    map = estimation::solve_map(forward, problem.prior, problem.observations, lsq);
  }
  std::optional<estimation::PriorConflict> conflict;
  if (summary.eta_mean.size() == problem.prior.size() && summary.eta_mean.allFinite()) {
    conflict = estimation::prior_conflict(problem.prior, summary.eta_mean);
  }
  std::optional<estimation::FitReport> fit_report;
  if (summary.fit_after && summary.fit_after->status.ok()) {
    fit_report = estimation::make_fit_report(
        problem.observations, summary.fit_after->z,
        estimation::PosteriorSpread{summary.names, summary.eta_covariance, summary.eta_prior_std});
    if (conflict) estimation::note_prior_conflict(*fit_report, *conflict);
  }

  // Curves at the prior and at the estimate, for the plots.
  const model::RunResult prior_run = simulator->run(forward.full_theta(summary.theta_prior));
  const model::RunResult post_run = simulator->run(forward.full_theta(summary.theta_of_eta_mean));

  const std::filesystem::path output = study.output(summary.ok());
  if (root) {
    io::CalibrationResults results;
    results.problem = &problem;
    results.summary = &summary;
    results.failure_policy = options.failure_policy;
    results.space = &config.simulator.parameters;
    results.estimated_theta = forward.full_theta(summary.theta_of_eta_mean);
    if (prior_run.status.ok()) results.prior_curves = prior_run.trajectory;
    if (post_run.status.ok()) results.calibrated_curves = post_run.trajectory;
    if (problem.curve_sampling) {
      const observers::CurveSampler sampler(*problem.curve_sampling, simulator->channels());
      const auto aligned = [&](const model::RunResult& run, std::optional<observers::AlignedBeat>& out) {
        observers::AlignedBeat beat;
        if (run.status.ok() && sampler.aligned_beat(run.trajectory, beat).ok()) out = std::move(beat);
      };
      aligned(prior_run, results.prior_aligned);
      aligned(post_run, results.calibrated_aligned);
    }
    if (fit_report) results.fit_report = &*fit_report;
    if (map) results.map = &*map;
    results.prior_conflict = conflict;

    fill_provenance(prov, config, ctx, "calibrate", threads, ranks);
    io::write_calibration_h5(output, results, prov);
    report_written(ctx, io::calibration_report(results), output, study.summary(summary.ok()),
                   [&](const std::filesystem::path& p) { io::write_calibration_json(p, config.name, results, prov); });
  }
  // Not a success (docs/estimation.md s.9): say what happened, exit 1; the results are written.
  return study.end(ctx, summary.ok(),
                   "calibration " + std::string(estimation::to_string(summary.termination)) + ": " + summary.message +
                       "; the results (status included) are in");
}

}  // namespace

void register_calibrate(CLI::App& app, CommandContext& ctx) {
  add_study_command(app, ctx, "calibrate",
                    "Calibrate global parameters from volume/pressure curves (Unscented Transform)",
                    {"Config file (YAML) with observations:, estimate:, calibration:",
                     "Also write the estimates and the fit as JSON", "Threads for the ensemble (default: all cores)"},
                    run_calibrate);
}

}  // namespace sigmaheart::app
