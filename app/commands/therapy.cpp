// `sigmaheart therapy CONFIG`: pacing therapies on a personalised heart with the uncertainty of its
// posterior (docs/estimation.md s.12): the baseline, a lead-site map over the AHA segments
// (biventricular and/or LV-only pacing), the best site with the probability that it is the best,
// and an AV/VV sweep there; for each therapy the acute response (AHR = dP/dt max change, SV, EF,
// stroke work, total activation time, septal-to-lateral work difference) with its mean and 90 %
// interval. The config's `therapy:` section: app/therapy_setup.h; what is written:
// app/io/therapy_h5.h. Exit codes: 2 bad input (file:line:column); 1 when a therapy or the
// baseline failed, or the personalisation it starts from did not converge (results written).
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/therapy_h5.h"
#include "app/progress.h"
#include "app/therapy_setup.h"
#include "estimation/therapy/therapy.h"

#include <spdlog/spdlog.h>

namespace sigmaheart::app {

namespace th = estimation::therapy;

int run_therapy(const StudyOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  TherapyProblem problem = parse_therapy(config);
  StudyRun study(o, ctx, config, "therapy");
  th::TherapyOptions& opts = problem.options;
  opts.ensemble.threads = problem.threads;
  const int threads = set_up_study_ensemble(o, ctx, opts.ensemble);
  study.attach(opts.ensemble);
  const bool root = ctx.root();
  ProgressLine progress(ctx.err, "therapy", root);
  opts.on_phase = [&progress](const std::string& phase, int members) {
    progress.finish();
    progress.start(phase, members);
  };
  opts.ensemble.progress = [&progress](int done, int) { progress.update(done); };

  const auto simulator = make_therapy_model(config, problem);
  std::optional<estimation::Posterior> posterior;
  std::vector<std::vector<int>> estimated;
  Eigen::VectorXd mean_theta = problem.base_theta;
  if (problem.personalization) {
    posterior = problem.personalization->posterior;
    estimated = problem.personalization->estimated;
    const Eigen::VectorXd m = posterior->theta_mean();
    for (size_t j = 0; j < estimated.size(); ++j)
      for (int i : estimated[j]) mean_theta(i) = m(static_cast<Eigen::Index>(j));
  }
  if (root)
    spdlog::info("therapy: {} lead site(s) x {} mode(s) on {} ({}), {} parameter(s) propagated, {} threads",
                 opts.sites().size(), opts.modes.size(), simulator->name(), problem.route,
                 posterior ? posterior->size() : 0, threads);
  th::TherapySummary summary;
  try {
    summary = th::run_therapy_study(*simulator, problem.base_theta, estimated, posterior, opts);
  } catch (const std::invalid_argument& e) {
    throw InputError(config.file.root()["therapy"].location(), e.what());
  }
  progress.finish();
  if (summary.conduction_velocity > 0.0) opts.graph.conduction_velocity = summary.conduction_velocity;  // the PV loops' beats too
  if (root && opts.velocity_from_sequence)
    spdlog::info("therapy: the paced wave at {:.3f} m/s, {}", summary.conduction_velocity, summary.conduction_source);

  // The beats at the posterior mean, baseline and best site, for the PV loops.
  io::TherapyResults results;
  results.problem = &problem;
  results.summary = &summary;
  results.space = &problem.space;
  results.mean_theta = mean_theta;
  auto beat = [&](const th::Therapy& t) -> std::optional<model::Trajectory> {
    const model::RunResult r = th::therapy_beat(*simulator, mean_theta, t, opts);
    if (!r.status.ok()) {
      spdlog::warn("the beat of '{}' at the posterior mean failed: {}", t.label, r.status.message);
      return std::nullopt;
    }
    return r.trajectory;
  };
  if (problem.pv_loops) {
    results.baseline_beat = beat(summary.baseline.therapy);
    if (summary.best >= 0) results.best_beat = beat(summary.map[static_cast<size_t>(summary.best)].therapy);
  }

  const bool personalised_ok = !problem.personalization || problem.personalization->converged;
  const bool ok = summary.ok() && personalised_ok;
  results.status = !summary.ok() ? std::string(th::to_string(summary.termination))
                   : !personalised_ok ? "personalisation not converged (" + problem.personalization->status + ")"
                                      : "ok";
  const std::filesystem::path output = study.output(ok);
  if (root) {
    fill_provenance(prov, config, ctx, "therapy", threads, ctx.ranks);
    io::write_therapy_h5(output, results, prov);
    report_written(ctx, io::therapy_report(results), output, study.summary(ok),
                   [&](const std::filesystem::path& p) { io::write_therapy_json(p, config.name, results, prov); });
  }
  const std::string why = summary.ok() ? "the prediction starts from a personalisation that did not converge (" +
                                              (problem.personalization ? problem.personalization->status : "") + ")"
                                        : summary.message;
  return study.end(ctx, ok, "therapy: " + why + "; results in");
}

void register_therapy(CLI::App& app, CommandContext& ctx) {
  add_study_command(app, ctx, "therapy",
                    "Predict pacing therapies (CRT lead sites, AV/VV delays) with the posterior's uncertainty",
                    {"Config file (YAML) with a therapy: section",
                     "Also write the lead-site map and the sweeps as JSON",
                     "Threads for the ensemble (default: the config's, else all cores)"},
                    run_therapy);
}

}  // namespace sigmaheart::app
