// Fibre fields: helix angle varying linearly across the wall (Streeter-type rule).
//
// At a point with transmural coordinate t (0 endocardium, 1 epicardium), local circumferential
// e_c (counter-clockwise about +z seen from the base), longitudinal e_l (apex -> base, tangent to
// the wall) and transmural e_t (endo -> epi) directions, the fibre is
//   f = cos(alpha) e_c + sin(alpha) e_l,  alpha = alpha_endo + t (alpha_epi - alpha_endo),
// the sheet-normal n = e_t and the sheet s = n x f (Land et al. 2015, problem 3, uses +90 endo to
// -90 epi; the thesis default is +70 endo to -70 epi).
#pragma once

#include "model/fem/material.h"
#include "model/fem/mesh.h"

#include <Eigen/Core>

#include <string>
#include <functional>
#include <vector>

namespace sigmaheart::model::fem {

struct FibreOptions {
  double alpha_endo_deg = 70.0;   // helix angle at the endocardium [deg]
  double alpha_epi_deg = -70.0;   // at the epicardium [deg]
  std::string validate() const;
};

// Orthonormal frame (f, s, n) from the local directions and the helix angle [rad].
Frame helix_frame(const Eigen::Vector3d& e_c, const Eigen::Vector3d& e_l, const Eigen::Vector3d& e_t, double alpha);

// frame(e, N) at every quadrature point (degree as in MechanicsOptions) of every tetrahedron e, N
// the element's shape functions there; element-major, n_tets * n_qp entries: the layout of the
// fibre fields below.
std::vector<Frame> frames_at_quadrature_points(
    const Mesh& mesh, int quadrature_degree,
    const std::function<Frame(Eigen::Index e, const Eigen::VectorXd& N)>& frame);

// Frames at the quadrature points (degree as in MechanicsOptions) of every tetrahedron of a mesh
// of the ellipsoid; t and the directions come from the ellipsoidal coordinates of the point.
// Element-major, n_tets * n_qp entries.
std::vector<Frame> ellipsoid_fibres(const Mesh& mesh, const EllipsoidGeometry& geometry, const FibreOptions& options,
                                    int quadrature_degree);

// Transmural coordinate of every node from a Laplace problem: t = 0 on `endo_tag`, 1 on
// `epi_tag`, natural conditions elsewhere (for meshes without an analytic parametrisation).
Eigen::VectorXd transmural_coordinate(const Mesh& mesh, int endo_tag = kEndocardium, int epi_tag = kEpicardium);

// Frames at quadrature points from a nodal transmural coordinate: e_t = grad t / |grad t|,
// e_l = the long axis `axis` (apex -> base) projected on the plane normal to e_t, e_c = e_l x e_t.
std::vector<Frame> rule_based_fibres(const Mesh& mesh, const Eigen::VectorXd& t, const Eigen::Vector3d& axis,
                                     const FibreOptions& options, int quadrature_degree);

// One frame per tetrahedron with the fibre along `f` (beam of Land problem 1).
std::vector<Frame> uniform_fibres(const Mesh& mesh, const Eigen::Vector3d& f, const Eigen::Vector3d& s);

}  // namespace sigmaheart::model::fem
