// `sigmaheart observe CONFIG -o OBS.csv`: the observation CSV that `calibrate` and `personalize`
// read (time, V_lv, V_seg01..17, optionally P_lv) from tracked meshes or segmented label images,
// by the definitions of docs/models.md s.5 (s.5.1: from images). Times are written after the ECG
// trigger (frame 0 at timing.trigger_offset), as the estimators' `align: ecg` reads them. The
// comment lines keep the provenance (config, files, landmarks, ED frame, trigger offset, checks);
// a results file beside it (kind "observe") holds the same for `scripts/plot`. A tracking failure
// found by the checks (a segment negative or jumping, regional volumes not summing to V_lv) is
// exit 1 with everything written; bad input exit 2 with nothing written.
#include "app/commands/commands.h"
#include "app/errors.h"
#include "app/io/observation_file.h"
#include "app/io/observe_h5.h"
#include "app/observe_frames.h"
#include "app/observe_setup.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app {

namespace {

struct ObserveOptions {
  std::filesystem::path config, output, results;
  std::vector<std::string> overrides;
};

std::string num(double v, int precision = 4) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

std::string mm_point(const Eigen::Vector3d& p, double unit) {
  return "(" + num(p(0) / unit) + ", " + num(p(1) / unit) + ", " + num(p(2) / unit) + ")";
}

// P_lv of the pressure trace at the frame times (linear interpolation; the same clock, times after
// the ECG trigger). A frame outside the trace is bad input.
Eigen::VectorXd merged_pressure(const ObserveSetup& s, const Eigen::VectorXd& times) {
  const io::ObservationCurves p = io::read_observation_csv(s.pressure_file);
  const auto c = p.trajectory.channel_index(s.pressure_column);
  if (!c) throw InputError(s.pressure_at, s.pressure_file.string() + " has no column '" + s.pressure_column + "'");
  const Eigen::VectorXd& t = p.trajectory.times;
  const Eigen::VectorXd y = p.trajectory.values.col(*c);
  Eigen::VectorXd out(times.size());
  for (Eigen::Index k = 0; k < times.size(); ++k) {
    const double tk = times(k);
    if (tk < t(0) || tk > t(t.size() - 1))
      throw InputError(s.pressure_at, "frame " + std::to_string(k) + " at " + num(tk * 1e3) + " ms after the trigger lies outside the pressure trace (" +
                                          num(t(0) * 1e3) + " to " + num(t(t.size() - 1) * 1e3) + " ms)");
    Eigen::Index j = 0;
    while (j + 2 < t.size() && t(j + 1) < tk) ++j;
    const double w = (tk - t(j)) / (t(j + 1) - t(j));
    out(k) = (1 - w) * y(j) + w * y(j + 1);
  }
  return out;
}

std::vector<std::string> comment_lines(const ObserveSetup& s, const ObservedFrames& fr, const observers::VolumeChecks& c,
                                       const std::string& command_line) {
  const bool meshes = s.source == ObserveSource::kMeshes;
  const double u = s.length_unit;
  const std::string unit = u == 1.0 ? "m" : u == 1e-2 ? "cm" : "mm";
  std::vector<std::string> l;
  l.push_back("sigmaheart observe: LV cavity and AHA regional volumes (docs/models.md s.5) from " +
              std::string(meshes ? "tracked meshes" : "label images"));
  l.push_back("command: " + command_line);
  l.push_back("config: " + s.config.string() + " (" + s.name + ")");
  l.push_back(std::to_string(fr.curves.times.size()) + " frames: " + (s.series.empty() ? s.files.front().string() : s.series.string()) +
              (s.files.size() > 1 ? " ... " + s.files.back().string() : std::string()));
  std::string lm = "landmarks [" + unit + "]: apex " + mm_point(s.landmarks.apex, u) + ", base ";
  if (s.landmarks.base.empty()) lm += "rim of the endocardium";
  for (const auto& b : s.landmarks.base) lm += mm_point(b, u) + " ";
  lm += ", rv_anterior " + mm_point(s.landmarks.rv_anterior, u);
  if (s.landmarks.rv_inferior) lm += ", rv_inferior " + mm_point(*s.landmarks.rv_inferior, u);
  l.push_back(lm);
  for (const auto& n : fr.notes) l.push_back(n);
  l.push_back("times: after the ECG trigger (align: ecg reads them so); frame 0 at trigger offset " + num(s.trigger_offset * 1e3) +
              " ms; frame times " + (s.file_times.empty() && (meshes || s.heart_rate > 0) ? "from the heart rate " + num(s.heart_rate * 60) + " bpm"
                                                                                          : std::string("from the files")));
  l.push_back("end-diastole: frame " + std::to_string(c.end_diastole) + " at " + num(fr.curves.times(c.end_diastole) * 1e3) + " ms (" +
              (s.end_diastole < 0 ? "largest V_lv" : "given") + "), end-systole frame " + std::to_string(c.end_systole) + "; EDV " +
              num(c.edv * 1e6) + " mL, ESV " + num(c.esv * 1e6) + " mL, EF " + num(100 * c.ef, 3) + " %");
  l.push_back("regional volumes sum to V_lv within " + num(100 * c.max_sum_error, 3) + " % (frame " + std::to_string(c.max_sum_error_frame) + ")");
  if (fr.has_quality)
    l.push_back("element quality: worst " + num(fr.worst_quality, 3) + " at frame " + std::to_string(fr.worst_quality_frame) + " (element " +
                std::to_string(fr.worst_element) + "), " + std::to_string(fr.inverted) + " inverted there");
  l.push_back(c.ok() ? "tracking checks: ok" : "tracking checks FAILED: " + std::to_string(c.findings.size()) + " findings (below)");
  std::istringstream findings(c.report());
  for (std::string line; std::getline(findings, line);) l.push_back("  " + line);
  return l;
}

int run_observe(const ObserveOptions& o, CommandContext& ctx) {
  io::Provenance prov = started_provenance();
  ConfigFile file = ConfigFile::load(o.config);
  apply_overrides(file, o.overrides);
  const ObserveSetup s = parse_observe(file);
  const std::filesystem::path csv =
      !o.output.empty() ? o.output : std::filesystem::path("results") / (o.config.stem().string() + "-observe.csv");
  const std::filesystem::path h5 = !o.results.empty() ? o.results : std::filesystem::path(csv).replace_extension(".h5");
  std::vector<std::filesystem::path> inputs = s.files;
  inputs.push_back(o.config);
  if (!s.series.empty()) inputs.push_back(s.series);
  if (!s.pressure_file.empty()) inputs.push_back(s.pressure_file);
  check_outputs({{"-o", csv}, {"--results", h5}}, inputs);

  const ObservedFrames fr = observe_frames(s);
  if (s.end_diastole >= fr.curves.times.size())
    throw InputError(s.end_diastole_at, "end_diastole is frame " + std::to_string(s.end_diastole) + " but there are " +
                                            std::to_string(fr.curves.times.size()) + " frames (from 0)");
  const observers::VolumeChecks checks = observers::check_volume_curves(fr.curves, s.checks);
  model::Trajectory tr = observers::volume_trajectory(fr.curves);
  std::vector<std::string> units(tr.channels.size(), "mL");
  if (!s.pressure_file.empty()) {
    const Eigen::VectorXd p = merged_pressure(s, tr.times);
    tr.channels.push_back({"P_lv", "Pa", "LV pressure merged from " + s.pressure_file.string()});
    tr.values.conservativeResize(Eigen::NoChange, tr.values.cols() + 1);
    tr.values.rightCols(1) = p;
    units.push_back("mmHg");
  }
  prov.kind = "observe";
  prov.name = s.name;
  prov.config_file = file.file();
  prov.config_text = file.text();
  prov.overrides = file.overrides();
  prov.command_line = ctx.command_line;
  std::string kept;
  const std::filesystem::path csv_out = result_path(csv, checks.ok(), &kept);
  const std::filesystem::path h5_out = result_path(h5, checks.ok(), &kept);
  io::write_observation_csv(csv_out, tr, "ms", units, comment_lines(s, fr, checks, ctx.command_line));
  io::write_observe_h5(h5_out, prov, tr, checks, fr);

  ctx.out << s.name << ": " << tr.samples() << " frames from " << (s.source == ObserveSource::kMeshes ? "tracked meshes" : "label images") << "\n";
  for (const auto& n : fr.notes) ctx.out << "  " << n << "\n";
  ctx.out << "  EDV " << num(checks.edv * 1e6) << " mL (frame " << checks.end_diastole << "), ESV " << num(checks.esv * 1e6)
          << " mL (frame " << checks.end_systole << "), EF " << num(100 * checks.ef, 3) << " %; regional volumes sum to V_lv within "
          << num(100 * checks.max_sum_error, 3) << " %\n";
  if (fr.has_quality)
    ctx.out << "  element quality: worst " << num(fr.worst_quality, 3) << " at frame " << fr.worst_quality_frame << ", " << fr.inverted
            << " inverted\n";
  ctx.out << "  regional EF [%]:";
  for (int z = 0; z < observers::kAhaSegments; ++z) ctx.out << " " << num(100 * checks.regional_ef[static_cast<size_t>(z)], 3);
  ctx.out << "\nwrote " << csv_out.string() << "\nwrote " << h5_out.string() << " (scripts/plot draws it)\n";
  if (!checks.ok())
    throw RunFailure("observe: tracking checks failed:\n" + checks.report() + "the curves are written to " + csv_out.string() + kept);
  return kExitOk;
}

}  // namespace

void register_observe(CLI::App& app, CommandContext& ctx) {
  auto [sub, opts] = add_config_command(app, ctx, "observe",
                                        "LV and AHA regional volume curves from tracked meshes or label images",
                                        run_observe, "Config file (YAML) with an observe: section");
  sub->add_option("-o,--output", opts->output, "Observation CSV; default results/<config>-observe.csv");
  sub->add_option("--results", opts->results, "Results file (HDF5) for scripts/plot; default the CSV's name with .h5");
}

}  // namespace sigmaheart::app
