// Anisotropic eikonal activation times on tetrahedral meshes (docs/models.md s.4.6).
//
// Equation: sqrt(grad(t)^T D grad(t)) = 1, D = v_f^2 f f^T + v_s^2 s s^T + v_n^2 n n^T, i.e.
// |grad t|_M = 1 with the metric M = D^-1: the travel time along a straight segment d inside one
// element is sqrt(d^T M d) [s]. Activation times t are P1 (one per mesh vertex) [s].
//
// Discretisation (Bornemann & Rasch 2006, "Finite-element discretization of static Hamilton-Jacobi
// equations based on a local variational principle", Comput Visual Sci 9:57; the same local
// problem as Fu, Jeong, Pan, Kirby & Whitaker 2011, SIAM J Sci Comput 33:2468): the time of a
// vertex v from a tetrahedron with the other vertices a, b, c is
//   t_v = min over x in the face (a, b, c) of  t_h(x) + |v - x|_M,
// t_h linear on the face. The minimum of this convex function is found exactly: the interior
// stationary point in closed form when it lies inside the face (the characteristic crosses the
// face: causality), otherwise the same 1D problem on the three edges, and the three vertices.
// Every candidate is the length of a realisable path, so on a constant metric the discrete times
// never fall below the exact ones, whatever the angles of the mesh (obtuse or sheared elements).
//
// Solver: label-correcting fast marching. Vertices leave a heap in order of time (ties by index)
// and update the other vertices of their tetrahedra; a vertex whose time drops after it left is
// pushed again (the correction fast marching needs when anisotropy breaks its ordering). The
// result is the fixed point of the local solver, the same as the fast iterative method of Fu et
// al. 2011. Serial and deterministic: the same mesh and options give the same bits.
#pragma once

#include "model/fem/cavity.h"
#include "model/fem/material.h"
#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// Conduction velocities along the fibre, sheet and sheet-normal directions [m/s]. Defaults: pig
// LV, orthotropic, 0.67 / 0.30 / 0.17 m/s (Caldwell et al. 2009, Circ Arrhythm Electrophysiol 2:433;
// the fibre value checked against the abstract, the sheet and normal values to verify).
struct ConductionVelocities {
  double fibre = 0.67;   // [m/s]
  double sheet = 0.30;   // [m/s]
  double normal = 0.17;  // [m/s]
  static ConductionVelocities isotropic(double v) { return {v, v, v}; }
};

// An activation onset: a point inside the mesh [m] and its time [s].
struct OnsetSite {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // [m]
  double time = 0.0;                                   // [s]
};

// An activation onset at a mesh vertex (index < n_vertices) and its time [s].
struct VertexOnset {
  int vertex = 0;
  double time = 0.0;  // [s]
};

struct EikonalOptions {
  // One entry for the whole mesh or one per tetrahedron.
  std::vector<ConductionVelocities> velocities = {ConductionVelocities{}};
  // Local frames (columns f, s, n; material.h), one for the whole mesh or one per tetrahedron.
  std::vector<Frame> frames = {Frame::Identity()};
  // A site inside tetrahedron e sets the exact times t0 + |x_v - x0|_M(e) on the four vertices of
  // e (the smaller value wins when onsets overlap).
  std::vector<OnsetSite> sites;
  // Onsets placed directly on vertices (no point location); sites and vertex onsets may be mixed,
  // at least one of the two lists is non-empty.
  std::vector<VertexOnset> vertex_onsets;
  // Vertices within this distance [m] of a site also get the exact time t0 + |x_v - x0|_M(e), M(e)
  // the metric of the tetrahedron containing the site (exact when the metric is constant on the
  // ball). A first-order scheme started from a point source has an O(h log(1/h)) error (Zhao 2005,
  // Math Comp 74:603); exact values on a ball of fixed radius restore first order (measured in
  // tests/model/fem/eikonal_test.cpp). 0: only the four vertices of the containing tetrahedron.
  double source_radius = 0.0;
  // A vertex is updated only when its time drops by more than this [s].
  double tolerance = 1e-12;
};

struct EikonalResult {
  Eigen::VectorXd times;  // activation time per vertex [s] (size mesh.n_vertices)
  long heap_pops = 0;     // vertices taken from the heap (>= n_vertices reached)
  long reopened = 0;      // pops of a vertex that had left the heap before (corrections)
  double earliest = 0.0;  // min of times [s]
  double latest = 0.0;    // max of times [s]
  double total_activation_time() const { return latest - earliest; }  // [s]
};

// Solves the eikonal equation on the vertices of `mesh` (straight-sided tetrahedra; the mid-edge
// nodes of quadratic meshes are ignored). Throws std::invalid_argument, naming the offending value,
// when a velocity is not positive and finite, a frame is not orthonormal, a size does not match,
// there is no onset, an onset time is not finite, a vertex onset is out of range, a site lies outside the mesh, or source_radius < 0. Vertices that no
// path reaches (a disconnected mesh) keep +infinity. Thread-safe (no shared state).
EikonalResult solve_eikonal(const Mesh& mesh, const EikonalOptions& options);

// The metric M = R diag(1/v_f^2, 1/v_s^2, 1/v_n^2) R^T of a frame R = (f, s, n) [s^2/m^2].
Eigen::Matrix3d conduction_metric(const Frame& frame, const ConductionVelocities& v);

