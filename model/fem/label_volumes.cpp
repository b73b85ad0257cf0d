#include "model/fem/label_volumes.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

namespace sigmaheart::model::fem {

double VoxelGrid::voxel_volume() const { return std::abs(edges.determinant()); }

Eigen::Vector3d VoxelGrid::index_of(const Eigen::Vector3d& x) const { return edges.partialPivLu().solve(x - origin); }

ImageAhaFrame image_aha_frame(const Landmarks& lm, const VoxelGrid& grid) {
  if (lm.base.size() < 3)
    throw LandmarkError("base", "an image needs landmarks.base: at least 3 points on the base plane (the mitral annulus)");
  auto inside = [&](const Eigen::Vector3d& p, const std::string& name) {
    const Eigen::Vector3d ijk = grid.index_of(p);
    for (int d = 0; d < 3; ++d)
      if (!(ijk(d) >= -0.5 && ijk(d) <= grid.dims[static_cast<size_t>(d)] - 0.5)) {
        std::ostringstream s;
        s.precision(4);
        s << name << " lies outside the image (voxel coordinates " << ijk.transpose() << ", the image has "
          << grid.dims[0] << " x " << grid.dims[1] << " x " << grid.dims[2] << "): other units or coordinates?";
        throw LandmarkError(name, s.str());
      }
  };
  inside(lm.apex, "apex");
  inside(lm.rv_anterior, "rv_anterior");
  if (lm.rv_inferior) inside(*lm.rv_inferior, "rv_inferior");
  ImageAhaFrame f;
  f.centre.setZero();
  for (size_t i = 0; i < lm.base.size(); ++i) {
    inside(lm.base[i], "base[" + std::to_string(i) + "]");
    f.centre += lm.base[i];
  }
  f.centre /= static_cast<double>(lm.base.size());
  f.apex = lm.apex;
  f.length = (f.centre - f.apex).norm();
  if (!(f.length > 0)) throw LandmarkError("apex", "apex coincides with the centre of the base points");
  f.axis = (f.centre - f.apex) / f.length;
  f.reference = aha_reference_direction(lm, f.centre, f.axis);
  return f;
}

std::string SectorOptions::validate() const {
  for (int s : subdivision)
    if (s < 1 || s > 64) return "subdivision must be 1..64 sub-samples per voxel edge";
  if (apical_cap_fraction < 0 || apical_cap_fraction >= 1.0 / 3.0) return "apical_cap_fraction must be in [0, 1/3)";
  return {};
}

SectorVolumes sector_volumes(const VoxelGrid& g, const std::uint8_t* mask, const ImageAhaFrame& f, const SectorOptions& o) {
  if (auto m = o.validate(); !m.empty()) throw std::invalid_argument("SectorOptions: " + m);
  const int nx = g.dims[0], ny = g.dims[1];
  // Sub-sample offsets inside a voxel, in world coordinates relative to its centre.
  std::vector<Eigen::Vector3d> sub;
  const auto& n = o.subdivision;
  for (int c = 0; c < n[2]; ++c)
    for (int b = 0; b < n[1]; ++b)
      for (int a = 0; a < n[0]; ++a)
        sub.push_back(g.edges * Eigen::Vector3d((a + 0.5) / n[0] - 0.5, (b + 0.5) / n[1] - 0.5, (c + 0.5) / n[2] - 0.5));
  // Axial heights and the two in-plane coordinates (relative to C) of each sub-sample are affine
  // in (i, j, k): per-voxel values plus per-sub-sample offsets.
  const Eigen::Vector3d e1 = f.reference, e2 = f.axis.cross(f.reference);
  std::vector<Eigen::Vector3d> sub_local;  // (s, u, v) offsets
  for (const auto& d : sub) sub_local.emplace_back(d.dot(f.axis), d.dot(e1), d.dot(e2));
  std::vector<long long> pool;
  for (long long idx = 0; idx < g.voxels(); ++idx)
    if (mask[idx]) pool.push_back(idx);
  if (pool.empty()) throw std::invalid_argument("the blood-pool label is empty");
  auto local = [&](long long idx) {
    const int i = static_cast<int>(idx % nx), j = static_cast<int>((idx / nx) % ny), k = static_cast<int>(idx / (static_cast<long long>(nx) * ny));
    const Eigen::Vector3d d = g.centre(i, j, k) - f.centre;
    return Eigen::Vector3d(d.dot(f.axis), d.dot(e1), d.dot(e2));
  };
  SectorVolumes out;
  out.voxels = static_cast<long long>(pool.size());
  double smin = std::numeric_limits<double>::infinity(), smax = -smin;
  // The extent reaches the voxels' faces (their corners along the axis): the end of the pool lies
  // anywhere in its last voxel, so the face is the unbiased estimate.
  double dsmin = smin, dsmax = -smin;
  for (int c = 0; c < 8; ++c) {
    const double d = (g.edges * Eigen::Vector3d(c & 1 ? 0.5 : -0.5, c & 2 ? 0.5 : -0.5, c & 4 ? 0.5 : -0.5)).dot(f.axis);
    dsmin = std::min(dsmin, d);
    dsmax = std::max(dsmax, d);
  }
  for (long long idx : pool) {
    const double s = local(idx)(0);
    smin = std::min(smin, s + dsmin);
    smax = std::max(smax, s + dsmax);
  }
  out.apex_height = smin;
  out.base_height = smax;
  if (o.heights == SectorHeights::kLandmarks) {
    smin = -f.length;  // the apex landmark; the base centre C is at 0
    smax = 0.0;
  }
  const double L = smax - smin;
  const double w = g.voxel_volume() / static_cast<double>(sub.size());
  constexpr double kDeg = 180.0 / std::numbers::pi;
  for (long long idx : pool) {
    const Eigen::Vector3d p = local(idx);
    for (const auto& d : sub_local) {
      const Eigen::Vector3d q = p + d;
      const int seg = aha_segment((q(0) - smin) / L, std::atan2(q(2), q(1)) * kDeg, o.apical_cap_fraction);
      out.regional[static_cast<size_t>(seg - 1)] += w;
    }
  }
  out.cavity = static_cast<double>(pool.size()) * g.voxel_volume();
  return out;
}

double distance_to_mask(const VoxelGrid& g, const std::uint8_t* mask, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  const int nx = g.dims[0], ny = g.dims[1];
  for (long long idx = 0; idx < g.voxels(); ++idx) {
    if (!mask[idx]) continue;
    const int i = static_cast<int>(idx % nx), j = static_cast<int>((idx / nx) % ny), k = static_cast<int>(idx / (static_cast<long long>(nx) * ny));
    best = std::min(best, (g.centre(i, j, k) - p).norm());
  }
  return best;
}

}  // namespace sigmaheart::model::fem
