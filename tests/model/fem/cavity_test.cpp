// AHA labels, cavity and regional volumes on the undeformed ellipsoid (exact answers) and on a
// deformed one (sum rule, derivative against finite differences).
#include "model/fem/cavity.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace sigmaheart::model::fem {
namespace {

// Cavity volume of the endocardial ellipsoid between the planes z1 < z2:
// pi r_s^2 int (1 - z^2 / r_l^2) dz (docs/models.md s.5).
double slab(const EllipsoidGeometry& g, double z1, double z2) {
  const double rs = g.r_short_endo, rl = g.r_long_endo;
  return std::numbers::pi * rs * rs * ((z2 - z1) - (z2 * z2 * z2 - z1 * z1 * z1) / (3 * rl * rl));
}

Mesh aha_mesh(int n_long = 9, int n_circ = 24) {
  EllipsoidMeshOptions o;
  o.n_transmural = 1;
  o.n_longitudinal = n_long;
  o.n_circumferential = n_circ;
  return ellipsoid_mesh(EllipsoidGeometry{}, o);
}

TEST(Cavity, SegmentsOfTheUndeformedEllipsoidHoldTheirAnalyticSlabShare) {
  const EllipsoidGeometry g;
  const Mesh mesh = aha_mesh();
  const AhaLabels labels = aha_labels(mesh);
  EXPECT_NEAR(labels.frame.length, g.z_base + g.r_long_endo, 1e-12);
  EXPECT_NEAR(labels.frame.axis.z(), 1.0, 1e-12);
  const CavityVolumes v = cavity_volumes(mesh, mesh.nodes, labels);
  const double z0 = -g.r_long_endo, L = g.z_base - z0;
  const double cav = slab(g, z0, g.z_base);
  EXPECT_NEAR(v.cavity, cav, 1e-3 * cav);
  const double basal = slab(g, z0 + 2 * L / 3, g.z_base), mid = slab(g, z0 + L / 3, z0 + 2 * L / 3),
               apical = slab(g, z0, z0 + L / 3);
  for (int s = 1; s <= 6; ++s) EXPECT_NEAR(v.regional[s - 1], basal / 6, 2e-3 * basal / 6) << "segment " << s;
  for (int s = 7; s <= 12; ++s) EXPECT_NEAR(v.regional[s - 1], mid / 6, 2e-3 * mid / 6) << "segment " << s;
  for (int s = 13; s <= 16; ++s) EXPECT_NEAR(v.regional[s - 1], apical / 4, 2e-3 * apical / 4) << "segment " << s;
  EXPECT_EQ(v.regional[16], 0.0);  // the cap has no endocardium (Cerqueira)
  // The sectors of one ring are equal to rounding (the mesh repeats every 15 degrees).
  for (int s = 2; s <= 6; ++s) EXPECT_NEAR(v.regional[s - 1], v.regional[0], 1e-12 * basal);
}

TEST(Cavity, ConvergesToTheAnalyticVolumeUnderRefinement) {
  const EllipsoidGeometry g;
  const double cav = slab(g, -g.r_long_endo, g.z_base);
  double prev = 1.0;
  for (int k : {1, 2, 4}) {
    const Mesh mesh = aha_mesh(3 * k, 12 * k);
    const double err = std::abs(cavity_volumes(mesh, mesh.nodes, aha_labels(mesh)).cavity - cav) / cav;
    EXPECT_LT(err, prev / 4) << "k = " << k;  // quadratic surfaces: at least 4x per halving
    prev = err;
  }
}

// A smooth deformation that keeps the base plane in place.
Eigen::MatrixX3d deform(const Mesh& mesh, double eps) {
  Eigen::MatrixX3d x = mesh.nodes;
  const double zb = 5e-3, L = 20e-3;
  for (int n = 0; n < mesh.n_nodes(); ++n) {
    const double X = mesh.nodes(n, 0), Y = mesh.nodes(n, 1), Z = mesh.nodes(n, 2);
    const double w = (Z - zb) / L;
    x(n, 0) += eps * L * w * (0.3 + Y / L);
    x(n, 1) += eps * L * w * (0.2 * X / L - 0.1);
    x(n, 2) += eps * L * w * (0.5 + X * X / (L * L));
  }
  return x;
}

TEST(Cavity, RegionalVolumesAddUpToTheCavityVolumeWhenDeformed) {
  const Mesh mesh = aha_mesh(6, 12);
  const AhaLabels labels = aha_labels(mesh);
  for (double eps : {0.0, 0.05, 0.2}) {
    const CavityVolumes v = cavity_volumes(mesh, deform(mesh, eps), labels);
    double sum = 0;
    for (double r : v.regional) sum += r;
    EXPECT_NEAR(sum, v.cavity, 1e-12 * v.cavity) << "eps " << eps;
  }
}

TEST(Cavity, VolumeGradientMatchesFiniteDifferences) {
  const Mesh mesh = aha_mesh(3, 12);
  const AhaLabels labels = aha_labels(mesh);
  const Eigen::MatrixX3d x = deform(mesh, 0.1);
  const CavityVolumes v = cavity_volumes(mesh, x, labels, true);
  ASSERT_EQ(v.gradient.size(), 3 * mesh.n_nodes());
  const double h = 1e-9;
  double err = 0, mag = 0;
  for (int n = 0; n < mesh.n_nodes(); n += 7)
    for (int d = 0; d < 3; ++d) {
      Eigen::MatrixX3d xp = x, xm = x;
      xp(n, d) += h;
      xm(n, d) -= h;
      const double fd = (cavity_volumes(mesh, xp, labels).cavity - cavity_volumes(mesh, xm, labels).cavity) / (2 * h);
      err = std::max(err, std::abs(fd - v.gradient[3 * n + d]));
      mag = std::max(mag, std::abs(fd));
    }
  EXPECT_GT(mag, 0.0);
  EXPECT_LT(err, 1e-6 * mag);
}

TEST(Cavity, LabelsCoverAllSeventeenSegmentsInTheDocumentedOrder) {
  const Mesh mesh = aha_mesh();
  const AhaLabels labels = aha_labels(mesh);
  std::array<int, 18> count{};
  for (int s : labels.element_segment) {
    ASSERT_GE(s, 1);
    ASSERT_LE(s, 17);
    ++count[static_cast<size_t>(s)];
  }
  for (int s = 1; s <= 17; ++s) EXPECT_GT(count[static_cast<size_t>(s)], 0) << "segment " << s;
  // Reference direction +x is the 1|2 boundary: just counter-clockwise of +x (phi = 30) is
  // anteroseptal (2) at base height, just clockwise (phi = -30) is anterior (1).
  EXPECT_EQ(aha_segment(0.9, 30, 0), 2);
  EXPECT_EQ(aha_segment(0.9, -30, 0), 1);
  EXPECT_EQ(aha_segment(0.5, 150, 0), 10);
  EXPECT_EQ(aha_segment(0.2, -30, 0), 13);
  EXPECT_EQ(aha_segment(0.2, 60, 0), 14);
  EXPECT_EQ(aha_segment(0.2, 240, 0), 16);
  EXPECT_EQ(aha_segment(-0.01, 0, 0), 17);
  EXPECT_EQ(aha_segment(0.05, 0, 0.1), 17);
}

}  // namespace
}  // namespace sigmaheart::model::fem
