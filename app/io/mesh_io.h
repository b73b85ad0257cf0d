// The file formats of the 3D meshes of model/fem (kept in app/ so the libraries do no file I/O).
//
//  - gmsh .msh reader, ASCII format 2.2 and 4.x: 4- and 10-node tetrahedra, 3- and 6-node
//    triangles with physical tags. Boundary faces are rebuilt from the tetrahedra (oriented
//    outward) and take the physical tag of the matching triangle; physical names containing
//    "endo", "epi", "base" map to kEndocardium, kEpicardium, kBase. Nodes are renumbered with the
//    corners first. Errors: MeshReadError naming file, line and what was expected.
//  - legacy DOLFIN HDF5 mesh reader (the format of the Arostica et al. 2025 benchmark toolkit's
//    ellipsoid_0.005.h5): /Mesh/mesh/geometry (n x 3, m), /Mesh/mesh/topology (n x 4 linear
//    tetrahedra) and optionally a facet MeshFunction (/MeshFunction/<k>/mesh/topology n x 3 and
//    /MeshFunction/<k>/values) whose values become the boundary-face tags as they are (the toolkit's
//    1 endocardium, 2 epicardium, 3 base equal kEndocardium, kEpicardium, kBase); unset markers
//    (0 or the all-ones value) leave kNoTag. Tetrahedra are reoriented positive. Errors:
//    MeshReadError naming the file, the dataset and what was expected.
//  - ParaView output: one .vtu per step (reference geometry, displacement and pressure point
//    data, fibre, AHA segment and tag cell data) and a .pvd collection. Files are written to a
//    temporary name and renamed.
#pragma once

#include "model/fem/material.h"
#include "model/fem/mesh.h"
#include "model/simulator.h"

#include <Eigen/Core>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

class MeshReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads a gmsh file; `text` variant parses a string (name used in messages).
model::fem::Mesh read_gmsh(const std::string& path);
model::fem::Mesh parse_gmsh(const std::string& text, const std::string& name = "<string>");

// Reads a legacy DOLFIN HDF5 mesh (linear tetrahedra; see above).
model::fem::Mesh read_dolfin_hdf5(const std::string& path);

struct VtuFields {
  const Eigen::VectorXd* displacement = nullptr;  // 3 per node [m]
  const Eigen::VectorXd* pressure = nullptr;      // per vertex [Pa] (interpolated to mid nodes)
  const std::vector<model::fem::Frame>* fibres = nullptr;     // per tetrahedron
  const std::vector<int>* aha = nullptr;          // per tetrahedron
};

// Writes one VTU file (quadratic tetrahedra as VTK_QUADRATIC_TETRA). Throws std::runtime_error.
void write_vtu(const std::string& path, const model::fem::Mesh& mesh, const VtuFields& fields);

// Writes a .pvd collection listing (time, file) pairs (file names relative to the .pvd); times
// read back exactly.
void write_pvd(const std::string& path, const std::vector<std::pair<double, std::string>>& steps);

// The ParaView time series of any model that offers fields (model::FieldOutput): one binary VTU
// per (time, state), `<name>_NNNN.vtu`, and `<name>.pvd` with the times, in `dir` (created).
// Returns the .pvd path.
std::filesystem::path write_field_series(model::FieldOutput& fields,
                                         const std::vector<std::pair<double, model::State>>& states,
                                         const std::filesystem::path& dir, const std::string& name);

}  // namespace sigmaheart::app::io
