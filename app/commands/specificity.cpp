// `sigmaheart specificity CONFIG`: calibrate every case of a cohort with one calibration set-up,
// then ask which parameters separate two groups (docs/estimation.md s.7; estimation/specificity). The
// sections are described in app/specificity_setup.h (cases:, specificity:) and
// app/calibration_setup.h (observations: without file:, estimate:, calibration:), the results
// file in app/io/specificity_h5.h.
//
// Every case is parsed (its observation file read, its indices computed) and its calibration
// validated before any calibration runs, so bad input is reported up front (exit 2,
// file:line:column).
//
// Parallelism (specificity.parallel): `cases` calibrates that many cases at once, each with a
// serial ensemble; `ensemble` calibrates the cases in order, each with a threaded ensemble; `auto`
// takes `cases` when the cohort has at least twice as many cases as threads. A UT iteration is
// p + 1 simplex members plus one serial centre run, so on 2 threads a threaded ensemble of a
// 5-parameter calibration keeps both threads busy only 6/7 of the time, while whole cases keep
// them busy until the last one. The numbers do not depend on the choice. Only the root rank prints
// and writes.
//
// Exit codes: 0 done (cases whose calibration failed are dropped, listed and warned about: the
// exclusion policy of estimation/specificity/specificity.h); 2 bad input; 1 when the statistics
// cannot be computed (fewer than specificity.min_cases_per_group calibrated cases in a compared
// group), with status "no-statistics" and every case's status in the results and the summary.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/results.h"
#include "app/io/specificity_h5.h"
#include "app/progress.h"
#include "app/specificity_setup.h"
#include "estimation/forward_model.h"

#include <omp.h>
#include <spdlog/fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <map>
#include <memory>

namespace sigmaheart::app {

namespace {

namespace sp = estimation::specificity;

int run_specificity_command(const StudyOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const auto wall_start = std::chrono::steady_clock::now();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  const SpecificitySetup setup = parse_specificity_setup(config);
  StudyRun study(o, ctx, config, "specificity");
  const int n = static_cast<int>(setup.cases.size());

  io::SpecificityRun run;
  run.threads = o.threads > 0 ? o.threads : setup.section.threads > 0 ? setup.section.threads : omp_get_max_threads();
  run.by_case = run.threads > 1 && (setup.section.parallel == SpecificityParallel::kCases ||
                                    (setup.section.parallel == SpecificityParallel::kAuto && n >= 2 * run.threads));
  const int ensemble_threads = run.by_case ? 1 : run.threads;  // of each case's calibration

  // One simulator and forward model per case (each case calibrates on its own clones).
  std::vector<std::unique_ptr<model::Simulator>> simulators;
  std::vector<std::unique_ptr<estimation::SimulatorForwardModel>> forwards;
  for (int i = 0; i < n; ++i) {
    simulators.push_back(config.simulator.make());
    forwards.push_back(std::make_unique<estimation::SimulatorForwardModel>(
        *simulators.back(), *setup.problems[static_cast<size_t>(i)].observer, setup.names));
    if (const std::string m = validate_case(setup.problems[static_cast<size_t>(i)], *forwards.back()); !m.empty()) {
      const auto& c = setup.cases[static_cast<size_t>(i)];
      throw InputError(c.where, "case '" + c.name + "': " + m);
    }
  }
  const std::vector<sp::CohortCase> cohort = cohort_of(setup);
  std::map<std::string, size_t> index_of;
  for (size_t i = 0; i < cohort.size(); ++i) index_of[cohort[i].id] = i;
  spdlog::info("specificity study '{}': {} cases, {} parameters ({}), {} threads over {}", config.name, n,
               setup.names.size(), fmt::join(setup.names, ", "), run.threads,
               run.by_case ? "cases" : "each case's ensemble");

  ProgressLine line(ctx.err, "specificity", ctx.root());
  line.start("calibrating cases", n);
  sp::SpecificityOptions so;
  so.parameters = setup.names;
  so.group_a = setup.section.group_a;
  so.group_b = setup.section.group_b;
  so.lda_shrinkage = setup.section.lda_shrinkage;
  so.adjust = setup.section.adjust;
  so.alpha = setup.section.alpha;
  so.min_cases_per_group = setup.section.min_cases_per_group;
  so.case_threads = run.by_case ? run.threads : 1;
  so.communicator = ctx.comm;  // cases spread over the ranks
  estimation::EnsembleOptions recorded;
  study.attach(recorded);
  so.checkpoint = recorded.checkpoint;
  so.progress = [&line](int done, int, const std::string&) { line.update(done); };
  const sp::SpecificitySummary summary = sp::run_specificity(
      cohort,
      [&](const sp::CohortCase& c) {
        const size_t i = index_of.at(c.id);
        return calibrate_case(setup.problems[i], *forwards[i], ensemble_threads, so.checkpoint, "case:" + c.id);
      },
      so);
  line.finish();
  run.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  const std::filesystem::path output = study.output(summary.ok());
  if (ctx.root()) {
    fill_provenance(prov, config, ctx, "specificity", run.threads, ctx.ranks);
    {
      io::Hdf5Writer h5(output);
      io::write_specificity_h5(h5, setup, summary, run);
      prov.end_utc = io::utc_now();
      io::write_provenance(h5, prov);
      h5.commit();
    }
    report_written(ctx, io::specificity_report(config.name, setup, summary, run), output, study.summary(summary.ok()),
                   [&](const std::filesystem::path& p) {
                     const auto j = io::specificity_json(config.name, setup, summary, run, output.string(), prov);
                     io::write_text_file(p, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
                   });
  }
  if (!summary.failed_cases.empty() && summary.ok()) {
    spdlog::warn("{} of {} calibrations failed and were left out of the statistics (listed above and "
                 "in /failed)", summary.failed_cases.size(), n);
  }
  return study.end(ctx, summary.ok(),
                   "specificity study '" + config.name + "': " + summary.message + "; per-case results in");
}

}  // namespace

void register_specificity(CLI::App& app, CommandContext& ctx) {
  add_study_command(app, ctx, "specificity", "Calibrate a cohort and find the parameters that separate two groups",
                    {"Config file (YAML) with cases:, observations:, estimate:, calibration: "
                     "(and optionally specificity:)",
                     "Also write the per-case estimates and the statistics as JSON",
                     "Threads (default: specificity.threads, else all cores)"},
                    run_specificity_command);
}

}  // namespace sigmaheart::app
