// Tetrahedral meshes of the left ventricle and of the Land et al. 2015 beam.
//
// Units: the generators take lengths in metres (SI, as everywhere in sigmaheart); the Land
// benchmark numbers (mm, kPa) are converted at the edge (land_benchmark.h).
//
// Node numbering: the corner vertices come first (0 .. n_vertices-1), then the mid-edge nodes of
// quadratic meshes. The mixed u-p formulation places its linear pressure on the vertices, so a
// pressure unknown is simply a vertex index.
// Element node order follows VTK: linear tetra (0,1,2,3); quadratic tetra adds the mid-edge
// nodes (0,1) (1,2) (0,2) (0,3) (1,3) (2,3). Triangles: (0,1,2) then (0,1) (1,2) (2,0).
#pragma once

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// Surface tags of boundary faces. Meshes read from gmsh map physical names containing "endo",
// "epi", "base" to the first three; unnamed physical ids are kept as they are.
enum SurfaceTag : int {
  kNoTag = 0,
  kEndocardium = 1,
  kEpicardium = 2,
  kBase = 3,
  kClamped = 4,  // beam: x = 0
  kBottom = 5,   // beam: z = 0 (pressure face)
};

struct Mesh {
  int order = 1;                 // 1: 4-node tetrahedra, 2: 10-node tetrahedra
  int n_vertices = 0;            // the first n_vertices nodes are tetrahedron corners
  Eigen::MatrixX3d nodes;        // reference positions [m]
  Eigen::MatrixXi tets;          // n_tets x (4 or 10), positively oriented
  std::vector<int> tet_tag;      // volume tag per tetrahedron (0 when none)
  Eigen::MatrixXi faces;         // boundary faces n x (3 or 6), normal points out of the solid
  std::vector<int> face_tag;     // SurfaceTag (or physical id) per boundary face
  std::map<std::string, int> physical_names;  // from gmsh; informative

  int n_nodes() const { return static_cast<int>(nodes.rows()); }
  int n_tets() const { return static_cast<int>(tets.rows()); }
  int nodes_per_tet() const { return order == 1 ? 4 : 10; }
  int nodes_per_face() const { return order == 1 ? 3 : 6; }

  // Nodes on faces carrying `tag` (sorted, unique).
  std::vector<int> nodes_with_tag(int tag) const;
  // Sum of signed tetrahedron volumes (straight-sided; exact for order 1) [m^3].
  double volume() const;
  // Empty when consistent (indices in range, positive volumes, vertex-first numbering);
  // otherwise a message naming the first problem.
  std::string check() const;
};

// Local mid-edge slot (4..9) of the edge (i, j) of a quadratic tetrahedron, VTK order.
int tet10_edge_slot(int i, int j);

// The four outward faces of a positively oriented tetrahedron, as local corner triples.
inline constexpr std::array<std::array<int, 3>, 4> kTetFaces = {{{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}};

// Boundary faces of `tets` (faces used by one tetrahedron), oriented outward, with mid-edge nodes
// for quadratic meshes. Tags are left at kNoTag.
void extract_boundary_faces(Mesh& mesh);

// Adds mid-edge nodes (placed at edge midpoints) to a linear mesh: order 1 -> 2. Boundary faces
// are rebuilt with their tags kept.
Mesh make_quadratic(const Mesh& linear);

// ---------------------------------------------------------------------------------------------
// Truncated prolate ellipsoid (Land et al. 2015, problems 2 and 3):
//   x = r_s(t) sin(theta) cos(v), y = r_s(t) sin(theta) sin(v), z = -r_l(t) cos(theta),
// r_s, r_l linear in the transmural coordinate t in [0, 1] (0 endocardium, 1 epicardium), theta
// the angle from the apex (0 at the apex on -z, theta_base(t) where layer t meets the base plane
// z = z_base), v the angle about the long axis z. (The paper writes u = theta - pi.)
struct EllipsoidGeometry {
  double r_short_endo = 7e-3;   // [m] Land 2015
  double r_long_endo = 17e-3;   // [m]
  double r_short_epi = 10e-3;   // [m]
  double r_long_epi = 20e-3;    // [m]
  double z_base = 5e-3;         // [m] base plane (the base height at the endocardium)
  // [m] base height at the epicardium; NaN (the default): z_base, a plane base. Otherwise the
  // base height varies linearly in t from z_base to z_base_epi: the base is the ruled surface
  // between the endocardial and the epicardial base rings (Arostica et al. 2025, Benchmark 1).
  double z_base_epi = std::numeric_limits<double>::quiet_NaN();

  // Human-sized variant (docs/models.md s.4): endo 25/45 mm, epi 35/55 mm, base plane 5 mm x 45/17.
  static EllipsoidGeometry human();
  std::string validate() const;

  double r_short(double t) const { return r_short_endo + t * (r_short_epi - r_short_endo); }
  double r_long(double t) const { return r_long_endo + t * (r_long_epi - r_long_endo); }
  // Height of the base on layer t [m].
  double base_height(double t) const { return std::isnan(z_base_epi) ? z_base : z_base + t * (z_base_epi - z_base); }
  // Angle from the apex (0 at the apex, increasing toward the base) where layer t meets the base.
  double theta_base(double t) const;
  // Position of (t, theta, v) where theta in [0, theta_base(t)] is measured from the apex.
  Eigen::Vector3d position(double t, double theta, double v) const;
  // Inverse map: (t, theta, v) of a point inside the wall (t by bisection). 
  Eigen::Vector3d coordinates(const Eigen::Vector3d& x) const;
};

struct EllipsoidMeshOptions {
  int n_transmural = 1;       // element layers across the wall
  int n_longitudinal = 6;     // element rings from apex to base
  int n_circumferential = 12; // elements around; a multiple of 6 puts nodes on 60-deg AHA bounds
  int order = 2;              // 1 or 2 (quadratic tetrahedra, curved faces on the exact surfaces)
  // When true and n_longitudinal is a multiple of 3, node rings are placed on the planes that cut
  // the endocardial cavity length in thirds (AHA basal/mid/apical levels, Cerqueira 2002).
  bool align_aha_levels = true;
  std::string validate() const;
};

// Structured mesh of the truncated ellipsoid: a (t, theta, v) grid cut into tetrahedra by the
// Kuhn (Freudenthal) split, conforming by construction; the apex column is collapsed onto the
// axis and its degenerate tetrahedra removed. Faces tagged endocardium, epicardium, base.
// Throws std::invalid_argument on invalid options.
Mesh ellipsoid_mesh(const EllipsoidGeometry& geometry, const EllipsoidMeshOptions& options);

// Box [0, lx] x [0, ly] x [0, lz] split into nx*ny*nz Kuhn cubes; faces tagged kClamped (x = 0),
// kBottom (z = 0), others kNoTag.
Mesh box_mesh(double lx, double ly, double lz, int nx, int ny, int nz, int order);

}  // namespace sigmaheart::model::fem
