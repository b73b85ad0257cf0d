// Volumes of a voxelised blood pool (model/fem/label_volumes.h, docs/models.md s.5.1) against the
// exact values of the human-sized truncated prolate ellipsoid (endocardium 25/45 mm, base plane
// z_b = 13.2 mm), voxelised by voxel centres at the cine resolutions 1.25 x 1.25 x 8 mm and
// 2 x 2 x 10 mm in a short-axis stack (slices normal to the long axis), at 8 placements of the
// grid (sub-voxel shifts and an in-plane rotation).
//
// The error has a known leading part: the last slice whose centre lies below the base plane
// reaches z_top, so the pool holds the slab between z_b and z_top (|z_top - z_b| <= dz/2) of area
// A_b = pi r_s^2 (1 - z_b^2 / r_l^2); and h is measured over the pool's own extent, so the
// sectors' thirds move with it. `predicted` computes both from the exact shape; what remains
// (in-plane pixels, the apex slices, sub-sample quadrature of the sector rays) is bounded here.
#include "model/fem/label_volumes.h"

#include "model/fem/mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace sigmaheart::model::fem {
namespace {

constexpr double kPi = std::numbers::pi;

struct Shape {
  double rs = 25e-3, rl = 45e-3, zb = 5e-3 * 45.0 / 17.0;
  bool inside(const Eigen::Vector3d& p) const {
    return p.z() <= zb && p.z() >= -rl && p.x() * p.x() + p.y() * p.y() <= rs * rs * (1 - p.z() * p.z() / (rl * rl));
  }
  double area(double z) const { return z < -rl || z > zb ? 0.0 : kPi * rs * rs * (1 - z * z / (rl * rl)); }
  // Volume of the pool between heights a < b (the slab above z_b has the base area).
  double between(double a, double b) const {
    auto F = [&](double z) {
      z = std::clamp(z, -rl, zb);
      return kPi * rs * rs * (z - z * z * z / (3 * rl * rl));
    };
    return F(b) - F(a) + area(zb) * std::max(0.0, b - std::max(a, zb));
  }
};

struct Placement {
  VoxelGrid grid;
  std::vector<std::uint8_t> mask;
};

Placement voxelise(const Shape& s, double dx, double dz, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double angle = 2 * kPi * u(rng);
  Placement p;
  const int n = static_cast<int>(std::ceil(2.4 * s.rs / dx)), nz = static_cast<int>(std::ceil((s.rl + s.zb) / dz)) + 3;
  p.grid.dims = {n, n, nz};
  p.grid.edges = Eigen::Matrix3d::Zero();
  p.grid.edges.col(0) << dx * std::cos(angle), dx * std::sin(angle), 0;
  p.grid.edges.col(1) << -dx * std::sin(angle), dx * std::cos(angle), 0;
  p.grid.edges.col(2) << 0, 0, dz;
  const Eigen::Vector3d shift(u(rng) * dx, u(rng) * dx, u(rng) * dz);
  p.grid.origin = -p.grid.edges * Eigen::Vector3d(n / 2.0, n / 2.0, 0) + Eigen::Vector3d(0, 0, -s.rl - dz) + shift;
  p.mask.resize(static_cast<size_t>(p.grid.voxels()));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) p.mask[static_cast<size_t>(i + n * (j + static_cast<long long>(n) * k))] = s.inside(p.grid.centre(i, j, k));
  return p;
}

Landmarks landmarks(const Shape& s) {
  Landmarks lm;
  lm.apex = {0, 0, -s.rl};
  const double r = s.rs * std::sqrt(1 - s.zb * s.zb / (s.rl * s.rl));
  for (double a : {0.3, 0.3 + 2 * kPi / 3, 0.3 + 4 * kPi / 3}) lm.base.push_back({r * std::cos(a), r * std::sin(a), s.zb});
  lm.rv_anterior = {s.rs, 0, 0};
  return lm;
}

