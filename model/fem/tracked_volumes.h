// Cavity and AHA regional volumes of a tracked endocardium (one mesh per frame with the same
// connectivity, the output of motion tracking), by exactly the definitions of docs/models.md s.5
// (cavity_volumes in cavity.h), with the AHA frame taken from landmarks (docs/models.md s.5.1).
//
// The endocardium is a set of boundary faces of the first frame: the triangles of a surface mesh,
// faces picked by a label, or the inner boundary of a volume mesh (inner_boundary_faces). Its
// open rim is the base ring (c, the mean of the ring nodes, moves with them); with base points
// given, the faces above their plane (a valve lid, a closed surface) are cut off first. The
// segments are assigned on the reference configuration and kept (Lagrangian segments, as in the
// simulator), so the volumes of frame k are cavity_volumes(surface, x_k, labels).
//
// Landmarks (positions in metres, the reference configuration): the apex A, the base ring's centre
// C (the mean of the ring nodes, after the cut when base points are given), the axis a = (C - A)/|C - A|, L = |C - A|; phi = 0 along the anterior RV insertion point P
// (projected normal to a). With the inferior insertion point Q as well, the septum (segments 2-3,
// 120 deg) is centred between the two: phi = 0 is rotated by (beta - 120)/2 where beta is the
// angle from P to Q counter-clockwise seen from the apex (a common reading of Cerqueira et al.
// 2002, whose septal segments lie between the insertion points).
#pragma once

#include "model/fem/cavity.h"
#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

struct Landmarks {
  Eigen::Vector3d apex = Eigen::Vector3d::Zero();         // endocardial apex [m]
  std::vector<Eigen::Vector3d> base;                      // empty: the rim; else >= 3 points on the base plane [m]
  Eigen::Vector3d rv_anterior = Eigen::Vector3d::Zero();  // anterior RV insertion point [m]
  std::optional<Eigen::Vector3d> rv_inferior;             // inferior RV insertion point [m]
};

// A landmark that does not fit the geometry (outside the mesh, on the axis, on the wrong side).
// `landmark` names it as in the config ("apex", "base[2]", "rv_inferior").
class LandmarkError : public std::invalid_argument {
 public:
  LandmarkError(std::string landmark, const std::string& message)
      : std::invalid_argument(message), landmark_(std::move(landmark)) {}
  const std::string& landmark() const { return landmark_; }

 private:
  std::string landmark_;
};

struct TrackedOptions {
  double landmark_tolerance = 15e-3;  // [m] largest distance of a landmark from the mesh's surface
  double apical_cap_fraction = 0.0;   // AhaOptions::apical_cap_fraction (0: docs/models.md s.5)
  std::string validate() const;
};

// The endocardium of a tracked mesh in the frame of its landmarks.
struct TrackedEndocardium {
  Mesh surface;         // the input's nodes (same indices), faces = the endocardium (kEndocardium), no tetrahedra
  AhaLabels labels;     // face_segment per face, base_ring, the frame
  Eigen::Vector3d reference_direction = Eigen::Vector3d::UnitX();  // phi = 0 (unit, normal to the axis)
  double insertion_angle_deg = 0.0;  // beta (NaN without rv_inferior)
  int faces_cut = 0;    // faces above the base plane dropped
  int faces_flipped = 0;  // faces re-oriented to agree with their neighbours (surface meshes)
};

// Boundary faces of a volume mesh (mesh.faces, normals out of the solid) at positions x that form
// the inner boundary: faces whose normal points into the region around the centroid m of the
// boundary nodes (n . (m - p) > 0, p the face centroid; true of the endocardium of a cup-shaped
// ventricle, false of the epicardium and the base), then the largest edge-connected patch of
// those. One flag per face.
std::vector<char> inner_boundary_faces(const Mesh& mesh, const Eigen::MatrixX3d& x);

// Builds the endocardium from the faces of `mesh` flagged in `endo` (one per face of mesh.faces),
// positions x_ref of the reference frame. `oriented`: the faces' normals already leave the solid
// (boundary faces of tetrahedra); otherwise (a surface mesh) they are made consistent across
// shared edges and the sign chosen so the cavity volume is positive. Throws LandmarkError for a
// landmark that does not fit, std::invalid_argument for a surface that cannot be used (no faces,
// a non-manifold edge, not one boundary loop, a negative cavity volume), with what was expected.
TrackedEndocardium make_tracked_endocardium(const Mesh& mesh, const std::vector<char>& endo, const Eigen::MatrixX3d& x_ref,
                                            bool oriented, const Landmarks& landmarks, const TrackedOptions& options = {});

// Phi = 0 direction (unit, normal to `axis`) from the insertion points about the line (centre,
// axis), and beta [deg] (NaN without rv_inferior). Throws LandmarkError when a point lies on the
// axis or rv_inferior is not 40-200 deg counter-clockwise from rv_anterior.
Eigen::Vector3d aha_reference_direction(const Landmarks& landmarks, const Eigen::Vector3d& centre,
                                        const Eigen::Vector3d& axis, double* beta_deg = nullptr);

// Element quality at positions x: tetrahedra by the mean ratio 12 (3|V|)^(2/3) / sum l^2 (1 for a
// regular tetrahedron, 0 when flat; Liu & Joe 1994), triangles by 4 sqrt(3) A / sum l^2 (1 for an
// equilateral triangle); corner nodes only. `inverted` counts tetrahedra of non-positive volume,
// or faces whose normal turned against their reference normal (n . n_ref <= 0).
struct ElementQuality {
  double min_quality = 1.0;
  int worst_element = -1;  // a tetrahedron when the mesh has them, else a face
  int inverted = 0;
};
ElementQuality element_quality(const Mesh& mesh, const Eigen::MatrixX3d& x, const Eigen::MatrixX3d& x_ref);

}  // namespace sigmaheart::model::fem
