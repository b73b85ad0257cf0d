// AHA 17-segment labels, cavity volume and regional volumes of the left ventricle.
//
// AHA segments (Cerqueira et al. 2002, Circulation 105:539; docs/models.md s.5). The long axis runs
// from the endocardial apex to the centre of the endocardial base ring; the cavity length L is
// cut in equal thirds: basal (1-6), mid (7-12), apical (13-16); 17 is the apical cap, by default
// the wall beyond the endocardial apex (Cerqueira: "the area beyond the end of the cavity").
// Angles phi are measured about the axis (counter-clockwise seen from the apex looking toward the
// base, i.e. right-handed about apex -> base) from a reference direction standing for the
// anterior RV insertion point, the boundary between segments 1 and 2. An ellipsoid has no RV:
// the documented default is +x. Basal/mid: segment 1 (anterior) spans phi in [-60, 0) deg, then
// anteroseptal, inferoseptal, inferior, inferolateral, anterolateral in 60-deg steps. Apical:
// 13 anterior [-75, 15), 14 septal, 15 inferior, 16 lateral in 90-deg steps (centred on the
// basal anterior, septal, inferior and lateral midlines).
//
// Volumes (Marchesseau et al. 2013, MedIA 17:816, here with the long axis as reference):
//   cavity   V   = int_endo ((x - c).a) (n.a) da            (field w = ((x - c).a) a, div w = 1)
//   regional V_z = 1/2 int_endo,z (x - c)_perp . n_perp da  (field w = (x - c)_perp / 2)
// with n the normal leaving the cavity, a the axis and c the current base-ring centre. Both
// fields vanish on a lid perpendicular to a through c, so the lid adds nothing and the regional
// volumes sum to the cavity volume exactly; the 60-deg sector of a ring holds exactly the cavity
// volume between its two cutting planes within that sector. The lid is assumed flat and
// perpendicular to the axis (true for the fixed and the sliding base).
#pragma once

#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

inline constexpr int kAhaSegments = 17;

struct AhaOptions {
  Eigen::Vector3d reference_direction = Eigen::Vector3d::UnitX();  // anterior RV insertion
  double apical_cap_fraction = 0.0;  // cap 17 also takes h < this fraction of L on the endocardium
  int endo_tag = kEndocardium;
  int base_tag = kBase;
  std::string validate() const;
};

struct AhaFrame {
  Eigen::Vector3d apex;     // endocardial apex (reference configuration)
  Eigen::Vector3d centre;   // centre of the endocardial base ring
  Eigen::Vector3d axis;     // unit, apex -> base
  double length = 0.0;      // cavity length L
};

struct AhaLabels {
  AhaFrame frame;
  std::vector<int> element_segment;  // 1..17 per tetrahedron
  std::vector<int> face_segment;     // 1..17 per boundary face, 0 for non-endocardial faces
  std::vector<int> base_ring;        // nodes of the endocardial base ring (c is their mean)
};

// Segment (1..17) of a point given by its height fraction h = (x - apex).axis / L and angle phi.
int aha_segment(double h, double phi_deg, double apical_cap_fraction);

// Frame and labels of a mesh in its reference configuration. Throws std::invalid_argument when
// the mesh has no endocardial or base faces.
AhaLabels aha_labels(const Mesh& mesh, const AhaOptions& options = {});

// Labels in a given frame (from landmarks, e.g. model/fem/tracked_volumes.h): every tetrahedron
// and every face tagged options.endo_tag classified at positions x (n_nodes x 3, the reference
// configuration), phi measured from `reference_direction` (projected normal to the axis), with
// `ring` as the base ring. aha_labels() is this with the frame it finds. Throws
// std::invalid_argument when the reference direction is parallel to the axis.
AhaLabels aha_labels_in_frame(const Mesh& mesh, const Eigen::MatrixX3d& x, const AhaFrame& frame,
                              const Eigen::Vector3d& reference_direction, const AhaOptions& options,
                              std::vector<int> ring);

struct CavityVolumes {
  double cavity = 0.0;                          // [m^3]
  std::array<double, kAhaSegments> regional{};  // [m^3], segment s at index s-1
  Eigen::VectorXd gradient;                     // dV/dx, 3 per node (only when requested)
};

// Volumes at current nodal positions x (n_nodes x 3), long axis labels.frame.axis (unit), c the
// mean of labels.base_ring at x. With
// `with_gradient` the derivative of the cavity volume w.r.t. every nodal coordinate is returned.
CavityVolumes cavity_volumes(const Mesh& mesh, const Eigen::MatrixX3d& x, const AhaLabels& labels,
                             bool with_gradient = false);

// Nodes shared by the endocardium and the base (the base ring).
std::vector<int> base_ring(const Mesh& mesh, int endo_tag = kEndocardium, int base_tag = kBase);

}  // namespace sigmaheart::model::fem
