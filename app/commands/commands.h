// The subcommands of `sigmaheart`. Each command file defines register_<name>(app, ctx), which adds
// its subcommand and options to `app` and, when that subcommand is chosen, sets ctx.run to the
// work to do; cli.cpp calls every register function once. A new command (calibrate,
// sensitivity, personalize, benchmark) adds one declaration here, one call in cli.cpp and its
// source in app/CMakeLists.txt.
//
// Commands report bad input by throwing InputError (exit code 2) and failed work by throwing
// RunFailure (exit code 1); ctx.run returns the exit code otherwise (normally 0).
#pragma once

#include "app/config.h"
#include "app/io/results.h"
#include "estimation/ensemble.h"
#include "estimation/parallel/communicator.h"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace sigmaheart::app {

struct CommandContext {
  std::ostream& out;          // results and tables (stdout)
  std::ostream& err;          // errors (stderr); logs go through spdlog
  std::string command_line;   // the whole invocation, for provenance
  std::function<int()> run;   // set by the chosen subcommand
  // The rank context (set up once by run_cli): every rank parses the config and runs the
  // estimator's collective calls; only the root rank prints results and writes files. On other
  // ranks `out`, `err` and spdlog are silent and io::AtomicFile discards what is written (so
  // writers need no guard; `if (!ctx.root())` may skip the work of preparing output). Pass
  // `comm` to EnsembleOptions::communicator to spread members over the ranks. run_cli makes all
  // ranks exit with the largest exit code of any rank.
  int rank = 0;
  int ranks = 1;
  estimation::parallel::Communicator* comm = nullptr;  // never null inside a command
  bool root() const { return rank == 0; }
  // The models configs may name (tests add stand-ins; see run_cli in app/cli.h).
  const model::ModelRegistry* models = &model::builtin_models();
  // The top-level config sections besides simulator: (validate checks each one present).
  const ConfigSections* sections = &builtin_config_sections();
};

void register_simulate(CLI::App& app, CommandContext& ctx);
void register_validate(CLI::App& app, CommandContext& ctx);
void register_params(CLI::App& app, CommandContext& ctx);
void register_calibrate(CLI::App& app, CommandContext& ctx);
void register_synthesize(CLI::App& app, CommandContext& ctx);
void register_sensitivity(CLI::App& app, CommandContext& ctx);
void register_specificity(CLI::App& app, CommandContext& ctx);
void register_personalize(CLI::App& app, CommandContext& ctx);
void register_benchmark(CLI::App& app, CommandContext& ctx);  // 3D mechanics benchmarks: land, arostica
void add_land_benchmark(CLI::App& benchmark, CommandContext& ctx);      // benchmark_land.cpp
void add_arostica_benchmark(CLI::App& benchmark, CommandContext& ctx);  // benchmark_arostica.cpp
void register_serve(CLI::App& app, CommandContext& ctx);      // UM-Bridge server (app/blackbox/)
void register_therapy(CLI::App& app, CommandContext& ctx);    // pacing therapies (therapy.cpp)
void register_observe(CLI::App& app, CommandContext& ctx);    // volume curves from images

// Helpers shared by the commands ---------------------------------------------------------------

// Adds the repeatable `--set key=value` option (see expand_override_key in config.h).
void add_set_option(CLI::App& sub, std::vector<std::string>& overrides);
// A provenance with start_utc set to now (a command's first line, so the time covers its work).
io::Provenance started_provenance();
// Fills the provenance every results file carries (docs/architecture.md, "Results files") from the
// config and the invocation: kind, name, config file and text, overrides, command line, seed,
// thread and rank counts. start_utc and end_utc stay the command's to set.
void fill_provenance(io::Provenance& prov, const Config& config, const CommandContext& ctx,
                     const std::string& kind, int threads, int ranks = 1);

// results/<config-stem>-<kind>.h5 (relative to the working directory).
std::filesystem::path default_output_path(const std::filesystem::path& config,
                                          const std::string& kind);

// The options of the commands that only read a config (params, validate).
struct ConfigOptions {
  std::filesystem::path config;
  std::vector<std::string> overrides;  // "key=value"
};

// A subcommand and the options it fills (shared with its callback).
template <class Options>
struct BoundCommand {
  CLI::App* app;
  std::shared_ptr<Options> options;
};

// Adds subcommand `name` to `parent`; when it is chosen, ctx.run calls run(options, ctx). The
// caller adds the command's own options to the returned app.
template <class Options>
BoundCommand<Options> add_command(CLI::App& parent, CommandContext& ctx, const std::string& name,
                                  const std::string& about, int (*run)(const Options&, CommandContext&)) {
  auto options = std::make_shared<Options>();
  CLI::App* sub = parent.add_subcommand(name, about);
  sub->callback([options, run, &ctx] { ctx.run = [options, run, &ctx] { return run(*options, ctx); }; });
  return {sub, options};
}

// add_command for a command on a config: the positional config (required; Options::config) and
// --set (Options::overrides) come first.
template <class Options>
BoundCommand<Options> add_config_command(CLI::App& app, CommandContext& ctx, const std::string& name,
                                         const std::string& about, int (*run)(const Options&, CommandContext&),
                                         const std::string& config_help = "Config file (YAML)") {
  BoundCommand<Options> command = add_command(app, ctx, name, about, run);
  command.app->add_option("config", command.options->config, config_help)->required();
  add_set_option(*command.app, command.options->overrides);
  return command;
}

// The options the estimation commands (calibrate, personalize, sensitivity, specificity) share.
struct StudyOptions {
  std::filesystem::path config;
  std::filesystem::path output;   // empty: default_output_path(config, <command>)
  std::filesystem::path summary;  // empty: no JSON summary
  int threads = 0;                // > 0: overrides the config's thread count
  std::vector<std::string> overrides;
  bool resume = false;            // --resume: continue from <output>.checkpoint
};

