// Generated meshes: conformity, orientation, tags, exact geometry.
#include "model/fem/mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <numbers>

namespace sigmaheart::model::fem {
namespace {

TEST(Mesh, EllipsoidMeshesAreConformingAndPositivelyOriented) {
  for (int order : {1, 2})
    for (int k : {1, 2}) {
      EllipsoidMeshOptions o;
      o.n_transmural = k;
      o.n_longitudinal = 6 * k;
      o.n_circumferential = 12 * k;
      o.order = order;
      const Mesh m = ellipsoid_mesh(EllipsoidGeometry{}, o);
      EXPECT_EQ(m.check(), "") << "order " << order << " k " << k;
      // Every boundary face is tagged: endo, epi or base (a closed surface, no holes).
      for (int t : m.face_tag) EXPECT_NE(t, kNoTag);
      // Euler characteristic of the boundary (a topological disc x interval = sphere): V - E + F = 2.
      std::set<std::pair<int, int>> edges;
      std::set<int> verts;
      for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
        for (int a = 0; a < 3; ++a) {
          const int i = m.faces(f, a), j = m.faces(f, (a + 1) % 3);
          edges.insert({std::min(i, j), std::max(i, j)});
          verts.insert(i);
        }
      EXPECT_EQ(static_cast<long>(verts.size()) - static_cast<long>(edges.size()) + m.faces.rows(), 2);
    }
}

TEST(Mesh, EllipsoidSurfacesLieOnTheAnalyticEllipsoidsAndBasePlane) {
  const EllipsoidGeometry g;
  const Mesh m = ellipsoid_mesh(g, EllipsoidMeshOptions{});
  for (int tag : {kEndocardium, kEpicardium})
    for (int n : m.nodes_with_tag(tag)) {
      const double rs = tag == kEndocardium ? g.r_short_endo : g.r_short_epi;
      const double rl = tag == kEndocardium ? g.r_long_endo : g.r_long_epi;
      const double rho = std::hypot(m.nodes(n, 0), m.nodes(n, 1));
      EXPECT_NEAR(rho * rho / (rs * rs) + m.nodes(n, 2) * m.nodes(n, 2) / (rl * rl), 1.0, 1e-12);
    }
  for (int n : m.nodes_with_tag(kBase)) EXPECT_NEAR(m.nodes(n, 2), g.z_base, 1e-15);
}

TEST(Mesh, LinearWallVolumeConvergesToTheAnalyticShell) {
  // Volume of the truncated ellipsoidal shell: the epicardial minus the endocardial cap below z_b.
  const EllipsoidGeometry g;
  auto cap = [&](double rs, double rl) {
    const double z1 = -rl, z2 = g.z_base;
    return std::numbers::pi * rs * rs * ((z2 - z1) - (z2 * z2 * z2 - z1 * z1 * z1) / (3 * rl * rl));
  };
  const double exact = cap(g.r_short_epi, g.r_long_epi) - cap(g.r_short_endo, g.r_long_endo);
  double prev = 1;
  for (int k : {1, 2, 4}) {
    EllipsoidMeshOptions o;
    o.n_longitudinal = 3 * k;
    o.n_circumferential = 12 * k;
    o.order = 1;
    const double err = std::abs(ellipsoid_mesh(g, o).volume() - exact) / exact;
    EXPECT_LT(err, prev / 3) << k;
    prev = err;
  }
}

TEST(Mesh, BoxMeshHasTheRightVolumeAndTags) {
  const Mesh m = box_mesh(10e-3, 1e-3, 1e-3, 8, 1, 1, 2);
  EXPECT_EQ(m.check(), "");
  EXPECT_NEAR(m.volume(), 1e-8, 1e-20);
  int clamped = 0, bottom = 0;
  for (int t : m.face_tag) {
    clamped += t == kClamped;
    bottom += t == kBottom;
  }
  EXPECT_EQ(clamped, 2);
  EXPECT_EQ(bottom, 16);
}

TEST(Mesh, MakeQuadraticKeepsTagsAndAddsOneNodePerEdge) {
  const Mesh lin = box_mesh(1, 1, 1, 2, 2, 2, 1);
  const Mesh q = make_quadratic(lin);
  EXPECT_EQ(q.check(), "");
  const Mesh q2 = box_mesh(1, 1, 1, 2, 2, 2, 2);
  EXPECT_EQ(q.n_nodes(), q2.n_nodes());
  EXPECT_EQ(q.faces.rows(), lin.faces.rows());
  int tagged = 0;
  for (int t : q.face_tag) tagged += t != kNoTag;
  EXPECT_EQ(tagged, 16);  // x = 0 and z = 0 faces, 8 triangles each
}

TEST(Mesh, InvalidOptionsAreRejected) {
  EllipsoidMeshOptions o;
  o.n_circumferential = 2;
  EXPECT_THROW(ellipsoid_mesh(EllipsoidGeometry{}, o), std::invalid_argument);
  EllipsoidGeometry g;
  g.r_short_epi = 5e-3;
  EXPECT_THROW(ellipsoid_mesh(g, EllipsoidMeshOptions{}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model::fem
