#include "app/cli.h"
#include "estimation/interrupt.h"

#include <csignal>

#include "app/commands/commands.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/results.h"
#include "estimation/parallel/communicator.h"

#include <CLI/CLI.hpp>
#include <omp.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <sstream>

namespace sigmaheart::app {

namespace {

const char* kFooter = R"(Exit codes:
  0  success
  1  runtime failure (a simulation failed, an output file could not be written)
  2  bad input (config or data file, unknown key, parameter out of bounds, bad option)

Results (HDF5) go to results/<config>-<command>.h5 unless -o is given; `scripts/plot RESULT.h5`
draws them. Curves and indices are in clinical units (mL, mmHg, s), parameters in SI.)";

// Logs go to stderr so that stdout carries only results.
void setup_logging(const std::string& level) {
  if (!spdlog::get("sigmaheart")) {
    auto logger = spdlog::stderr_color_mt("sigmaheart");
    logger->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
    spdlog::set_default_logger(logger);
  }
  spdlog::set_level(spdlog::level::from_str(level));
}

std::string join_command_line(int argc, const char* const* argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (a.find_first_of(" \t\"'") != std::string::npos) a = "'" + a + "'";
    s += (i ? " " : "") + a;
  }
  return s;
}

// run_cli on this rank alone; never throws.
int run_cli_on_rank(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
                    estimation::parallel::Communicator& comm, const model::ModelRegistry& models) {
  CommandContext ctx{out, err, join_command_line(argc, argv), {}};
  ctx.models = &models;
  ctx.rank = comm.rank();
  ctx.ranks = comm.size();
  ctx.comm = &comm;
  CLI::App app{"sigmaheart: personalise Bestel-Clement-Sorine heart models from clinical data",
               "sigmaheart"};
  app.footer(kFooter);
  app.set_version_flag("--version", "sigmaheart " + io::version() + " (" + io::git_describe() + ")");
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "Log verbosity on stderr")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}))
      ->capture_default_str();
  app.require_subcommand(1);
  app.fallthrough();  // --log-level may also follow the subcommand

  register_simulate(app, ctx);
  register_validate(app, ctx);
  register_params(app, ctx);
  register_calibrate(app, ctx);
  register_synthesize(app, ctx);
  register_sensitivity(app, ctx);
  register_specificity(app, ctx);
  register_personalize(app, ctx);
  register_benchmark(app, ctx);
  register_serve(app, ctx);
  register_therapy(app, ctx);
#ifdef SIGMAHEART_HAVE_FEM
  register_observe(app, ctx);
#endif

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e, out, err);
    return code == 0 ? kExitOk : kExitBadInput;
  }

  try {
    setup_logging(ctx.root() ? log_level : std::string("off"));
    clear_named_input_files();
    estimation::install_interrupt_handlers();
    return ctx.run ? ctx.run() : kExitOk;
  } catch (const estimation::Interrupted& e) {
    err << "error: interrupted by " << (e.signal == SIGINT ? "SIGINT" : e.signal == SIGTERM ? "SIGTERM" : "a signal")
        << " before the run finished; nothing was written but the checkpoint (see above)\n";
    return kExitInterruptedBase + e.signal;
  } catch (const InputError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const RunFailure& e) {
    err << "error: " << e.what() << "\n";
    return kExitRuntimeFailure;
  } catch (const std::exception& e) {
    err << "error: " << e.what() << "\n";
    return kExitRuntimeFailure;
  } catch (...) {
    err << "error: unknown exception\n";
    return kExitRuntimeFailure;
  }
}

}  // namespace

int run_cli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
            const model::ModelRegistry& models) {
  estimation::parallel::SerialCommunicator one;
  return run_cli(argc, argv, out, err, one, models);
}

int run_cli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
            estimation::parallel::Communicator& comm, const model::ModelRegistry& models) {
  if (comm.size() <= 1) return run_cli_on_rank(argc, argv, out, err, comm, models);
  // Other ranks: silent streams (their error text is kept in case rank 0 succeeds), no file
  // writes (io::AtomicFile discards them).
  std::ostringstream discarded;
  std::ostringstream rank_err;
  const bool root = comm.root();
  int code = kExitRuntimeFailure;
  {
    io::OutputRankScope outputs(root);
    try {
      code = run_cli_on_rank(argc, argv, root ? out : discarded, root ? err : rank_err, comm, models);
    } catch (...) {  // e.g. std::bad_alloc while setting up the command line
      code = kExitRuntimeFailure;
    }
  }
  // Every rank reaches this point whatever happened in the command (run_cli_on_rank never
  // throws), so these two collectives cannot leave a rank waiting.
  const int agreed = comm.all_reduce_max(code);
  const int root_code = comm.broadcast(code, 0);
  if (!root && code != kExitOk && root_code == kExitOk) {
    std::string text = rank_err.str();
    if (text.empty()) text = "error: exit code " + std::to_string(code) + "\n";
    err << "rank " << comm.rank() << ": " << text << std::flush;
  }
  return agreed;
}

int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
            const model::ModelRegistry& models) {
  std::vector<const char*> argv = {"sigmaheart"};
  for (const auto& a : args) argv.push_back(a.c_str());
  return run_cli(static_cast<int>(argv.size()), argv.data(), out, err, models);
}

