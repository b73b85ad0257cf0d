#include "app/io/label_image_io.h"

#include "app/errors.h"
#include "app/io/atomic_file.h"

#include <nifti2_io.h>

#include <cmath>
#include <memory>
#include <set>
#include <sstream>

namespace sigmaheart::app::io {

namespace {

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
  throw InputError(file.string(), 0, 0, what);
}

struct NimFree {
  void operator()(nifti_image* p) const { nifti_image_free(p); }
};
using Nim = std::unique_ptr<nifti_image, NimFree>;

double space_unit(int code) {
  switch (code) {
    case NIFTI_UNITS_METER: return 1.0;
    case NIFTI_UNITS_MICRON: return 1e-6;
    default: return 1e-3;  // NIFTI_UNITS_MM, or unknown: mm by convention
  }
}

double time_unit(int code) {
  switch (code) {
    case NIFTI_UNITS_SEC: return 1.0;
    case NIFTI_UNITS_MSEC: return 1e-3;
    case NIFTI_UNITS_USEC: return 1e-6;
    default: return 0.0;  // unknown: the interval is not given
  }
}

// Voxel value n as a double (after the header's scaling when it has one).
double voxel(const nifti_image* nim, long long n) {
  const void* d = nim->data;
  double v = 0;
  switch (nim->datatype) {
    case NIFTI_TYPE_UINT8: v = static_cast<const std::uint8_t*>(d)[n]; break;
    case NIFTI_TYPE_INT8: v = static_cast<const std::int8_t*>(d)[n]; break;
    case NIFTI_TYPE_INT16: v = static_cast<const std::int16_t*>(d)[n]; break;
    case NIFTI_TYPE_UINT16: v = static_cast<const std::uint16_t*>(d)[n]; break;
    case NIFTI_TYPE_INT32: v = static_cast<const std::int32_t*>(d)[n]; break;
    case NIFTI_TYPE_UINT32: v = static_cast<const std::uint32_t*>(d)[n]; break;
    case NIFTI_TYPE_INT64: v = static_cast<double>(static_cast<const std::int64_t*>(d)[n]); break;
    case NIFTI_TYPE_FLOAT32: v = static_cast<const float*>(d)[n]; break;
    case NIFTI_TYPE_FLOAT64: v = static_cast<const double*>(d)[n]; break;
    default: return std::nan("");
  }
  if (nim->scl_slope != 0.0 && std::isfinite(nim->scl_slope)) v = v * nim->scl_slope + nim->scl_inter;
  return v;
}

model::fem::VoxelGrid grid_of(const nifti_image* nim) {
  model::fem::VoxelGrid g;
  g.dims = {static_cast<int>(nim->nx), static_cast<int>(nim->ny), static_cast<int>(nim->nz)};
  const double u = space_unit(nim->xyz_units);
  const nifti_dmat44& m = nim->sform_code > 0 ? nim->sto_xyz : nim->qto_xyz;
  if (nim->sform_code > 0 || nim->qform_code > 0) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) g.edges(r, c) = m.m[r][c] * u;
      g.origin(r) = m.m[r][3] * u;
    }
  } else {
    g.edges = Eigen::Vector3d(nim->dx, nim->dy, nim->dz).asDiagonal();
    g.edges *= u;
  }
  return g;
}

}  // namespace

bool have_nifti() { return true; }

