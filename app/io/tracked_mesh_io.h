// Reading tracked meshes for `sigmaheart observe` (docs/models.md s.5.1) with VTK 9 (Debian
// libvtk9-dev; compiled in when CMake finds it, SIGMAHEART_HAVE_VTK): VTK XML (.vtu, .vtp),
// legacy .vtk, STL and OBJ surfaces, and ParaView .pvd series (times from it). One file per frame,
// all with the same connectivity (the output of motion tracking), or one mesh plus a
// displacement point array per frame.
//
// Cells: tetrahedra (VTK_TETRA, VTK_QUADRATIC_TETRA: reoriented positive, boundary faces rebuilt
// with normals out of the solid), triangles (VTK_TRIANGLE, VTK_QUADRATIC_TRIANGLE; quads, polygons
// and strips are split into triangles); vertices and lines are ignored; any other cell is an error.
// A file with tetrahedra and triangles: the triangles only carry labels (a labelled surface), the
// faces are the tetrahedra's. Every error is an app::InputError naming the file (and the frame),
// and what was expected.
#pragma once

#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <filesystem>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

// True when the executable was built with VTK (observe's mesh formats).
bool have_vtk();

// A .pvd collection: the files (resolved against the .pvd's folder) and their times [s as written].
struct PvdSeries {
  std::vector<std::filesystem::path> files;
  std::vector<double> times;
};
// Throws InputError (the .pvd, the DataSet's index) for a missing file attribute, a multi-part
// step, or times that do not increase strictly.
PvdSeries read_pvd_series(const std::filesystem::path& pvd);

struct TrackedMeshReadOptions {
  double length_unit = 1e-3;       // metres per coordinate unit of the files
  std::string displacement;        // point array (3 components) to read per frame ("" none)
  std::string point_label;         // point array of frame 0 to read ("" none)
  std::string cell_label;          // cell array of frame 0's triangles to read ("" none)
};

struct TrackedMeshSeries {
  model::fem::Mesh mesh;                       // connectivity; nodes = frame 0's points [m]
  bool volume = false;                         // tetrahedra (faces = their boundary), else a surface
  std::vector<Eigen::MatrixX3d> points;        // per frame [m]
  std::vector<Eigen::MatrixX3d> displacement;  // per frame [m] (when asked for)
  Eigen::VectorXd point_label;                 // per node (when asked for)
  Eigen::VectorXd face_label;                  // per face of mesh.faces (NaN where no labelled triangle)
  std::vector<std::filesystem::path> files;
};

// Reads one file per frame. Throws InputError: a file that cannot be read, no usable cells, a
// connectivity or point count that differs from frame 0's, a missing or mis-sized array, a
// non-finite coordinate, a frame whose size differs from frame 0's by more than 3x (mixed units).
TrackedMeshSeries read_tracked_meshes(const std::vector<std::filesystem::path>& files, const TrackedMeshReadOptions& options);

}  // namespace sigmaheart::app::io