// The help texts of an estimation command's positional config, --summary and --threads.
struct StudyHelp {
  std::string config;
  std::string summary;
  std::string threads;
};

// Adds subcommand `name` with the options of StudyOptions (config, -o/--output, --summary,
// --threads, --set); when it is chosen, ctx.run calls run(options, ctx).
void add_study_command(CLI::App& app, CommandContext& ctx, const std::string& name, const std::string& about,
                       const StudyHelp& help, int (*run)(const StudyOptions&, CommandContext&));

// Before any work: each output path (empty ones skipped) must differ from every input and from
// the other outputs, and its directory must be one this process can create files in (the
// directories are created, a uniquely named probe file is made and removed). InputError at the
// option (`-o`, `--summary`) otherwise, so a run never computes for an hour to fail at the write
// or overwrites its own config. Every rank checks (the same paths give the same answer).
void check_outputs(const std::vector<std::pair<std::string, std::filesystem::path>>& outputs,
                   const std::vector<std::filesystem::path>& inputs);

// The results file of an estimation command: o.output, else default_output_path(o.config, kind).
std::filesystem::path study_output(const StudyOptions& o, const std::string& kind);

// Where a run writes the result `file`: `file` itself, or <stem>.failed<ext> beside it when the run
// did not succeed and `file` exists already, so that a failed run never replaces an earlier
// result; then "; the earlier result <file> was kept" is appended to *note (if given).
std::filesystem::path result_path(const std::filesystem::path& file, bool succeeded, std::string* note);

// What every estimation command does around its estimator (docs/architecture.md s.5, "Checkpoint
// and resume", and s.6): made after the config is loaded, before any forward run.
//  - The outputs are checked against the data files the config names (an output may not be one).
//  - The checkpoint <output>.checkpoint (estimation/checkpoint.h): every ensemble the command
//    attaches records its finished members there; with --resume the members an earlier run of the
//    same command, config, overrides and data files finished are taken from it instead of being
//    run again. finish() removes it once the results are written; if the command ends otherwise
//    (interrupted, killed, an error) it stays, and the log says how to continue.
//  - A run that did not succeed never replaces an earlier result: output(false) and summary(false)
//    are <stem>.failed<ext> when the file exists already, and kept_note() says so.
class StudyRun {
 public:
  StudyRun(const StudyOptions& o, const CommandContext& ctx, const Config& config, const std::string& kind);
  ~StudyRun();
  StudyRun(const StudyRun&) = delete;
  StudyRun& operator=(const StudyRun&) = delete;

  // Records the members of an ensemble in the checkpoint; `scope` separates independent streams of
  // work (a case of a cohort; estimation/checkpoint.h).
  void attach(estimation::EnsembleOptions& ensemble, const std::string& scope = "") const;
  std::filesystem::path output(bool succeeded);
  std::filesystem::path summary(bool succeeded);  // empty when no --summary
  // "; the earlier result <file> was kept" when output(false) moved this run's results aside.
  std::string kept_note() const { return kept_note_; }
  // The results are written: logs what the checkpoint saved and removes it.
  void finish();
  // The command's end once its results are written: finish(), then kExitOk when it succeeded, else
  // stopped_early(ctx, "<failure> <the results file output() gave><kept_note()>").
  int end(const CommandContext& ctx, bool succeeded, const std::string& failure);
  const std::filesystem::path& checkpoint_path() const { return checkpoint_path_; }

 private:
  std::filesystem::path aside(const std::filesystem::path& file, bool succeeded);

  std::filesystem::path output_;
  std::filesystem::path written_;  // what output() last returned
  std::filesystem::path summary_;
  std::filesystem::path checkpoint_path_;
  std::unique_ptr<estimation::MemberCheckpoint> checkpoint_;
  std::string kept_note_;
  bool root_ = true;
  bool finished_ = false;
};

// The ensemble of calibrate and personalize: --threads (o.threads > 0) over the config's count,
// the members spread over ctx's ranks, the serial backend on one thread. Returns the thread count
// (the config's, else omp_get_max_threads()) for the log and the provenance.
int set_up_study_ensemble(const StudyOptions& o, const CommandContext& ctx, estimation::EnsembleOptions& ensemble);

// The end of a run whose estimator failed: kExitRuntimeFailure off the root rank (which printed
// nothing); on the root rank throws RunFailure(message).
int stopped_early(const CommandContext& ctx, const std::string& message);

// Prints `report` and "wrote <output>"; with a non-empty `summary` path, calls
// write_summary(summary) and prints "wrote <summary>".
void report_written(CommandContext& ctx, const std::string& report, const std::filesystem::path& output,
                    const std::filesystem::path& summary,
                    const std::function<void(const std::filesystem::path&)>& write_summary);

// `sigmaheart simulate`: one forward run of the configured simulator.
struct SimulateOptions {
  std::filesystem::path config;
  std::filesystem::path output;   // empty: default_output_path(config, "simulate")
  std::filesystem::path csv;      // empty: no CSV
  std::filesystem::path summary;  // empty: no JSON summary
  std::filesystem::path vtu;      // empty: no ParaView time series (3D models only)
  std::vector<std::string> overrides;            // "key=value"
};
int run_simulate(const SimulateOptions& options, CommandContext& ctx);

// `sigmaheart therapy`: the therapies of the config's therapy: section (app/therapy_setup.h), in
// process (the Python API calls it as the command line does).
int run_therapy(const StudyOptions& options, CommandContext& ctx);

}  // namespace sigmaheart::app
