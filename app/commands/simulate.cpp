// `sigmaheart simulate CONFIG`: one forward run of the configured simulator with the config's
// parameter values; the periodic beat, its indices and the provenance go to a results file.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/beat_summary.h"
#include "app/io/mesh_io.h"
#include "app/io/results.h"

#include <omp.h>
#include <spdlog/spdlog.h>

namespace sigmaheart::app {

namespace {

// The states of the last beat of a model with fields (model::FieldOutput), for its ParaView time
// series, and a progress line per beat (a 3D beat takes tens of seconds).
struct BeatRecorder {
  bool keep_states = false;
  int beat = 0;
  std::vector<std::pair<double, model::State>> states;  // (time in beat [s], state)

  void attach(model::FieldOutput& fields) {
    fields.observe_steps([this](int b, double t, const model::State& s) {
      if (b != beat) {
        spdlog::info("beat {} ...", b);
        beat = b;
        states.clear();
      }
      if (keep_states) states.emplace_back(t, s);
    });
  }
};

void check_vtu_directory(const std::filesystem::path& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
    throw InputError("--vtu " + dir.string(), 0, 0, "is a file; expected a directory for the .vtu/.pvd files");
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError("--vtu " + dir.string(), 0, 0, "cannot create the directory: " + ec.message());
}

}  // namespace

int run_simulate(const SimulateOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  const std::filesystem::path output = !o.output.empty() ? o.output : default_output_path(o.config, "simulate");
  check_outputs({{"-o", output}, {"--csv", o.csv}, {"--summary", o.summary}}, {o.config});
  if (!o.vtu.empty()) check_vtu_directory(o.vtu);

  auto simulator = config.simulator.make();
  const Eigen::VectorXd theta = config.simulator.parameters.nominal();
  spdlog::info("simulating '{}' with {} ({} parameters)", config.name, simulator->name(),
               theta.size());
  BeatRecorder rec;
  rec.keep_states = !o.vtu.empty();
  if (model::FieldOutput* fields = simulator->fields()) {
    rec.attach(*fields);
  } else if (rec.keep_states) {
    throw InputError("--vtu", 0, 0, "model '" + simulator->name() + "' offers no spatial fields for ParaView (" +
                                        "a model with fields, such as lv-3d, does)");
  }
  const model::RunResult result = simulator->run(theta);
  const auto code = result.status.code;
  if (code == model::StatusCode::kOutOfBounds || code == model::StatusCode::kInvalidArgument) {
    // The model refused these parameters or numerics before integrating: bad input (exit 2).
    throw InputError(Location{config.file.file(), 0, 0},
                     "the simulator rejects this config: " + result.status.message);
  }
  // A failed run still shows what it computed (docs/architecture.md s.7): a run that did not settle
  // to a periodic beat its last whole beat, marked "not-periodic" with its indices; a run that
  // diverged or went non-finite inside a beat that beat's finite samples up to the failure, with
  // no indices. Either way the command exits 1, and as for the estimation commands a file that
  // exists already is kept and this run's goes to <stem>.failed<ext> beside it (result_path). A
  // failure without at least two finite samples has nothing to show: nothing is written and an
  // earlier result at -o stays; so does any other failure (an external program's).
  const Eigen::Index rows = result.trajectory.values.rows(), kept_rows = io::finite_rows(result.trajectory);
  const bool not_periodic = code == model::StatusCode::kNotPeriodic && rows > 1 && kept_rows == rows;
  const bool partial =
      (code == model::StatusCode::kDiverged || code == model::StatusCode::kNonFinite) && kept_rows > 1;
  const bool ok = result.status.ok();
  const std::string failure = ok ? std::string()
                                 : "simulation of '" + config.name + "' failed (" + model::to_string(code) +
                                       "): " + result.status.message;
  if (!ok && !not_periodic && !partial) throw RunFailure(failure);
  model::Trajectory beat = result.trajectory;
  if (partial) {
    beat.times.conservativeResize(kept_rows);
    beat.values.conservativeResize(kept_rows, Eigen::NoChange);
    if (rec.states.size() > static_cast<size_t>(kept_rows)) rec.states.erase(rec.states.begin() + kept_rows, rec.states.end());
    spdlog::info("failed in beat {} after {:.4f} s of it ({} samples kept), {} Newton iterations, {} step cuts",
                 result.info.beats, beat.times(kept_rows - 1), kept_rows, result.info.newton_iterations,
                 result.info.step_cuts);
  } else {
    spdlog::info("{} after {} beats (change {:.2e}), {} Newton iterations, {} step cuts{}",
                 not_periodic ? "not periodic" : "periodic", result.info.beats, result.info.periodicity_change,
                 result.info.newton_iterations, result.info.step_cuts,
                 result.info.linear_iterations > 0
                     ? fmt::format(", {} GMRES iterations", result.info.linear_iterations)
                     : std::string());
  }
  const auto indicators =
      partial ? io::failed_beat_facts(result, beat) : io::beat_indicators(result, simulator->channels());
  const std::string status = model::to_string(code);
  std::string kept;
  const std::filesystem::path h5_path = result_path(output, ok, &kept);
  const std::filesystem::path csv_path = result_path(o.csv, ok, &kept);
  const std::filesystem::path summary_path = result_path(o.summary, ok, &kept);
  // The ParaView series is named after its .pvd: <name>.failed_NNNN.vtu beside an earlier <name>.pvd.
  const std::string vtu_name =
      rec.keep_states ? result_path(o.vtu / (config.name + ".pvd"), ok, &kept).stem().string() : config.name;

  fill_provenance(prov, config, ctx, "simulate", omp_get_max_threads(), 1);

  {
    io::Hdf5Writer h5(h5_path);
    io::write_parameters(h5, "/parameters", config.simulator.parameters, theta);
    std::vector<std::string> sources;
    for (auto s : config.simulator.sources) sources.emplace_back(to_string(s));
    h5.write_strings("/parameters/source", sources);
    io::write_trajectory(h5, "/trajectories/simulated", beat);
    h5.set_attribute("/trajectories/simulated", "model", simulator->name());
    h5.set_attribute("/trajectories/simulated", "description",
                     partial        ? "the failing beat up to its last finite sample (see /summary status and "
                                      "message), time from its start"
                     : not_periodic ? "the last beat, not periodic (see /summary status), time from its start"
                                    : "the last (periodic) beat, time from its start");
    io::write_indicators(h5, "/summary", indicators);
    h5.set_attribute("/summary", "status", status);
    if (!ok) h5.set_attribute("/summary", "message", result.status.message);
    h5.set_attribute("/summary", "newton_iterations", result.info.newton_iterations);
    h5.set_attribute("/summary", "step_cuts", result.info.step_cuts);
    prov.end_utc = io::utc_now();
    io::write_provenance(h5, prov);
    h5.commit();
  }
  if (!csv_path.empty()) io::write_trajectory_csv(csv_path, beat);
  if (!summary_path.empty()) io::write_indicators_json(summary_path, indicators, &prov, status);
  std::filesystem::path pvd;
  if (rec.keep_states) pvd = io::write_field_series(*simulator->fields(), rec.states, o.vtu, vtu_name);

  if (partial)
    ctx.out << config.name << " (" << simulator->name() << "): FAILED (" << status << ") in beat "
            << result.info.beats << "\n";
  else
    ctx.out << config.name << " (" << simulator->name() << "): " << (not_periodic ? "NOT periodic" : "periodic")
            << " after " << result.info.beats << " beats\n";
  ctx.out << io::format_indicators(indicators);
  ctx.out << "wrote " << h5_path.string() << "\n";
  if (!csv_path.empty()) ctx.out << "wrote " << csv_path.string() << "\n";
  if (!summary_path.empty()) ctx.out << "wrote " << summary_path.string() << "\n";
  if (!pvd.empty())
    ctx.out << "wrote " << rec.states.size() << " ParaView steps of the " << (partial ? "failing" : "last")
            << " beat, " << pvd.string() << "\n";
  if (not_periodic) throw RunFailure(failure + "; the last beat is written to " + h5_path.string() + kept);
  if (partial)
    throw RunFailure(failure + "; the beat up to t = " + fmt::format("{:.4g}", beat.times(kept_rows - 1)) +
                     " s of beat " + std::to_string(result.info.beats) + " is written to " + h5_path.string() + kept);
  return kExitOk;
}

void register_simulate(CLI::App& app, CommandContext& ctx) {
  auto [sub, opts] = add_config_command(app, ctx, "simulate", "Run the configured simulator once and save the beat",
                                        run_simulate);
  sub->add_option("-o,--output", opts->output, "Results file (HDF5); default results/<config>-simulate.h5");
  sub->add_option("--csv", opts->csv, "Also write the curves as CSV (header 'name [unit]')");
  sub->add_option("--summary", opts->summary, "Also write the indices as JSON");
  sub->add_option("--vtu", opts->vtu,
                  "Models with spatial fields (lv-3d): write the last beat as binary VTU files plus a .pvd "
                  "index into this directory (lv-3d: displacement, activation time, active stress, fibre "
                  "strain, AHA segments)");
}

}  // namespace sigmaheart::app
