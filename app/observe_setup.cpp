#include "app/observe_setup.h"

#include "app/config.h"
#include "app/io/tracked_mesh_io.h"
#include "model/units.h"

#include <algorithm>
#include <regex>

namespace sigmaheart::app {

namespace {

// A glob with '*' and '?' in the file name (not in the folders), sorted by name.
std::vector<std::filesystem::path> expand_glob(const ConfigNode& at, const std::filesystem::path& pattern) {
  std::string rx;
  for (char c : pattern.filename().string()) {
    if (c == '*') rx += ".*";
    else if (c == '?') rx += '.';
    else if (std::string("\\^$.|+()[]{}").find(c) != std::string::npos) rx += std::string("\\") + c;
    else rx += c;
  }
  const std::regex re(rx);
  std::vector<std::filesystem::path> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(pattern.parent_path(), ec))
    if (e.is_regular_file() && std::regex_match(e.path().filename().string(), re)) out.push_back(e.path());
  if (ec) at.fail("cannot list the folder " + pattern.parent_path().string() + ": " + ec.message());
  std::sort(out.begin(), out.end());
  if (out.empty()) at.fail("no file matches " + pattern.string());
  return out;
}

// The frames' files: a .pvd (times from it), a glob, one file, or a list of files.
void parse_files(const ConfigNode& node, const std::filesystem::path& base, ObserveSetup& s) {
  s.files_at = node.location();
  const std::string what = s.source == ObserveSource::kMeshes ? "mesh file" : "NIfTI image";
  if (node.is_sequence()) {
    if (node.size() == 0) node.fail("expected at least one file");
    for (size_t i = 0; i < node.size(); ++i) s.files.push_back(input_file(node[i], node[i].as<std::string>(), base, what));
    return;
  }
  const std::string text = node.as<std::string>();
  if (text.find_first_of("*?") != std::string::npos) {
    s.files = expand_glob(node, base / text);
    for (const auto& f : s.files) input_file(node, f, {}, what);  // already relative to the working directory
    return;
  }
  const std::filesystem::path p = input_file(node, text, base, what);
  if (s.source == ObserveSource::kMeshes && p.extension() == ".pvd") {
    s.series = p;
    const io::PvdSeries series = io::read_pvd_series(p);
    s.files = series.files;
    s.file_times = series.times;
    for (const auto& f : s.files) input_file(node, f, {}, "mesh file of the .pvd");  // resolved against the .pvd
  } else {
    s.files.push_back(p);
  }
}

Eigen::Vector3d point(const ConfigNode& node, double unit, const std::string& name, ObserveSetup& s) {
  const std::vector<double> v = node.as<std::vector<double>>();
  if (v.size() != 3) node.fail("expected a point [x, y, z]");
  s.landmark_at[name] = node.location();
  return Eigen::Vector3d(v[0], v[1], v[2]) * unit;
}

void parse_landmarks(const ConfigNode& lm, ObserveSetup& s) {
  lm.check_keys({"apex", "base", "rv_anterior", "rv_inferior", "tolerance"});
  const double u = s.length_unit;
  s.landmarks.apex = point(lm.require_child("apex"), u, "apex", s);
  s.landmarks.rv_anterior = point(lm.require_child("rv_anterior"), u, "rv_anterior", s);
  if (lm.has("rv_inferior")) s.landmarks.rv_inferior = point(lm["rv_inferior"], u, "rv_inferior", s);
  const ConfigNode base = lm["base"];
  s.landmark_at["base"] = base.defined() ? base.location() : lm.location();
  if (base.is_sequence()) {
    for (size_t i = 0; i < base.size(); ++i)
      s.landmarks.base.push_back(point(base[i], u, "base[" + std::to_string(i) + "]", s));
    if (s.landmarks.base.size() < 3) base.fail("expected 'rim' or at least 3 points [x, y, z] on the base plane");
  } else if (base.defined() && base.as<std::string>() != "rim") {
    base.fail("expected 'rim' (the open rim of the endocardium) or a list of points on the base plane");
  }
  s.tracked.landmark_tolerance = lm.optional_quantity("tolerance", "m", s.tracked.landmark_tolerance);
  if (!(s.tracked.landmark_tolerance > 0)) lm["tolerance"].fail("expected a distance > 0");
}

void parse_timing(const ConfigNode& t, ObserveSetup& s) {
  t.check_keys({"heart_rate", "time_unit", "trigger_offset", "end_diastole"});
  s.heart_rate = t.optional_quantity("heart_rate", "1/s", 0.0);
  if (t.has("heart_rate") && !(s.heart_rate > 0)) t["heart_rate"].fail("expected a heart rate > 0 (e.g. 60 bpm)");
  if (t.has("time_unit")) {
    const std::string unit = t["time_unit"].as_choice({"s", "ms"});
    for (double& x : s.file_times) x *= unit == "ms" ? 1e-3 : 1.0;
  }
  s.trigger_offset = t.optional_quantity("trigger_offset", "s", 0.0);
  const ConfigNode ed = t["end_diastole"];
  s.end_diastole_at = ed.defined() ? ed.location() : t.location();
  if (ed.defined() && !(ed.is_scalar() && ed.as<std::string>() == "max-volume")) {
    s.end_diastole = ed.as<int>();
    if (s.end_diastole < 0) ed.fail("expected 'max-volume' or a frame index from 0");
  }
}

void parse_endocardium(const ConfigNode& e, ObserveSetup& s) {
  if (!e.defined()) return;
  if (e.is_scalar()) {
    const std::string c = e.as_choice({"auto", "surface", "inner"});
    s.endocardium = c == "auto" ? EndoChoice::kAuto : c == "surface" ? EndoChoice::kSurface : EndoChoice::kInner;
    return;
  }
  e.check_keys({"point_label", "cell_label", "value"});
  if (e.has("point_label") == e.has("cell_label")) e.fail("expected one of point_label: NAME or cell_label: NAME");
  if (e.has("point_label")) {
    s.endocardium = EndoChoice::kPointLabel;
    s.read.point_label = e["point_label"].as<std::string>();
  } else {
    s.endocardium = EndoChoice::kCellLabel;
    s.read.cell_label = e["cell_label"].as<std::string>();
  }
  s.endo_value = e.optional<double>("value", 1.0);
}

}  // namespace

