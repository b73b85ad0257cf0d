// ParaView output: binary VTU documents (VTK XML UnstructuredGrid) and PVD time-series indexes.
//
// Encoding (Kitware, "VTK File Formats", section "XML File Formats"): one Piece;
// every DataArray is format="appended" into a single <AppendedData encoding="raw"> block that
// starts with '_'; each array there is a UInt64 byte count (header_type="UInt64") followed by the
// raw values in the machine byte order (declared in byte_order). An array's `offset` attribute is
// the position of its byte count, counted from the byte after '_'. Cells are VTK_TETRA (10) or
// VTK_QUADRATIC_TETRA (24), node order as in mesh.h (VTK's order). Points Float64 x 3,
// connectivity and offsets Int64, types UInt8, fields Float64 (or Int32 for labels).
//
// No file I/O here (docs/architecture.md s.1): documents are written to a std::ostream; app/
// writes files atomically, e.g. app::io::write_text_file(path, [&](std::ostream& os) { doc.write(os); }).
#pragma once

#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// One data array of a VTU document.
struct VtuArray {
  std::string name;
  int components = 1;                 // 1 (scalar) or 3 (vector) typically
  bool is_int32 = false;              // Int32 labels instead of Float64 values
  std::vector<double> float64;        // n_entities * components, entity-major
  std::vector<std::int32_t> int32;
};

class VtuDocument {
 public:
  // Geometry and cells of `mesh` (linear or quadratic tetrahedra); the mesh is copied.
  explicit VtuDocument(const Mesh& mesh);

  // Replaces the point coordinates, e.g. by the current (deformed) positions [m]; n_nodes x 3.
  void set_points(const Eigen::MatrixX3d& points);
  // Point data at every node: n_nodes * components values, node-major (x0 y0 z0 x1 ...).
  void add_point_data(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values, int components = 1);
  // Point data given at the vertices only (n_vertices * components): mid-edge nodes of quadratic
  // meshes get the mean of their edge ends (P1 interpolation), e.g. eikonal activation times.
  void add_vertex_data(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values, int components = 1);
  // Cell data: n_tets * components values, or one Int32 label per tetrahedron.
  void add_cell_data(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values, int components = 1);
  void add_cell_labels(const std::string& name, const std::vector<int>& labels);

  // Removes the point and cell data (geometry and cells stay): one document can be refilled for
  // every step of a time series.
  void clear_data() {
    point_.clear();
    cell_.clear();
  }

  // Writes the document (XML header then the appended binary block). Throws std::runtime_error
  // when the stream fails.
  void write(std::ostream& os) const;
  std::string str() const;

  const std::vector<VtuArray>& point_data() const { return point_; }
  const std::vector<VtuArray>& cell_data() const { return cell_; }

 private:
  Mesh mesh_;
  std::vector<VtuArray> point_, cell_;
};

// One step of a time series: time [s] and the VTU file name relative to the .pvd.
struct PvdEntry {
  double time = 0.0;  // [s]
  std::string file;
};
// Writes a PVD collection (ParaView's time-series index); times are written so that they read
// back exactly (shortest round-trip decimal form).
void write_pvd(std::ostream& os, const std::vector<PvdEntry>& entries);

}  // namespace sigmaheart::model::fem
