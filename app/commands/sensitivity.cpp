// `sigmaheart sensitivity CONFIG`: a one-at-a-time, Morris or Sobol' study of the configured
// simulator's observer outputs (ESTIMATION.md s.6), or of an analytic test function with exact
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

#include <memory>

namespace sigmaheart::app {

namespace {

struct SensitivityCommandOptions {
  std::filesystem::path config;
  std::filesystem::path output;   // empty: default_output_path(config, "sensitivity")
  std::filesystem::path summary;  // empty: no JSON summary
  int threads = 0;                // > 0: overrides sensitivity.ensemble.threads
  std::vector<std::string> overrides;
};

int run_sensitivity(const SensitivityCommandOptions& o, CommandContext& ctx) {
  io::Provenance prov;
  prov.start_utc = io::utc_now();
  const Config config = load_config(o.config, o.overrides, *ctx.models);
  SensitivitySetup setup = parse_sensitivity(config);
  const std::filesystem::path output =
      !o.output.empty() ? o.output : default_output_path(o.config, "sensitivity");
  estimation::EnsembleOptions ensemble = setup.ensemble();
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
  if (ctx.root()) {
    io::Hdf5Writer h5(output);
    io::write_sensitivity_h5(h5, setup, summary);
    prov.end_utc = io::utc_now();
    io::write_provenance(h5, prov);
    h5.commit();
    ctx.out << io::sensitivity_report(setup, summary) << "wrote " << output.string() << "\n";
    if (!o.summary.empty()) {
      const auto js = io::sensitivity_json(config.name, setup, summary, output.string());
      io::write_text_file(o.summary, [&](std::ostream& f) { f << js.dump(2) << "\n"; });
      ctx.out << "wrote " << o.summary.string() << "\n";
    }
  }
  if (!study.ok()) {
    throw RunFailure("sensitivity study '" + config.name + "': " + study.message +
                     " (failed runs listed in " + output.string() + ", /analysis/failed)");
  }
  return kExitOk;
}

}  // namespace

void register_sensitivity(CLI::App& app, CommandContext& ctx) {
  register_config_section({"sensitivity", [](const Config& c) { parse_sensitivity(c); }});
  auto opts = std::make_shared<SensitivityCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "sensitivity", "One-at-a-time, Morris or Sobol' study of the model outputs (section sensitivity:)");
  sub->add_option("config", opts->config, "Config file (YAML) with a sensitivity: section")->required();
  sub->add_option("-o,--output", opts->output,
                  "Results file (HDF5); default results/<config>-sensitivity.h5");
  sub->add_option("--summary", opts->summary, "Also write the indices (clinical units) as JSON");
  sub->add_option("--threads", opts->threads, "Threads for the design runs (default: the config's, else all cores)")
      ->check(CLI::PositiveNumber);
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx] { ctx.run = [opts, &ctx] { return run_sensitivity(*opts, ctx); }; });
}

}  // namespace sigmaheart::app
