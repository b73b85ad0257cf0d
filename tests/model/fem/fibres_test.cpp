// Helix fibre fields: angles at the endocardium and epicardium, orthonormal frames, the Laplace
// transmural coordinate.
#include "model/fem/fibres.h"

#include "model/fem/element.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace sigmaheart::model::fem {
namespace {

// Helix angle of f against the circumferential direction, about the wall normal [deg].
double helix_deg(const Frame& R, const Eigen::Vector3d& x) {
  const Eigen::Vector3d e_c = Eigen::Vector3d(-x.y(), x.x(), 0).normalized();
  const Eigen::Vector3d f = R.col(0);
  const Eigen::Vector3d e_l = R.col(2).cross(e_c).normalized();  // apex -> base in the wall plane
  return std::atan2(f.dot(e_l), f.dot(e_c)) * 180.0 / std::numbers::pi;
}

TEST(Fibres, EllipsoidHelixAngleVariesLinearlyAcrossTheWall) {
  EllipsoidMeshOptions mo;
  mo.n_transmural = 4;
  mo.n_longitudinal = 6;
  mo.n_circumferential = 12;
  const EllipsoidGeometry g;
  const Mesh mesh = ellipsoid_mesh(g, mo);
  const auto frames = ellipsoid_fibres(mesh, g, FibreOptions{60.0, -60.0}, 2);
  const auto& rule = tet_rule(2);
  ASSERT_EQ(frames.size(), static_cast<size_t>(mesh.n_tets()) * rule.size());
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  int checked = 0;
  for (Eigen::Index e = 0; e < mesh.tets.rows(); ++e)
    for (size_t q = 0; q < rule.size(); ++q) {
      const Frame& R = frames[static_cast<size_t>(e) * rule.size() + q];
      EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
      EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
      tet_shape(2, rule[q].xi, N, dN);
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      for (int a = 0; a < 10; ++a) x += N[a] * mesh.nodes.row(mesh.tets(e, a)).transpose();
      const Eigen::Vector3d c = g.coordinates(x);
      if (c[1] < 0.3) continue;  // away from the axis, where e_c is defined
      EXPECT_NEAR(helix_deg(R, x), 60.0 - 120.0 * std::clamp(c[0], 0.0, 1.0), 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 100);
}

TEST(Fibres, LaplaceTransmuralCoordinateIsZeroOnEndoOneOnEpiAndMonotone) {
  EllipsoidMeshOptions mo;
  mo.n_transmural = 3;
  mo.order = 2;
  const EllipsoidGeometry g;
  const Mesh mesh = ellipsoid_mesh(g, mo);
  const Eigen::VectorXd t = transmural_coordinate(mesh);
  for (int n : mesh.nodes_with_tag(kEndocardium)) EXPECT_NEAR(t[n], 0.0, 1e-12);
  for (int n : mesh.nodes_with_tag(kEpicardium)) EXPECT_NEAR(t[n], 1.0, 1e-12);
  // Inside: close to the ellipsoidal coordinate (exact for concentric spheres; here within 0.15, largest near the base where the Laplace problem has a natural condition).
  for (int n = 0; n < mesh.n_vertices; ++n) EXPECT_NEAR(t[n], g.coordinates(mesh.nodes.row(n).transpose())[0], 0.15);
  const auto frames = rule_based_fibres(mesh, t, Eigen::Vector3d::UnitZ(), FibreOptions{}, 2);
  EXPECT_EQ(frames.size(), static_cast<size_t>(mesh.n_tets()) * 4);
}

TEST(Fibres, UniformFibresAreOrthonormal) {
  const Mesh m = box_mesh(1, 1, 1, 1, 1, 1, 1);
  const auto f = uniform_fibres(m, Eigen::Vector3d(1, 1, 0), Eigen::Vector3d::UnitY());
  EXPECT_LT((f[0].transpose() * f[0] - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(f[0](0, 0), std::sqrt(0.5), 1e-14);
}

}  // namespace
}  // namespace sigmaheart::model::fem
