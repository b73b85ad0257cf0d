#include "app/observe_frames.h"

#include "app/errors.h"
#include "app/io/label_image_io.h"
#include "app/io/tracked_mesh_io.h"
#include "model/fem/cavity.h"

#include <cmath>
#include <sstream>

namespace sigmaheart::app {

namespace {

std::string fmt3(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

// A landmark error at the landmark's key in the config.
[[noreturn]] void landmark_failure(const ObserveSetup& s, const model::fem::LandmarkError& e) {
  auto it = s.landmark_at.find(e.landmark());
  if (it == s.landmark_at.end()) it = s.landmark_at.find(e.landmark().substr(0, e.landmark().find('[')));
  throw InputError(it != s.landmark_at.end() ? it->second : Location{s.config.string(), 0, 0}, e.what());
}

// Frame times after the ECG trigger: the files' own (shifted so frame 0 is at the trigger offset),
// else n frames spread over one period of the heart rate.
Eigen::VectorXd frame_times(const ObserveSetup& s, std::vector<double> own, int n, const std::string& source) {
  if (own.empty()) {
    if (!(s.heart_rate > 0))
      throw InputError(source, 0, 0, "the frames carry no times: give observe.timing.heart_rate");
    for (int k = 0; k < n; ++k) own.push_back(k / (s.heart_rate * n));
  }
  Eigen::VectorXd t(n);
  for (int k = 0; k < n; ++k) t(k) = own[static_cast<size_t>(k)] - own[0] + s.trigger_offset;
  return t;
}

ObservedFrames observe_meshes(const ObserveSetup& s) {
  using namespace model::fem;
  const io::TrackedMeshSeries m = io::read_tracked_meshes(s.files, s.read);
  const int n = static_cast<int>(m.points.size());
  const std::string first = s.files.front().string();
  std::vector<Eigen::MatrixX3d> x(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k)
    x[static_cast<size_t>(k)] = s.points_are_reference ? Eigen::MatrixX3d(m.points[static_cast<size_t>(k)] + m.displacement[static_cast<size_t>(k)])
                                                      : m.points[static_cast<size_t>(k)];
  Eigen::MatrixX3d x_ref = x[0];
  if (s.reference_undeformed) x_ref = s.points_are_reference ? m.points[0] : Eigen::MatrixX3d(m.points[0] - m.displacement[0]);

  // The endocardium among the faces.
  EndoChoice choice = s.endocardium;
  if (choice == EndoChoice::kAuto) choice = m.volume ? EndoChoice::kInner : EndoChoice::kSurface;
  std::vector<char> endo(static_cast<size_t>(m.mesh.faces.rows()), 0);
  std::string how;
  switch (choice) {
    case EndoChoice::kSurface:
      if (m.volume) throw InputError(s.files_at, "endocardium: surface needs a surface mesh; " + first + " has tetrahedra (use inner or a label)");
      std::fill(endo.begin(), endo.end(), 1);
      how = "every triangle of the surface";
      break;
    case EndoChoice::kInner:
      if (!m.volume) throw InputError(s.files_at, "endocardium: inner needs tetrahedra; " + first + " is a surface (use surface or a label)");
      endo = inner_boundary_faces(m.mesh, x_ref);
      how = "the inner boundary of the tetrahedra";
      break;
    case EndoChoice::kPointLabel:
      for (Eigen::Index f = 0; f < m.mesh.faces.rows(); ++f) {
        bool all = true;
        for (int j = 0; j < m.mesh.faces.cols(); ++j) all = all && m.point_label(m.mesh.faces(f, j)) == s.endo_value;
        endo[static_cast<size_t>(f)] = all;
      }
      how = "faces whose nodes all carry " + s.read.point_label + " = " + fmt3(s.endo_value);
      break;
    case EndoChoice::kCellLabel:
      for (Eigen::Index f = 0; f < m.mesh.faces.rows(); ++f) endo[static_cast<size_t>(f)] = m.face_label(f) == s.endo_value;
      how = "triangles with " + s.read.cell_label + " = " + fmt3(s.endo_value);
      break;
    case EndoChoice::kAuto: break;
  }
  TrackedEndocardium t;
  try {
    t = make_tracked_endocardium(m.mesh, endo, x_ref, m.volume, s.landmarks, s.tracked);
  } catch (const LandmarkError& e) {
    landmark_failure(s, e);
  } catch (const std::invalid_argument& e) {
    throw InputError(first, 0, 0, std::string("frame 0: ") + e.what() + " (endocardium: " + how + ")");
  }
  ObservedFrames out;
  out.notes.push_back("endocardium: " + std::to_string(t.surface.faces.rows()) + " faces (" + how + ")" +
                      (t.faces_cut ? ", " + std::to_string(t.faces_cut) + " above the base plane cut off" : std::string()) +
                      ", base ring of " + std::to_string(t.labels.base_ring.size()) + " nodes");
  const AhaFrame& f = t.labels.frame;
  out.notes.push_back("AHA frame (segments on " + std::string(s.reference_undeformed ? "the undeformed mesh" : "frame 0") +
                      "): cavity length " + fmt3(f.length * 1e3) + " mm, axis (" + fmt3(f.axis(0)) + ", " + fmt3(f.axis(1)) + ", " +
                      fmt3(f.axis(2)) + ")" +
                      (std::isnan(t.insertion_angle_deg) ? std::string() : ", RV insertions " + fmt3(t.insertion_angle_deg) + " deg apart"));
  out.curves.cavity.resize(n);
  out.curves.regional.resize(n, kAhaSegments);
  out.has_quality = true;
  for (int k = 0; k < n; ++k) {
    const CavityVolumes v = cavity_volumes(t.surface, x[static_cast<size_t>(k)], t.labels);
    out.curves.cavity(k) = v.cavity;
    for (int z = 0; z < kAhaSegments; ++z) out.curves.regional(k, z) = v.regional[static_cast<size_t>(z)];
    const ElementQuality q = element_quality(m.volume ? m.mesh : t.surface, x[static_cast<size_t>(k)], x[0]);
    if (k == 0 || q.min_quality < out.worst_quality) {
      out.worst_quality = q.min_quality;
      out.worst_quality_frame = k;
      out.worst_element = q.worst_element;
      out.inverted = q.inverted;
    }
  }
  out.curves.times = frame_times(s, s.file_times, n, s.series.empty() ? first : s.series.string());
  return out;
}

ObservedFrames observe_images(const ObserveSetup& s) {
  using namespace model::fem;
  const io::LabelImageSeries img = io::read_label_images(s.files, s.label);
  const int n = static_cast<int>(img.masks.size());
  ImageAhaFrame frame;
  try {
    frame = image_aha_frame(s.landmarks, img.grid);
    const double d = distance_to_mask(img.grid, img.masks[0].data(), s.landmarks.apex);
    if (d > s.tracked.landmark_tolerance)
      throw LandmarkError("apex", "apex is " + fmt3(d * 1e3) + " mm from the blood pool of frame 0 (at most " +
                                      fmt3(s.tracked.landmark_tolerance * 1e3) + " mm expected)");
  } catch (const LandmarkError& e) {
    landmark_failure(s, e);
  }
  ObservedFrames out;
  const Eigen::Vector3d h = img.grid.edges.colwise().norm() * 1e3;
  out.notes.push_back("label image: " + std::to_string(img.grid.dims[0]) + " x " + std::to_string(img.grid.dims[1]) + " x " +
                      std::to_string(img.grid.dims[2]) + " voxels of " + fmt3(h(0)) + " x " + fmt3(h(1)) + " x " + fmt3(h(2)) +
                      " mm, label " + std::to_string(s.label) + ", " + std::to_string(s.sectors.subdivision[0]) + "x" +
                      std::to_string(s.sectors.subdivision[1]) + "x" + std::to_string(s.sectors.subdivision[2]) +
                      " sub-samples per voxel for the sectors (Eulerian sectors: docs/models.md s.5.1)");
  out.curves.cavity.resize(n);
  out.curves.regional.resize(n, kAhaSegments);
  for (int k = 0; k < n; ++k) {
    const SectorVolumes v = sector_volumes(img.grid, img.masks[static_cast<size_t>(k)].data(), frame, s.sectors);
    out.curves.cavity(k) = v.cavity;
    for (int z = 0; z < kAhaSegments; ++z) out.curves.regional(k, z) = v.regional[static_cast<size_t>(z)];
  }
  std::vector<double> own;
  if (img.frame_interval > 0 && s.heart_rate == 0.0)
    for (int k = 0; k < n; ++k) own.push_back(k * img.frame_interval);
  out.curves.times = frame_times(s, own, n, s.files.front().string());
  return out;
}

}  // namespace

ObservedFrames observe_frames(const ObserveSetup& s) {
  return s.source == ObserveSource::kMeshes ? observe_meshes(s) : observe_images(s);
}

}  // namespace sigmaheart::app