struct Errors {
  double cavity = 0, regional = 0;            // largest relative errors against the exact values
  double cavity_bound = 0, regional_bound = 0;  // ... and the bounds the error analysis gives
  double cavity_rest = 0, regional_rest = 0;  // in-plane pixel part (after the slice sampling) / its 4-sigma bound
};

int level_of(double h) { return h < 0 ? 0 : h < 1.0 / 3 ? 3 : h < 2.0 / 3 ? 2 : 1; }  // 1 basal, 2 mid, 3 apical

// The errors of one resolution over 8 placements, in the given height mode. The image volumes are
// compared with (a) the exact values and (b) the slice-sampled values: every voxel of slice k
// holds the exact cross-section A(z_k) and its 8 sub-slices go to the sectors of their heights,
// which leaves only the in-plane pixels. Their error is a sum of +-dx^2/2 per boundary pixel,
// independent between pixels: sigma^2 = sum dx^4/12 over the ~1.3 x 2 pi r / dx pixels on the
// circle (dx^4/48 over the pixels a sector ray crosses, resolved by 2 x 2 sub-samples).
Errors measure(double dx, double dz, SectorHeights heights) {
  const Shape s;
  std::mt19937 rng(43);
  Errors e;
  const double V = s.between(-s.rl, s.zb), Lx = s.zb + s.rl;
  const double slope = 2 * kPi * s.rs * s.rs / s.rl;  // dA/dz at the apex
  for (int trial = 0; trial < 8; ++trial) {
    const Placement p = voxelise(s, dx, dz, rng);
    const ImageAhaFrame f = image_aha_frame(landmarks(s), p.grid);
    SectorOptions so;
    so.heights = heights;
    const SectorVolumes v = sector_volumes(p.grid, p.mask.data(), f, so);
    double sum = 0;
    for (double r : v.regional) sum += r;
    EXPECT_NEAR(sum / v.cavity, 1.0, 1e-12);
    // Heights: h(z) from the landmarks or the pool's extent (C = (0, 0, z_b)).
    const double bottom = heights == SectorHeights::kLandmarks ? -s.rl : s.zb + v.apex_height;
    const double top = heights == SectorHeights::kLandmarks ? s.zb : s.zb + v.base_height;
    auto h = [&](double z) { return (z - bottom) / (top - bottom); };
    double sampled = 0, var = 0;
    std::array<double, 4> level_sampled{}, level_var{};
    for (int k = 0; k < p.grid.dims[2]; ++k) {
      const double zk = p.grid.centre(0, 0, k).z(), A = s.area(zk);
      if (A == 0) continue;
      const double r = std::sqrt(A / kPi), pixels = 1.3 * 2 * kPi * r / dx;
      sampled += A * dz;
      var += pixels * std::pow(dx, 4) / 12 * dz * dz;
      std::array<int, 4> n{};  // sub-slices of this slice per level
      for (int c = 0; c < 8; ++c) ++n[static_cast<size_t>(level_of(h(zk + ((c + 0.5) / 8 - 0.5) * dz)))];
      for (size_t l = 0; l < 4; ++l) {
        level_sampled[l] += A * dz * n[l] / 8;
        // One sector: its share of the circle's pixels and the two rays; the same pixels in every
        // sub-slice of the slice (errors add in amplitude across sub-slices).
        const double share = l == 3 ? 0.25 : 1.0 / 6;
        level_var[l] += std::pow(dz * n[l] / 8, 2) * (share * pixels * std::pow(dx, 4) / 12 + 2 * r / dx * std::pow(dx, 4) / 48);
      }
    }
    e.cavity = std::max(e.cavity, std::abs(v.cavity / V - 1));
    e.cavity_rest = std::max(e.cavity_rest, std::abs(v.cavity - sampled) / (4 * std::sqrt(var)));
    // The slab above the base plane, the apex slice (A ~ slope (z - z_apex)) and the midpoint rule.
    e.cavity_bound = std::max(e.cavity_bound, (s.area(s.zb) * dz / 2 + slope * dz * dz / 8 +
                                               Lx * dz * dz / 24 * 2 * kPi * s.rs * s.rs / (s.rl * s.rl) + 4 * std::sqrt(var)) / V);
    for (int z = 1; z <= 16; ++z) {
      const int l = z <= 6 ? 1 : z <= 12 ? 2 : 3;
      const double h0 = l == 1 ? 2.0 / 3 : l == 2 ? 1.0 / 3 : 0.0, share = l < 3 ? 1.0 / 6 : 1.0 / 4;
      const double exact = share * s.between(-s.rl + h0 * Lx, -s.rl + (h0 + 1.0 / 3) * Lx);
      const double got = v.regional[static_cast<size_t>(z - 1)];
      const double sd = std::sqrt(level_var[static_cast<size_t>(l)]);
      e.regional = std::max(e.regional, std::abs(got / exact - 1));
      e.regional_rest = std::max(e.regional_rest, std::abs(got - share * level_sampled[static_cast<size_t>(l)]) / (4 * sd));
      // The levels' cut planes: where h places them (dz/16 by the sub-slices; with the extent
      // also the extent's error, |top - z_b| + |bottom + r_l| scaled to the plane), the slab or
      // the apex slice of the end segments, the linear change of A across a slice.
      double cut = 0;
      for (double hc : {h0, h0 + 1.0 / 3}) {
        if (hc == 0.0 || hc == 1.0) continue;
        const double zc = -s.rl + hc * Lx, shift = std::abs(bottom + hc * (top - bottom) - zc) + dz / 16;
        cut += s.area(zc) * shift + slope * dz * dz / 8;
      }
      const double ends = l == 1 ? s.area(s.zb) * dz / 2 : l == 3 ? slope * dz * dz / 8 : 0.0;
      e.regional_bound = std::max(e.regional_bound, (share * (cut + ends) + 4 * sd) / exact);
    }
  }
  return e;
}

