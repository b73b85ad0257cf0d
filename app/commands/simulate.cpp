// `sigmaheart simulate CONFIG`: one forward run of the configured simulator with the config's
// parameter values; the periodic beat, its indices and the provenance go to a results file.
#include "app/commands/commands.h"
#include "app/config.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/mesh_io.h"
#include "app/io/results.h"
#include "observers/global_indices.h"
#ifdef SIGMAHEART_HAVE_FEM
#include "model/fem/electromechanics.h"
#endif

#include <cmath>

#include <omp.h>
#include <spdlog/spdlog.h>


namespace sigmaheart::app {

namespace {

// The beat's global indices (observers/global_indices.h) in display units (EF in %), then the
// run's beat-level facts. An index the observer cannot compute is reported and left out.
std::vector<io::Indicator> simulate_indicators(const model::RunResult& result,
                                               const std::vector<model::Channel>& channels) {
  std::vector<io::Indicator> out;
  try {
    const observers::GlobalIndices indices({}, channels);
    Eigen::VectorXd z(indices.size());
    const model::Status status = indices.observe(result.trajectory, z);
    if (status.ok()) {
      const auto outputs = indices.outputs();
      for (size_t i = 0; i < outputs.size(); ++i) {
        const double si = z(static_cast<Eigen::Index>(i));
        if (outputs[i].name == "EF") {
          out.push_back({"EF", 100.0 * si, "%", "ejection fraction SV / EDV"});
          continue;
        }
        const io::DisplayUnit d = io::display_unit(outputs[i].unit);
        out.push_back({outputs[i].name, si * d.from_si, d.unit, outputs[i].doc});
      }
    } else {
      spdlog::warn("indices of the simulated beat: {}", status.message);
    }
  } catch (const std::invalid_argument& e) {
    spdlog::warn("indices of the simulated beat: {}", e.what());
  }
  out.push_back({"period", result.info.period, "s", "heart period"});
  out.push_back({"beats", static_cast<double>(result.info.beats), "1",
                 "beats integrated: until the beat was periodic, or all allowed (status not-periodic)"});
  out.push_back({"periodicity_change", result.info.periodicity_change, "1",
                 "distance of the last beat's start state from periodic, relative to each entry's scale "
                 "(the shooting's last Newton correction, or lv-3d's beat-to-beat change)"});
  return out;
}

// A run that failed inside a beat (diverged, non-finite): no indices (a part of a beat has no EDV
// or EF), only where it stopped.
std::vector<io::Indicator> failed_beat_facts(const model::RunResult& result, const model::Trajectory& beat) {
  return {{"period", result.info.period, "s", "heart period"},
          {"beats", static_cast<double>(result.info.beats), "1", "beats begun; the last one failed"},
          {"time_reached", beat.times(beat.samples() - 1), "s",
           "time of the last sample written, from the start of the failing beat"}};
}

// The leading samples of a trajectory whose values are all finite.
Eigen::Index finite_rows(const model::Trajectory& tr) {
  Eigen::Index k = 0;
  while (k < tr.values.rows() && k < tr.times.size() && tr.values.row(k).allFinite() && std::isfinite(tr.times(k))) ++k;
  return k;
}

// The states of the last beat of a 3D run, for its ParaView time series, and progress lines per
// beat (a 3D beat takes tens of seconds).
struct BeatRecorder {
  bool keep_states = false;
  int beat = 0;
  std::vector<std::pair<double, model::State>> states;  // (time in beat [s], state)
};

#ifdef SIGMAHEART_HAVE_FEM
model::fem::LeftVentricle3D* as_3d(model::Simulator* s) { return dynamic_cast<model::fem::LeftVentricle3D*>(s); }
#endif

// One binary VTU per kept step of the last beat, `<name>_NNNN.vtu`, and `<name>.pvd` with the time
// in the beat [s]; every file is written to a temporary name and renamed (app/io/atomic_file.h).
// Returns the .pvd path.
std::filesystem::path write_beat_vtu(model::Simulator* simulator, const BeatRecorder& rec,
                                     const std::filesystem::path& dir, const std::string& name) {
#ifdef SIGMAHEART_HAVE_FEM
  auto* lv = as_3d(simulator);
  std::filesystem::create_directories(dir);
  std::vector<std::pair<double, std::string>> steps;
  for (size_t i = 0; i < rec.states.size(); ++i) {
    char file[32];
    std::snprintf(file, sizeof file, "_%04zu.vtu", i);
    const std::string fname = name + file;
    const model::fem::VtuDocument doc = lv->field_document(rec.states[i].second);
    io::write_text_file(dir / fname, [&](std::ostream& os) { doc.write(os); });
    steps.emplace_back(rec.states[i].first, fname);
  }
  const std::filesystem::path pvd = dir / (name + ".pvd");
  io::write_pvd(pvd.string(), steps);
  return pvd;
#else
  (void)simulator, (void)rec, (void)dir, (void)name;
  throw RunFailure("sigmaheart was built without model/fem: no ParaView output");
#endif
}

}  // namespace

int run_simulate(const SimulateOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  const Config config = load_config(o.config, o.overrides, *ctx.models, *ctx.sections);
  const std::filesystem::path output = !o.output.empty() ? o.output : default_output_path(o.config, "simulate");
  check_outputs({{"-o", output}, {"--csv", o.csv}, {"--summary", o.summary}}, {o.config});
  if (!o.vtu.empty()) {
    std::error_code ec;
    if (std::filesystem::exists(o.vtu, ec) && !std::filesystem::is_directory(o.vtu, ec))
      throw InputError("--vtu " + o.vtu.string(), 0, 0, "is a file; expected a directory for the .vtu/.pvd files");
    std::filesystem::create_directories(o.vtu, ec);
    if (ec) throw InputError("--vtu " + o.vtu.string(), 0, 0, "cannot create the directory: " + ec.message());
  }

  auto simulator = config.simulator.make();
  const Eigen::VectorXd theta = config.simulator.parameters.nominal();
  spdlog::info("simulating '{}' with {} ({} parameters)", config.name, simulator->name(),
               theta.size());
  BeatRecorder rec;
  rec.keep_states = !o.vtu.empty();
#ifdef SIGMAHEART_HAVE_FEM
  if (auto* lv = as_3d(simulator.get())) {
    lv->set_beat_observer([&rec](int beat, double t, const model::State& s) {
      if (beat != rec.beat) {
        spdlog::info("beat {} ...", beat);
        rec.beat = beat;
        rec.states.clear();
      }
      if (rec.keep_states) rec.states.emplace_back(t, s);
    });
  } else if (rec.keep_states) {
    throw InputError("--vtu", 0, 0, "model '" + simulator->name() +
                                        "' has no 3D fields; ParaView output needs `model: lv-3d`");
  }
#else
  if (rec.keep_states) throw InputError("--vtu", 0, 0, "sigmaheart was built without model/fem (no 3D fields)");
#endif
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
  const Eigen::Index rows = result.trajectory.values.rows(), kept_rows = finite_rows(result.trajectory);
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
  const auto indicators = partial ? failed_beat_facts(result, beat) : simulate_indicators(result, simulator->channels());
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
  if (rec.keep_states) pvd = write_beat_vtu(simulator.get(), rec, o.vtu, vtu_name);

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
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* sub = app.add_subcommand("simulate", "Run the configured simulator once and save the beat");
  sub->add_option("config", opts->config, "Config file (YAML)")->required();
  sub->add_option("-o,--output", opts->output, "Results file (HDF5); default results/<config>-simulate.h5");
  sub->add_option("--csv", opts->csv, "Also write the curves as CSV (header 'name [unit]')");
  sub->add_option("--summary", opts->summary, "Also write the indices as JSON");
  sub->add_option("--vtu", opts->vtu,
                  "3D models: write the last beat as binary VTU files plus a .pvd index into this directory "
                  "(ParaView: displacement, activation time, active stress, fibre strain, AHA segments)");
  add_set_option(*sub, opts->overrides);
  sub->callback([opts, &ctx] { ctx.run = [opts, &ctx] { return run_simulate(*opts, ctx); }; });
}

}  // namespace sigmaheart::app
