// Volumes of a tracked endocardium (model/fem/tracked_volumes.h, docs/models.md s.5.1) against the
// exact integrals of a truncated prolate ellipsoid that deforms by a known formula: scaled
// radially by s_r and along the axis by s_l about the origin, and twisted about the axis by an
// angle growing linearly from the apex to the base. The deformed endocardium is again a truncated
// prolate ellipsoid (r_s s_r, r_l s_l, base at z_b s_l); twist moves material points along it,
// so the material segment between heights h0..h1 (fractions of the cavity length, kept by the
// scaling) and an angle span dphi holds exactly dphi/360 of the cavity between those heights:
//   V(h0, h1) = pi r_s'^2 [z - z^3 / (3 r_l'^2)] from z(h0) to z(h1),  z(h) = -r_l' + h (z_b' + r_l').
#include "model/fem/tracked_volumes.h"

#include "model/fem/cavity.h"
#include "model/fem/mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace sigmaheart::model::fem {
namespace {

struct Motion {
  double sr = 1.0, sl = 1.0, twist_deg = 0.0;
};

Eigen::MatrixX3d deform(const Mesh& m, const EllipsoidGeometry& g, const Motion& d) {
  Eigen::MatrixX3d x(m.n_nodes(), 3);
  for (int n = 0; n < m.n_nodes(); ++n) {
    const Eigen::Vector3d p = m.nodes.row(n);
    const double h = (p.z() + g.r_long_endo) / (g.z_base + g.r_long_endo);
    const double b = d.twist_deg * h * std::numbers::pi / 180.0;
    x.row(n) << d.sr * (std::cos(b) * p.x() - std::sin(b) * p.y()), d.sr * (std::sin(b) * p.x() + std::cos(b) * p.y()), d.sl * p.z();
  }
  return x;
}

struct Exact {
  double cavity = 0;
  std::array<double, kAhaSegments> regional{};
};

Exact exact_volumes(const EllipsoidGeometry& g, const Motion& d) {
  const double rs = g.r_short_endo * d.sr, rl = g.r_long_endo * d.sl, zb = g.z_base * d.sl;
  const auto F = [&](double h) {
    const double z = -rl + h * (zb + rl);
    return std::numbers::pi * rs * rs * (z - z * z * z / (3 * rl * rl));
  };
  Exact e;
  e.cavity = F(1) - F(0);
  for (int s = 1; s <= 6; ++s) e.regional[static_cast<size_t>(s - 1)] = (F(1) - F(2.0 / 3)) / 6;
  for (int s = 7; s <= 12; ++s) e.regional[static_cast<size_t>(s - 1)] = (F(2.0 / 3) - F(1.0 / 3)) / 6;
  for (int s = 13; s <= 16; ++s) e.regional[static_cast<size_t>(s - 1)] = (F(1.0 / 3) - F(0)) / 4;
  return e;
}

// The endocardial faces of an ellipsoid mesh, as a tracked mesh would give them.
std::vector<char> endo_flags(const Mesh& m) {
  std::vector<char> f(m.face_tag.size());
  for (size_t k = 0; k < f.size(); ++k) f[k] = m.face_tag[k] == kEndocardium;
  return f;
}

Landmarks ellipsoid_landmarks(const EllipsoidGeometry& g) {
  Landmarks lm;
  lm.apex = {0, 0, -g.r_long_endo};
  lm.rv_anterior = {g.r_short_endo, 0, 0};
  return lm;
}

Mesh mesh_at(int level, int order) {
  EllipsoidMeshOptions o;
  o.n_longitudinal = 6 << level;
  o.n_circumferential = 24 << level;
  o.order = order;
  return ellipsoid_mesh(EllipsoidGeometry::human(), o);
}

// Largest relative error of the cavity and of the 16 non-empty segments.
std::pair<double, double> errors(const Mesh& m, const Motion& d) {
  const EllipsoidGeometry g = EllipsoidGeometry::human();
  const TrackedEndocardium t = make_tracked_endocardium(m, endo_flags(m), m.nodes, true, ellipsoid_landmarks(g));
  const CavityVolumes v = cavity_volumes(t.surface, deform(m, g, d), t.labels);
  const Exact e = exact_volumes(g, d);
  double reg = 0;
  for (int s = 0; s < 16; ++s) reg = std::max(reg, std::abs(v.regional[static_cast<size_t>(s)] / e.regional[static_cast<size_t>(s)] - 1));
  EXPECT_EQ(v.regional[16], 0.0);
  return {std::abs(v.cavity / e.cavity - 1), reg};
}

TEST(TrackedVolumes, DeformingEllipsoidConvergesAtSecondOrderOnLinearTriangles) {
  const Motion d{1.1, 0.9, 25.0};
  std::vector<std::pair<double, double>> e;
  for (int level = 0; level < 3; ++level) e.push_back(errors(mesh_at(level, 1), d));
  for (int k = 0; k + 1 < 3; ++k) {
    const double p_cav = std::log2(e[static_cast<size_t>(k)].first / e[static_cast<size_t>(k + 1)].first);
    const double p_reg = std::log2(e[static_cast<size_t>(k)].second / e[static_cast<size_t>(k + 1)].second);
    // Piecewise-linear interpolation of a smooth surface: the enclosed volume errs by O(h^2).
    EXPECT_NEAR(p_cav, 2.0, 0.15) << "level " << k << ": errors " << e[static_cast<size_t>(k)].first << " -> " << e[static_cast<size_t>(k + 1)].first;
    EXPECT_NEAR(p_reg, 2.0, 0.3) << "level " << k << ": errors " << e[static_cast<size_t>(k)].second << " -> " << e[static_cast<size_t>(k + 1)].second;
  }
  std::printf("linear triangles, 3 levels: cavity error %.2e %.2e %.2e, regional %.2e %.2e %.2e\n", e[0].first, e[1].first,
              e[2].first, e[0].second, e[1].second, e[2].second);
}

TEST(TrackedVolumes, DeformingEllipsoidConvergesFasterOnQuadraticTriangles) {
  const Motion d{1.1, 0.9, 25.0};
  const auto coarse = errors(mesh_at(0, 2), d), fine = errors(mesh_at(1, 2), d);
  // Curved (isoparametric) faces interpolate the surface to O(h^3); the volume converges at
  // least at third order.
  EXPECT_GT(std::log2(coarse.first / fine.first), 3.0) << coarse.first << " -> " << fine.first;
  EXPECT_GT(std::log2(coarse.second / fine.second), 2.5) << coarse.second << " -> " << fine.second;
  std::printf("quadratic triangles, 2 levels: cavity error %.2e %.2e, regional %.2e %.2e\n", coarse.first, fine.first,
              coarse.second, fine.second);
}

TEST(TrackedVolumes, LandmarksOfTheSimulatorsFrameGiveItsLabelsAndVolumes) {
  const Mesh m = mesh_at(0, 2);
  const AhaLabels own = aha_labels(m);
  const TrackedEndocardium t = make_tracked_endocardium(m, endo_flags(m), m.nodes, true, ellipsoid_landmarks(EllipsoidGeometry::human()));
  ASSERT_EQ(t.surface.faces.rows(), std::count(m.face_tag.begin(), m.face_tag.end(), kEndocardium));
  int k = 0;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    if (m.face_tag[static_cast<size_t>(f)] == kEndocardium) EXPECT_EQ(t.labels.face_segment[static_cast<size_t>(k++)], own.face_segment[static_cast<size_t>(f)]);
  EXPECT_EQ(t.labels.base_ring, own.base_ring);
  const Eigen::MatrixX3d x = deform(m, EllipsoidGeometry::human(), {1.05, 0.95, 10.0});
  const CavityVolumes a = cavity_volumes(m, x, own), b = cavity_volumes(t.surface, x, t.labels);
  EXPECT_NEAR(b.cavity / a.cavity, 1.0, 1e-13);
  for (int s = 0; s < 16; ++s) EXPECT_NEAR(b.regional[static_cast<size_t>(s)] / a.regional[static_cast<size_t>(s)], 1.0, 1e-12) << s + 1;
}

TEST(TrackedVolumes, RegionalVolumesSumToTheCavityWhenTheRingIsFlat) {
  const Mesh m = mesh_at(0, 1);
  const TrackedEndocardium t = make_tracked_endocardium(m, endo_flags(m), m.nodes, true, ellipsoid_landmarks(EllipsoidGeometry::human()));
  const CavityVolumes v = cavity_volumes(t.surface, deform(m, EllipsoidGeometry::human(), {0.8, 0.85, -15.0}), t.labels);
  double sum = 0;
  for (double r : v.regional) sum += r;
  EXPECT_NEAR(sum / v.cavity, 1.0, 1e-13);
}

// A surface mesh (triangles of any orientation, as an STL gives them) is oriented consistently
// and its sign chosen from the cavity: the same volumes as the oriented faces.
TEST(TrackedVolumes, ASurfaceInAnyOrientationGivesTheSameVolumes) {
  const Mesh m = mesh_at(0, 1);
  const std::vector<char> flags = endo_flags(m);
  Mesh surface = m;
  std::vector<Eigen::Index> keep;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    if (flags[static_cast<size_t>(f)]) keep.push_back(f);
  surface.faces.resize(static_cast<Eigen::Index>(keep.size()), 3);
  std::mt19937 rng(7);
  for (size_t i = 0; i < keep.size(); ++i) {
    surface.faces.row(static_cast<Eigen::Index>(i)) = m.faces.row(keep[i]);
    if (rng() % 2) {
      std::swap(surface.faces(static_cast<Eigen::Index>(i), 1), surface.faces(static_cast<Eigen::Index>(i), 2));
    }
  }
  surface.face_tag.assign(keep.size(), kNoTag);
  surface.tets.resize(0, 4);
  const Landmarks lm = ellipsoid_landmarks(EllipsoidGeometry::human());
  const TrackedEndocardium a = make_tracked_endocardium(m, flags, m.nodes, true, lm);
  const TrackedEndocardium b = make_tracked_endocardium(surface, std::vector<char>(keep.size(), 1), m.nodes, false, lm);
  EXPECT_GT(b.faces_flipped, 0);
  const Eigen::MatrixX3d x = deform(m, EllipsoidGeometry::human(), {1.1, 0.9, 20.0});
  const CavityVolumes va = cavity_volumes(a.surface, x, a.labels), vb = cavity_volumes(b.surface, x, b.labels);
  EXPECT_NEAR(vb.cavity / va.cavity, 1.0, 1e-13);
  for (int s = 0; s < 16; ++s) EXPECT_NEAR(vb.regional[static_cast<size_t>(s)] / va.regional[static_cast<size_t>(s)], 1.0, 1e-12);
}

TEST(TrackedVolumes, TheInnerBoundaryOfTheWallIsTheEndocardium) {
  for (int order : {1, 2}) {
    const Mesh m = mesh_at(0, order);
    EXPECT_EQ(inner_boundary_faces(m, m.nodes), endo_flags(m)) << "order " << order;
  }
}

// A closed surface (the endocardium with its lid, as a segmentation's surface comes) is cut by the
// plane of the base points; the lid's faces go and the rest is the open endocardium.
TEST(TrackedVolumes, BasePointsCutTheLidOfAClosedSurface) {
  const Mesh m = mesh_at(0, 1);
  const EllipsoidGeometry g = EllipsoidGeometry::human();
  std::vector<char> flags = endo_flags(m);
  for (size_t f = 0; f < flags.size(); ++f) flags[f] = flags[f] || m.face_tag[f] == kBase;  // the base ring's annulus as a lid stand-in
  Landmarks lm = ellipsoid_landmarks(g);
  for (double a : {0.0, 2.0, 4.0}) lm.base.push_back({g.r_short_endo * 0.9 * std::cos(a), g.r_short_endo * 0.9 * std::sin(a), g.z_base - 0.5e-3});
  const TrackedEndocardium t = make_tracked_endocardium(m, flags, m.nodes, true, lm);
  EXPECT_EQ(t.faces_cut, std::count(m.face_tag.begin(), m.face_tag.end(), kBase));
  // The rest is the open endocardium: the volumes of the endocardium alone.
  const TrackedEndocardium open = make_tracked_endocardium(m, endo_flags(m), m.nodes, true, ellipsoid_landmarks(g));
  EXPECT_EQ(t.surface.faces, open.surface.faces);
  EXPECT_EQ(cavity_volumes(t.surface, m.nodes, t.labels).cavity, cavity_volumes(open.surface, m.nodes, open.labels).cavity);
}

TEST(TrackedVolumes, LandmarksThatDoNotFitAreNamed) {
  const Mesh m = mesh_at(0, 1);
  const EllipsoidGeometry g = EllipsoidGeometry::human();
  auto fails_at = [&](Landmarks lm, const std::string& name, const std::string& words) {
    try {
      make_tracked_endocardium(m, endo_flags(m), m.nodes, true, lm);
      ADD_FAILURE() << name << " accepted";
    } catch (const LandmarkError& e) {
      EXPECT_EQ(e.landmark(), name);
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  Landmarks lm = ellipsoid_landmarks(g);
  lm.apex *= 1000;  // mm given as m
  fails_at(lm, "apex", "from the mesh's surface");
  lm = ellipsoid_landmarks(g);
  lm.rv_anterior = {0, 0, 0.2};
  fails_at(lm, "rv_anterior", "from the mesh's surface");
  lm = ellipsoid_landmarks(g);
  lm.rv_inferior = Eigen::Vector3d(0, -g.r_short_endo, 0);  // 270 deg: the wrong side
  fails_at(lm, "rv_inferior", "expected 40-200 deg");
}

TEST(TrackedVolumes, BothInsertionPointsCentreTheSeptumBetweenThem) {
  const EllipsoidGeometry g = EllipsoidGeometry::human();
  Landmarks lm = ellipsoid_landmarks(g);
  const Eigen::Vector3d c(0, 0, g.z_base), a = Eigen::Vector3d::UnitZ();
  double beta = 0;
  // At 120 deg the insertion points bound segments 2-3 exactly: the anterior point alone decides.
  lm.rv_inferior = Eigen::Vector3d(g.r_short_endo * std::cos(2.0944), g.r_short_endo * std::sin(2.0944), 0);
  EXPECT_NEAR((aha_reference_direction(lm, c, a, &beta) - Eigen::Vector3d::UnitX()).norm(), 0.0, 1e-4);
  EXPECT_NEAR(beta, 120.0, 1e-3);
  // At 100 deg the septum's centre (60 deg from phi = 0) sits at 50 deg: phi = 0 turns by -10 deg.
  lm.rv_inferior = Eigen::Vector3d(std::cos(100 * std::numbers::pi / 180), std::sin(100 * std::numbers::pi / 180), 0) * g.r_short_endo;
  const Eigen::Vector3d r = aha_reference_direction(lm, c, a, &beta);
  EXPECT_NEAR(std::atan2(r.y(), r.x()) * 180 / std::numbers::pi, -10.0, 1e-9);
}

TEST(TrackedVolumes, ElementQualityFindsTheInvertedElement) {
  const Mesh m = mesh_at(0, 1);
  Eigen::MatrixX3d x = m.nodes;
  const ElementQuality q0 = element_quality(m, x, m.nodes);
  EXPECT_EQ(q0.inverted, 0);
  EXPECT_GT(q0.min_quality, 0.0);
  // Push one vertex of tetrahedron 0 through its opposite face.
  const Eigen::Vector3d p0 = x.row(m.tets(0, 0)), opp = (x.row(m.tets(0, 1)) + x.row(m.tets(0, 2)) + x.row(m.tets(0, 3))).transpose() / 3;
  x.row(m.tets(0, 0)) = (2 * opp - p0).transpose();
  const ElementQuality q = element_quality(m, x, m.nodes);
  EXPECT_GE(q.inverted, 1);
  EXPECT_LT(q.min_quality, 0.0);
}

}  // namespace
}  // namespace sigmaheart::model::fem