// Stated in docs/models.md s.5.1 (the table of image errors).
TEST(LabelVolumes, CineResolutionErrorsStayWithinTheirAnalysis) {
  for (const auto mode : {SectorHeights::kLandmarks, SectorHeights::kExtent})
    for (const auto& [dx, dz] : {std::pair{1.25e-3, 8e-3}, std::pair{2e-3, 10e-3}}) {
      const Errors e = measure(dx, dz, mode);
      std::printf("%s heights, voxels %.2f x %.2f x %.0f mm: V_lv error <= %.2f %% (bound %.2f %%); regional error <= %.1f %% "
                  "(bound %.1f %%); in-plane rest <= %.2f and %.2f of its 4-sigma bound\n",
                  mode == SectorHeights::kLandmarks ? "landmark" : "extent", dx * 1e3, dx * 1e3, dz * 1e3, 100 * e.cavity,
                  100 * e.cavity_bound, 100 * e.regional, 100 * e.regional_bound, e.cavity_rest, e.regional_rest);
      EXPECT_LE(e.cavity, e.cavity_bound);
      EXPECT_LE(e.regional, e.regional_bound);
      EXPECT_LT(e.cavity_rest, 1.0);
      EXPECT_LT(e.regional_rest, 1.0);
    }
}

TEST(LabelVolumes, LandmarksOutsideTheImageAreNamed) {
  const Shape s;
  std::mt19937 rng(1);
  const Placement p = voxelise(s, 2e-3, 10e-3, rng);
  Landmarks lm = landmarks(s);
  lm.apex *= 1000;
  try {
    image_aha_frame(lm, p.grid);
    ADD_FAILURE() << "accepted";
  } catch (const LandmarkError& e) {
    EXPECT_EQ(e.landmark(), "apex");
  }
  lm = landmarks(s);
  lm.base.clear();
  EXPECT_THROW(image_aha_frame(lm, p.grid), LandmarkError);
}

}  // namespace
}  // namespace sigmaheart::model::fem
