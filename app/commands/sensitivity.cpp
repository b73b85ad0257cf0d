// `sigmaheart sensitivity CONFIG`: a one-at-a-time, Morris or Sobol' study of the configured
// simulator's observer outputs (docs/estimation.md s.6), or of an analytic test function with exact
// indices, so a study set-up can be checked with the same command. The section is described in
// app/sensitivity_setup.h, the results file in app/io/sensitivity_h5.h.
//
// Usage: sigmaheart sensitivity CONFIG [-o OUT.h5] [--summary OUT.json] [--threads N] [--set k=v]
//
// Results: results/<config>-sensitivity.h5 (or -o), kind "sensitivity". Outputs are in clinical
// units (mL, mmHg, mL/s, mmHg/s, durations in ms, EF in %); parameters in SI.
// MPI: every rank parses the config and runs the study collectively (the design goes through the
// configured Ensemble, which spreads runs over ranks and gathers them on every rank); only the root
// rank prints and writes.
// Exit codes: 0 done; 2 bad config (file:line:column); 1 the study could not be completed (e.g. a
// Sobol' design with failed runs under failure_policy: stop, or a failed nominal run of OAT): the
// results file and the JSON summary are still written and list the failed runs.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/results.h"
#include "app/io/sensitivity_h5.h"
#include "app/progress.h"
#include "app/sensitivity_setup.h"

#include <omp.h>
#include <spdlog/spdlog.h>


namespace sigmaheart::app {

namespace {

int run_sensitivity(const StudyOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  SensitivitySetup setup = parse_sensitivity(config);
  StudyRun run(o, ctx, config, "sensitivity");
  estimation::EnsembleOptions ensemble = setup.ensemble();
  run.attach(ensemble);
  if (o.threads > 0) ensemble.threads = o.threads;
  ensemble.communicator = ctx.comm;  // members spread over the ranks, if several
  if (ensemble.threads == 1 && ensemble.backend == estimation::Backend::kThreads) {
    ensemble.backend = estimation::Backend::kSerial;
  }
  const int threads = ensemble.backend == estimation::Backend::kSerial ? 1
                      : ensemble.threads > 0                           ? ensemble.threads
                                                                       : omp_get_max_threads();
  const char* method = to_string(setup.method);
  spdlog::info("sensitivity study '{}': {} of {} ({} parameters, {} outputs, {} runs, {} threads)",
               config.name, method, setup.model_kind, setup.prior.size(),
               setup.model->outputs().size(), setup.runs(), threads);
  ProgressLine progress(ctx.err, "sensitivity", ctx.root());
  ensemble.progress = [&progress](int done, int) { progress.update(done); };
  setup.set_ensemble(ensemble);
  fill_provenance(prov, config, ctx, "sensitivity", threads, ctx.ranks);
  prov.seed = setup.seed();

  progress.start(std::string(method) + " design", setup.runs());
  SensitivitySummary summary;
  try {
    summary = run_sensitivity_study(setup);
  } catch (const std::invalid_argument& e) {
    throw InputError(config.file.root()["sensitivity"].location(), e.what());
  }
  progress.finish();
  const estimation::sensitivity::StudySummary& study = study_of(summary);
  const std::filesystem::path output = run.output(study.ok());
  if (ctx.root()) {
    io::Hdf5Writer h5(output);
    io::write_sensitivity_h5(h5, setup, summary);
    prov.end_utc = io::utc_now();
    io::write_provenance(h5, prov);
    h5.commit();
    report_written(ctx, io::sensitivity_report(setup, summary), output, run.summary(study.ok()),
                   [&](const std::filesystem::path& p) {
                     const auto js = io::sensitivity_json(config.name, setup, summary, output.string(), prov);
                     io::write_text_file(p, [&](std::ostream& f) { f << js.dump(2) << "\n"; });
                   });
  }
  run.finish();
  if (!study.ok()) {
    throw RunFailure("sensitivity study '" + config.name + "': " + study.message +
                     " (failed runs listed in " + output.string() + ", /analysis/failed)" + run.kept_note());
  }
  return kExitOk;
}

}  // namespace

void register_sensitivity(CLI::App& app, CommandContext& ctx) {
  add_study_command(app, ctx, "sensitivity",
                    "One-at-a-time, Morris or Sobol' study of the model outputs (section sensitivity:)",
                    {"Config file (YAML) with a sensitivity: section", "Also write the indices (clinical units) as JSON",
                     "Threads for the design runs (default: the config's, else all cores)"},
                    run_sensitivity);
}

}  // namespace sigmaheart::app