LabelImageSeries read_label_images(const std::vector<std::filesystem::path>& files, int label) {
  if (files.empty()) throw InputError("observe", 0, 0, "no image files");
  nifti_set_debug_level(0);
  LabelImageSeries s;
  for (size_t f = 0; f < files.size(); ++f) {
    const auto& file = files[f];
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) fail(file, "cannot open the file (expected a NIfTI image, .nii or .nii.gz)");
    Nim nim(nifti_image_read(file.string().c_str(), 1));
    if (!nim || !nim->data) fail(file, "not a readable NIfTI image (expected .nii or .nii.gz, NIfTI-1 or -2)");
    for (int d = 5; d <= 7; ++d)
      if (nim->dim[0] >= d && nim->dim[d] > 1) fail(file, "has " + std::to_string(nim->dim[0]) + " dimensions; expected a 3D or 4D label image");
    if (std::isnan(voxel(nim.get(), 0))) fail(file, "voxel type " + std::to_string(nim->datatype) + " is not a label type (integers or floats)");
    const model::fem::VoxelGrid g = grid_of(nim.get());
    if (f == 0) {
      s.grid = g;
      const double tu = time_unit(nim->time_units);
      if (nim->nt > 1 && tu > 0 && nim->dt > 0) s.frame_interval = nim->dt * tu;
    } else if (g.dims != s.grid.dims || !g.edges.isApprox(s.grid.edges, 1e-6) || (g.origin - s.grid.origin).norm() > 1e-6 * g.edges.norm()) {
      std::ostringstream m;
      m << "its grid (" << g.dims[0] << " x " << g.dims[1] << " x " << g.dims[2] << ", voxel " << g.edges.colwise().norm() * 1e3
        << " mm) differs from " << files[0].string() << "'s: every frame needs the same grid and units";
      fail(file, m.str());
    }
    const long long nvox = g.voxels();
    const long long volumes = nim->nvox / nvox;
    for (long long t = 0; t < volumes; ++t) {
      std::vector<std::uint8_t> mask(static_cast<size_t>(nvox), 0);
      long long count = 0;
      std::set<long long> present;
      for (long long n = 0; n < nvox; ++n) {
        const double v = voxel(nim.get(), t * nvox + n);
        if (v != std::round(v)) fail(file, "voxel " + std::to_string(n) + " of volume " + std::to_string(t) + " is " + std::to_string(v) + ": not an integer label");
        if (static_cast<long long>(v) == label) {
          mask[static_cast<size_t>(n)] = 1;
          ++count;
        } else if (present.size() < 12) {
          present.insert(static_cast<long long>(v));
        }
      }
      if (count == 0) {
        std::string labels;
        for (long long p : present) labels += (labels.empty() ? "" : ", ") + std::to_string(p);
        fail(file, "frame " + std::to_string(s.masks.size()) + " (volume " + std::to_string(t) + " of this file): no voxel carries the LV label " +
                       std::to_string(label) + " (labels present: " + labels + ")");
      }
      s.masks.push_back(std::move(mask));
      s.files.push_back(file);
      s.volume_in_file.push_back(static_cast<int>(t));
    }
  }
  return s;
}

void write_label_image(const std::filesystem::path& path, const model::fem::VoxelGrid& grid,
                       const std::vector<std::vector<std::uint8_t>>& frames, double frame_interval) {
  const int64_t dims[8] = {4, grid.dims[0], grid.dims[1], grid.dims[2], static_cast<int64_t>(frames.size()), 1, 1, 1};
  Nim nim(nifti_make_new_nim(dims, NIFTI_TYPE_UINT8, 1));
  if (!nim) throw RunFailure(path.string() + ": cannot make a NIfTI image");
  const long long nvox = grid.voxels();
  auto* data = static_cast<std::uint8_t*>(nim->data);
  for (size_t t = 0; t < frames.size(); ++t) {
    if (static_cast<long long>(frames[t].size()) != nvox) throw std::invalid_argument("write_label_image: a frame of the wrong size");
    std::copy(frames[t].begin(), frames[t].end(), data + static_cast<long long>(t) * nvox);
  }
  const Eigen::Vector3d spacing = grid.edges.colwise().norm();
  nim->dx = nim->pixdim[1] = spacing(0) * 1e3;
  nim->dy = nim->pixdim[2] = spacing(1) * 1e3;
  nim->dz = nim->pixdim[3] = spacing(2) * 1e3;
  nim->dt = nim->pixdim[4] = frame_interval;
  nim->xyz_units = NIFTI_UNITS_MM;
  nim->time_units = NIFTI_UNITS_SEC;
  nim->qform_code = 0;
  nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) nim->sto_xyz.m[r][c] = r == 3 ? (c == 3 ? 1.0 : 0.0) : (c == 3 ? grid.origin(r) : grid.edges(r, c)) * 1e3;
  nim->sto_ijk = nifti_dmat44_inverse(nim->sto_xyz);
  AtomicFile out(path);
  const std::string name = path.filename().string();
  const std::string ext = name.size() > 7 && name.ends_with(".nii.gz") ? ".nii.gz" : ".nii";
  const std::string tmp = out.temp_path().string() + ext;
  if (nifti_set_filenames(nim.get(), tmp.c_str(), 0, 1) != 0) throw RunFailure(path.string() + ": bad NIfTI file name");
  nifti_image_write(nim.get());
  std::error_code ec;
  std::filesystem::rename(tmp, out.temp_path(), ec);
  if (ec) throw RunFailure(path.string() + ": cannot write: " + ec.message());
  out.commit();
}

}  // namespace sigmaheart::app::io
