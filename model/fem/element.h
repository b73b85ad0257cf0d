// Reference-element shape functions and quadrature rules (tetrahedra and triangles, P1 and P2).
// Reference tetrahedron: (0,0,0) (1,0,0) (0,1,0) (0,0,1), volume 1/6; reference triangle area 1/2.
// Node order as in mesh.h (VTK).
#pragma once

#include <Eigen/Core>

#include <vector>

namespace sigmaheart::model::fem {

struct QuadraturePoint3 {
  Eigen::Vector3d xi;
  double weight;  // weights sum to 1/6
};
struct QuadraturePoint2 {
  Eigen::Vector2d xi;
  double weight;  // weights sum to 1/2
};

// Tetrahedron rules with positive weights: degree 1 (1 point), 2 (4 points), 5 (14 points,
// Walkington 2000 / Keast-type symmetric rule). Other degrees round up; above 5 throws.
const std::vector<QuadraturePoint3>& tet_rule(int degree);
// Triangle rules: degree 2 (3 points) and 4 (6 points, Dunavant 1985).
const std::vector<QuadraturePoint2>& tri_rule(int degree);

// Values (n) and reference gradients (n x 3) of the P1 (n = 4) or P2 (n = 10) tetrahedron.
void tet_shape(int order, const Eigen::Vector3d& xi, Eigen::VectorXd& N, Eigen::MatrixXd& dN);
// Values (n) and reference derivatives (n x 2) of the P1 (3) or P2 (6) triangle.
void tri_shape(int order, const Eigen::Vector2d& xi, Eigen::VectorXd& N, Eigen::MatrixXd& dN);

}  // namespace sigmaheart::model::fem
