// `sigmaheart personalize CONFIG`: regional personalisation with the Reduced-Order Unscented
// Kalman Filter (Moireau & Chapelle 2011; docs/estimation.md s.4): per-segment parameters (one
// contractility per AHA segment, as Marchesseau et al. 2013, Med Image Anal 17:816) and any global
// ones, from regional volume curves. The config's `personalize:` section: app/personalize_setup.h;
// what is written: app/io/roukf_h5.h (HDF5 of kind "personalize" with every filter step, optional
// JSON summary, a table on the terminal). Exit codes: 2 bad input (file:line:column), 1 when the
// filter aborts (results written).
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/roukf_h5.h"
#include "app/personalize_setup.h"
#include "app/progress.h"
#include "estimation/mpi.h"
#include "estimation/roukf/roukf.h"

#include <spdlog/spdlog.h>

#include <memory>

namespace sigmaheart::app {

namespace {

// Progress per pass over the measured beat.
std::function<bool(const estimation::RoukfStep&)> roukf_progress(ProgressLine& progress, int passes,
                                                                  int frames) {
  auto stage_beat = std::make_shared<int>(-1);
  return [&progress, stage_beat, passes, frames](const estimation::RoukfStep& s) {
    if (s.beat != *stage_beat) {
      if (*stage_beat >= 0) progress.finish();
      *stage_beat = s.beat;
      progress.start("pass " + std::to_string(s.beat + 1) + "/" + std::to_string(passes) +
                         " over " + std::to_string(frames) + " frames",
                     frames);
    }
    progress.update(s.frame + 1);
    return true;
  };
}

int run_personalize(const StudyOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  PersonalizeProblem problem = parse_personalize(config);
  StudyRun study(o, ctx, config, "personalize");

  std::unique_ptr<model::SteppableSimulator> simulator = model::into_steppable(config.simulator.make());
  if (!simulator) {
    config.file.root()["simulator"]["model"].fail(
        "model " + config.simulator.model + " cannot be advanced step by step; personalize needs a "
        "steppable simulator (lumped-regional, lumped-sphere, lv-3d, or external with steppable: true)");
  }
  // Zones, the data's volume shares, the alignment on end-diastole (app/personalize_setup.h).
  simulator = prepare_personalize_model(config, problem, std::move(simulator));
  const model::SteppableSimulator* steppable = simulator.get();
  estimation::RoukfOptions& filter = problem.filter;
  const int threads = set_up_study_ensemble(o, ctx, filter.ensemble);
  study.attach(filter.ensemble);
  const int frames = static_cast<int>(problem.data.times.size());
  const bool root = ctx.root();

  ProgressLine progress(ctx.err, "personalize", root);
  filter.on_step = roukf_progress(progress, filter.beats, frames);
  if (root) {
    spdlog::info("personalize: {} parameter(s) of {} from {} channel(s) x {} frames, {} pass(es), "
                 "{} threads",
                 problem.prior.size(), simulator->name(), problem.data.channels.size(), frames,
                 filter.beats, threads);
    for (const std::string& note : problem.notes) spdlog::info("personalize: {}", note);
  }
  const estimation::RoukfSummary summary =
      estimation::run_roukf(*steppable, problem.prior, problem.data, filter);
  progress.finish();
  if (summary.termination == estimation::RoukfTermination::kInvalidInput) {
    throw InputError(config.file.root()["personalize"].location(), summary.message);
  }

  const std::filesystem::path output = study.output(summary.ok());
  if (root) {
    io::RoukfResults results;
    results.problem = &problem;
    results.summary = &summary;
    results.space = &problem.space;
    results.threads = threads;
    fill_provenance(prov, config, ctx, "personalize", threads, ctx.ranks);
    io::write_roukf_h5(output, results, prov);
    report_written(ctx, io::roukf_report(results), output, study.summary(summary.ok()),
                   [&](const std::filesystem::path& p) { io::write_roukf_json(p, config.name, results, prov); });
  }
  return study.end(ctx, summary.ok(),
                   "the filter stopped (" + std::string(estimation::to_string(summary.termination)) +
                       "): " + summary.message + "; the steps done are in");
}

}  // namespace

void register_personalize(CLI::App& app, CommandContext& ctx) {
  add_study_command(app, ctx, "personalize", "Estimate per-segment parameters from regional volume curves (ROUKF)",
                    {"Config file (YAML) with a personalize: section",
                     "Also write the final estimates and their std as JSON",
                     "Threads for the ensemble (default: the config's, else all cores)"},
                    run_personalize);
}

}  // namespace sigmaheart::app