void add_set_option(CLI::App& sub, std::vector<std::string>& overrides) {
  sub.add_option("--set", overrides,
                 "Override a config value: a parameter (sigma0=1.5e5, P_at0='8 mmHg'), "
                 "numerics.<key>=value, or a full dotted path; repeatable")
      ->type_name("KEY=VALUE")
      ->allow_extra_args(false);
}

void add_study_command(CLI::App& app, CommandContext& ctx, const std::string& name, const std::string& about,
                       const StudyHelp& help, int (*run)(const StudyOptions&, CommandContext&)) {
  auto opts = std::make_shared<StudyOptions>();
  CLI::App* sub = app.add_subcommand(name, about);
  sub->add_option("config", opts->config, help.config)->required();
  sub->add_option("-o,--output", opts->output, "Results file (HDF5); default results/<config>-" + name + ".h5");
  sub->add_option("--summary", opts->summary, help.summary);
  sub->add_option("--threads", opts->threads, help.threads)
      ->check(CLI::Range(1, estimation::kMaxThreads));
  sub->add_flag("--resume", opts->resume,
                "Continue an interrupted run: members recorded in <output>.checkpoint are not run again");
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx, run, name] {
    ctx.run = [opts, &ctx, run, name] {
      check_outputs({{"-o", study_output(*opts, name)}, {"--summary", opts->summary}}, {opts->config});
      return run(*opts, ctx);
    };
  });
}

namespace {

// The same file, whether or not it exists yet (weakly canonical paths).
bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ea, eb;
  const auto ca = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
  const auto cb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
  return !ea && !eb && ca == cb;
}

}  // namespace

void check_outputs(const std::vector<std::pair<std::string, std::filesystem::path>>& outputs,
                   const std::vector<std::filesystem::path>& inputs) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    const auto& [option, path] = outputs[i];
    if (path.empty()) continue;
    const Location where{option + " " + path.string(), 0, 0};
    for (const auto& input : inputs) {
      if (same_file(path, input)) {
        throw InputError(where, "is the input file " + input.string() +
                                    "; choose another output path (the input would be overwritten)");
      }
    }
    for (size_t j = 0; j < i; ++j) {
      if (!outputs[j].second.empty() && same_file(path, outputs[j].second)) {
        throw InputError(where, "is also the " + outputs[j].first + " file; give two different paths");
      }
    }
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) {
      throw InputError(where, "is a directory; expected a file path such as results/run.h5");
    }
    const std::filesystem::path dir =
        path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
    std::filesystem::create_directories(dir, ec);
    // A probe file with a name no other process uses: this process id and a counter.
    static int probes = 0;
    const std::filesystem::path probe =
        dir / (".sigmaheart-write-test-" + std::to_string(::getpid()) + "-" + std::to_string(++probes));
    std::FILE* f = std::fopen(probe.c_str(), "wx");
    if (!f) {
      const int error = errno;
      throw InputError(where, "cannot write in " + dir.string() + ": " + std::strerror(error) +
                                  " (checked before any work)");
    }
    std::fclose(f);
    std::filesystem::remove(probe, ec);
  }
}

std::filesystem::path study_output(const StudyOptions& o, const std::string& kind) {
  return !o.output.empty() ? o.output : default_output_path(o.config, kind);
}

std::filesystem::path result_path(const std::filesystem::path& file, bool succeeded, std::string* note) {
  if (succeeded || file.empty() || !std::filesystem::exists(file)) return file;
  if (note) *note += "; the earlier result " + file.string() + " was kept";
  return file.parent_path() / (file.stem().string() + ".failed" + file.extension().string());
}

int set_up_study_ensemble(const StudyOptions& o, const CommandContext& ctx, estimation::EnsembleOptions& ensemble) {
  if (o.threads > 0) ensemble.threads = o.threads;
  ensemble.communicator = ctx.comm;  // members spread over the ranks, if several
  if (ensemble.threads == 1) ensemble.backend = estimation::Backend::kSerial;
  return ensemble.threads > 0 ? ensemble.threads : omp_get_max_threads();
}

int stopped_early(const CommandContext& ctx, const std::string& message) {
  if (!ctx.root()) return kExitRuntimeFailure;
  throw RunFailure(message);
}

void report_written(CommandContext& ctx, const std::string& report, const std::filesystem::path& output,
                    const std::filesystem::path& summary,
                    const std::function<void(const std::filesystem::path&)>& write_summary) {
  ctx.out << report << "wrote " << output.string() << "\n";
  if (!summary.empty()) {
    write_summary(summary);
    ctx.out << "wrote " << summary.string() << "\n";
  }
}

io::Provenance started_provenance() {
  io::Provenance prov;
  prov.start_utc = io::utc_now();
  return prov;
}

void fill_provenance(io::Provenance& prov, const Config& config, const CommandContext& ctx,
                     const std::string& kind, int threads, int ranks) {
  prov.kind = kind;
  prov.name = config.name;
  prov.config_file = config.file.file();
  prov.config_text = config.file.text();
  prov.overrides = config.file.overrides();
  prov.command_line = ctx.command_line;
  prov.seed = config.seed;
  prov.threads = threads;
  prov.ranks = ranks;
}

std::filesystem::path default_output_path(const std::filesystem::path& config,
                                          const std::string& kind) {
  return std::filesystem::path("results") / (config.stem().string() + "-" + kind + ".h5");
}

}  // namespace sigmaheart::app
