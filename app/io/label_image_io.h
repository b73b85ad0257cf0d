// NIfTI label images for `sigmaheart observe` (docs/models.md s.5.1), with nifticlib (Debian
// libnifti2-dev: NIfTI-1 and NIfTI-2, .nii and .nii.gz; compiled in when CMake finds it,
// SIGMAHEART_HAVE_NIFTI). A 4D image (one volume per frame) or a series of 3D images. World
// coordinates from the sform (else the qform, else the voxel sizes), in the header's spatial unit
// (unknown: mm, the NIfTI convention); the frame interval from pixdim[4] in its time unit.
#pragma once

#include "model/fem/label_volumes.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

bool have_nifti();

struct LabelImageSeries {
  model::fem::VoxelGrid grid;                      // [m]
  std::vector<std::vector<std::uint8_t>> masks;    // per frame: 1 where the voxel carries the label
  double frame_interval = 0.0;                     // [s] from the header (0: not given)
  std::vector<std::filesystem::path> files;        // per frame, the file it came from
  std::vector<int> volume_in_file;                 // per frame, its volume index in that file
};

// Reads the frames; `label` is the LV blood-pool value. Throws InputError naming the file (and the
// frame): unreadable, not 3D or 4D, a non-integer label, a frame without the label (with the labels
// it has), files with different grids or units.
LabelImageSeries read_label_images(const std::vector<std::filesystem::path>& files, int label);

// Writes a 4D NIfTI (uint8 labels, frames x grid, sform from the grid in mm, frame interval in s)
// atomically: tests, the benchmark and experiments/from-images make their images with it.
void write_label_image(const std::filesystem::path& path, const model::fem::VoxelGrid& grid,
                       const std::vector<std::vector<std::uint8_t>>& frames, double frame_interval);

}  // namespace sigmaheart::app::io