// The tetrahedron containing x and its barycentric coordinates (vertex order of mesh.tets), or -1
// when x lies outside (tolerance 1e-9 in barycentric coordinates). When x is on a shared face the
// tetrahedron with the largest smallest coordinate wins (lowest index on ties).
int locate_point(const Mesh& mesh, const Eigen::Vector3d& x, Eigen::Vector4d* barycentric = nullptr);

// --- Interpolation of the P1 times ---------------------------------------------------------------

// Time at every node: vertices as given, mid-edge nodes the mean of their edge ends [s].
Eigen::VectorXd activation_at_nodes(const Mesh& mesh, const Eigen::VectorXd& vertex_times);
// Time at barycentric coordinates (vertex order of mesh.tets) of tetrahedron `tet` [s].
double activation_at(const Mesh& mesh, const Eigen::VectorXd& vertex_times, int tet, const Eigen::Vector4d& barycentric);
// Time at the quadrature points of tet_rule(degree) (element.h), element-major: entry
// e * n_qp + q, the same layout as the fibre frames of fibres.h [s].
std::vector<double> activation_at_quadrature(const Mesh& mesh, const Eigen::VectorXd& vertex_times, int quadrature_degree);

// --- Velocity fields and activation patterns of the LV ---------------------------------------

// Distance of every vertex from the vertices of the faces tagged `tag` [m], through the mesh (an
// isotropic eikonal solve at 1 m/s; an upper bound of the Euclidean distance within the wall).
// Throws std::invalid_argument when no face carries the tag.
Eigen::VectorXd surface_depth(const Mesh& mesh, int tag);

// Per-tetrahedron velocities: `bulk` everywhere, isotropic `fast_speed` [m/s] on the tetrahedra
// whose centroid lies within `depth` [m] of the surface `tag` (mean of the vertex depths), and on
// every tetrahedron with a face on it: a fast subendocardial layer standing for the Purkinje
// network, of a thickness that does not depend on the mesh once the mesh resolves it.
std::vector<ConductionVelocities> layered_velocities(const Mesh& mesh, const ConductionVelocities& bulk,
                                                     double fast_speed, double depth, int tag = kEndocardium);

// The vertex of the faces tagged `tag` nearest to the surface point at AHA coordinates (h, phi)
// (cavity.h: h the height fraction from the endocardial apex along the long axis of `frame`, phi
// [deg] about it from reference_direction): distance measured along the axis and along the arc at
// the vertex's own radius. Throws std::invalid_argument when no face carries the tag.
Eigen::Vector3d surface_site(const Mesh& mesh, const AhaFrame& frame, const Eigen::Vector3d& reference_direction,
                             int tag, double h, double phi_deg);

enum class ActivationPattern {
  kHealthy,  // LV endocardial onset at Durrer's three sites, fast endocardial layer
  kLbbb,     // left bundle branch block: onset on the right side of the septum, no fast layer
};
// "healthy" / "lbbb"; throws std::invalid_argument naming the text otherwise.
ActivationPattern parse_activation_pattern(const std::string& name);
std::string to_string(ActivationPattern pattern);

struct ActivationPatternOptions {
  ConductionVelocities myocardium{};  // [m/s] (Caldwell et al. 2009)
  double fast_endocardial_speed = 2.0;  // [m/s], healthy only (Purkinje-like layer; docs/models.md)
  double fast_endocardial_depth = 1.5e-3;  // [m], thickness of that layer
  // LBBB: times at which the right-sided onset reaches the septum (RV septal surface) and, later,
  // the anterior and inferior RV insertions (RV free wall activation) [s]. The 20 ms delay is an
  // assumption of this model (no right ventricle in the mesh), not a measured value.
  double lbbb_septal_onset = 0.0;        // [s]
  double lbbb_insertion_onset = 0.020;   // [s]
  Eigen::Vector3d reference_direction = Eigen::Vector3d::UnitX();  // anterior RV insertion (cavity.h)
  std::string validate() const;
};

// Eikonal options of a pattern on an LV mesh with endocardial, epicardial and base tags and
// per-tetrahedron frames (e.g. ellipsoid_fibres(..., 1)). Sites are placed on mesh vertices at AHA
// coordinates (height fraction h from the apex, angle phi about the long axis; cavity.h):
//  - healthy (Durrer et al. 1970, Circulation 41:899: the first LV areas excited, 0-5 ms, are high
//    anterior paraseptal, central left septal, and posterior paraseptal one third from apex to
//    base): endocardial sites at (h, phi) = (0.8, 0 deg), (0.5, 60 deg), (1/3, 120 deg), time 0,
//    and the fast endocardial layer;
//  - lbbb (Strik et al. 2012, J Cardiovasc Transl Res 5:117: the LV is activated from the right
//    ventricle across the septum, the lateral wall last): epicardial sites on the septum (the RV
//    side, phi 30/60/90 deg at h 1/3, 1/2, 2/3) at lbbb_septal_onset and on the RV insertion lines
//    (phi 0 and 120 deg, same heights) at lbbb_insertion_onset; myocardial velocities everywhere.
// Throws std::invalid_argument on invalid options or a mesh without the tags.
EikonalOptions activation_pattern(const Mesh& mesh, const std::vector<Frame>& tet_frames, ActivationPattern pattern,
                                  const ActivationPatternOptions& options = {});

}  // namespace sigmaheart::model::fem