ObserveSetup parse_observe(const ConfigFile& file) {
  const ConfigNode root = file.root();
  root.check_keys({"name", "description", "seed", "simulator", "observe"}, "key", "at the top level");
  ObserveSetup s;
  s.config = file.file();
  s.name = root.optional<std::string>("name", std::filesystem::path(file.file()).stem().string());
  const ConfigNode o = root.require_child("observe");
  o.check_keys({"meshes", "images", "units", "displacement", "reference", "endocardium", "label", "subdivision",
                "heights", "landmarks", "timing", "pressure", "checks", "apical_cap"});
  if (o.has("meshes") == o.has("images")) o.fail("expected one of meshes: (tracked meshes) or images: (NIfTI label images)");
  s.source = o.has("meshes") ? ObserveSource::kMeshes : ObserveSource::kImages;
  const bool meshes = s.source == ObserveSource::kMeshes;
  auto mesh_only = [&](const char* key) {
    if (!meshes && o.has(key)) o[key].fail(std::string(key) + " applies to meshes:, not to images:");
  };
  auto image_only = [&](const char* key) {
    if (meshes && o.has(key)) o[key].fail(std::string(key) + " applies to images:, not to meshes:");
  };
  for (const char* k : {"displacement", "reference", "endocardium"}) mesh_only(k);
  for (const char* k : {"label", "subdivision", "heights"}) image_only(k);
  if (o.has("heights"))
    s.sectors.heights = o["heights"].as_choice({"landmarks", "extent"}) == "landmarks" ? model::fem::SectorHeights::kLandmarks
                                                                                      : model::fem::SectorHeights::kExtent;
  if (o.has("units")) {
    const std::string u = o["units"].as_choice({"m", "cm", "mm"});
    s.length_unit = model::units::convert(1.0, u, "m");
  }
  s.read.length_unit = s.length_unit;
  const std::filesystem::path base = std::filesystem::path(file.file()).parent_path();
  parse_files(meshes ? o["meshes"] : o["images"], base, s);

  if (const ConfigNode d = o["displacement"]; d.defined()) {
    d.check_keys({"array", "points"});
    s.read.displacement = d.require<std::string>("array");
    if (d.has("points")) s.points_are_reference = d["points"].as_choice({"deformed", "reference"}) == "reference";
  }
  if (o.has("reference")) {
    s.reference_undeformed = o["reference"].as_choice({"first-frame", "undeformed"}) == "undeformed";
    if (s.reference_undeformed && s.read.displacement.empty())
      o["reference"].fail("'undeformed' needs displacement: {array: NAME} (the undeformed mesh is points - displacement)");
  }
  parse_endocardium(o["endocardium"], s);
  if (o.has("label")) s.label = o["label"].as<int>();
  if (o.has("subdivision")) {
    const std::vector<double> v = o["subdivision"].as<std::vector<double>>();
    if (v.size() != 3) o["subdivision"].fail("expected [ni, nj, nk] sub-samples per voxel");
    for (int d = 0; d < 3; ++d) s.sectors.subdivision[static_cast<size_t>(d)] = static_cast<int>(v[static_cast<size_t>(d)]);
    if (auto m = s.sectors.validate(); !m.empty()) o["subdivision"].fail(m);
  }
  parse_landmarks(o.require_child("landmarks"), s);
  if (!meshes && s.landmarks.base.empty())
    o["landmarks"].fail("images need landmarks.base: at least 3 points on the base plane (the mitral annulus)");
  parse_timing(o["timing"], s);
  if (s.file_times.empty() && s.source == ObserveSource::kMeshes && s.heart_rate == 0.0)
    (o.has("timing") ? o["timing"] : o).fail("the mesh files carry no times: give timing.heart_rate (or a .pvd series)");
  if (const ConfigNode p = o["pressure"]; p.defined()) {
    p.check_keys({"file", "column"});
    s.pressure_at = p.location();
    s.pressure_file = input_file(p.require_child("file"), p.require<std::string>("file"), base, "pressure trace (CSV)");
    s.pressure_column = p.optional<std::string>("column", "P_lv");
  }
  if (!meshes) s.checks.jump_fraction = 0.5;  // slices move a segment's volume in steps (observers/volume_curves.h)
  if (const ConfigNode c = o["checks"]; c.defined()) {
    c.check_keys({"jump_fraction", "sum_tolerance"});
    s.checks.jump_fraction = c.optional<double>("jump_fraction", s.checks.jump_fraction);
    s.checks.sum_tolerance = c.optional<double>("sum_tolerance", s.checks.sum_tolerance);
    if (auto m = s.checks.validate(); !m.empty()) c.fail(m);
  }
  const double cap = o.optional<double>("apical_cap", 0.0);
  s.tracked.apical_cap_fraction = s.sectors.apical_cap_fraction = cap;
  if (auto m = s.tracked.validate(); !m.empty()) o["apical_cap"].fail(m);
  s.checks.end_diastole = s.end_diastole;
  return s;
}

}  // namespace sigmaheart::app
