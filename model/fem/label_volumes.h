// Cavity and AHA regional volumes of a segmented blood pool (a label image frame), by the sector
// reading of docs/models.md s.5 (s.5.1 "From images"): the volume of the segment z is the volume
// of the blood pool whose points lie in z's sector about the long axis, h the height fraction
// along the axis and phi the angle from the anterior RV insertion point. This is what the mesh
// definition V_z = 1/2 int_z (x - c)_perp . n_perp da measures too (the cavity between the axis
// and the segment's patch of endocardium), with two differences a voxel cannot avoid:
//  - Eulerian sectors: without tracking, a blood-pool point is classified where it is now, phi
//    from the fixed landmarks and h either between the landmarks' apex and base plane (fixed
//    heights, the default) or over the frame's own extent of the pool along the axis (the thirds
//    follow the base's descent, but an extent is known to a slice: +-dz/2 at each end). The mesh
//    segments move with the tissue (twist, uneven shortening).
//  - Partial volumes: a voxel counts whole when labelled; the sector boundaries are resolved by
//    sub-samples (SectorOptions::subdivision) and each sub-sample's share goes to its segment.
// Both errors are measured in tests/model/fem/label_volumes_test.cpp and stated in
// docs/models.md s.5.1. No file I/O: app/io/label_image_io reads NIfTI.
#pragma once

#include "model/fem/tracked_volumes.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {

// A voxel grid: the centre of voxel (i, j, k) lies at origin + edges * (i, j, k)^T [m].
struct VoxelGrid {
  std::array<int, 3> dims{};                                // voxels along i, j, k
  Eigen::Matrix3d edges = Eigen::Matrix3d::Identity();      // columns: the voxel's edge vectors [m]
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();         // centre of voxel (0, 0, 0) [m]
  double voxel_volume() const;                              // |det(edges)| [m^3]
  long long voxels() const { return static_cast<long long>(dims[0]) * dims[1] * dims[2]; }
  Eigen::Vector3d centre(int i, int j, int k) const { return origin + edges * Eigen::Vector3d(i, j, k); }
  // Continuous index coordinates of a world point.
  Eigen::Vector3d index_of(const Eigen::Vector3d& x) const;
};

// The AHA frame of an image from its landmarks: centre C = the mean of the base points (required),
// axis a = (C - A)/|C - A|, phi = 0 along aha_reference_direction.
struct ImageAhaFrame {
  Eigen::Vector3d apex, centre, axis, reference;
  double length = 0.0;  // |C - A| [m]
};
// Throws LandmarkError when the base points are missing, a landmark lies outside the grid's field
// of view, or the insertion points do not fit (aha_reference_direction).
ImageAhaFrame image_aha_frame(const Landmarks& landmarks, const VoxelGrid& grid);

enum class SectorHeights { kLandmarks, kExtent };

struct SectorOptions {
  std::array<int, 3> subdivision{2, 2, 8};  // sub-samples per voxel along i, j, k
  SectorHeights heights = SectorHeights::kLandmarks;  // h from the landmarks or the pool's extent
  double apical_cap_fraction = 0.0;         // as AhaOptions: segment 17 takes h below it
  std::string validate() const;
};

struct SectorVolumes {
  double cavity = 0.0;                          // [m^3] labelled voxels x voxel volume
  std::array<double, kAhaSegments> regional{};  // [m^3] segment s at s-1; they sum to `cavity`
  double apex_height = 0.0, base_height = 0.0;  // [m] extent of the pool along the axis, from C
  long long voxels = 0;                         // labelled voxels
};

// Volumes of the voxels where mask != 0 (one byte per voxel, i fastest: i + nx (j + ny k)).
// Throws std::invalid_argument when the mask has the wrong size or is empty.
SectorVolumes sector_volumes(const VoxelGrid& grid, const std::uint8_t* mask, const ImageAhaFrame& frame,
                             const SectorOptions& options = {});

// Distance [m] from p to the nearest voxel centre with mask != 0 (infinity when none).
double distance_to_mask(const VoxelGrid& grid, const std::uint8_t* mask, const Eigen::Vector3d& p);

}  // namespace sigmaheart::model::fem
