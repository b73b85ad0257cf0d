// The image formats of `sigmaheart observe` when the build found no library for them
// (app/CMakeLists.txt): the readers exit 2 and say what to install.
#include "app/errors.h"
#include "app/io/label_image_io.h"
#include "app/io/tracked_mesh_io.h"

namespace sigmaheart::app::io {
namespace {

// The input error of a reader whose library was missing at configure time, at `file` (the first of
// `files` when there are several).
[[maybe_unused, noreturn]] void unavailable(const std::filesystem::path& file, const char* library, const char* package) {
  throw InputError(file.string(), 0, 0,
                   std::string("built without ") + library + ": install " + package +
                       " and rebuild (scripts/setup installs it)");
}
[[maybe_unused]] std::filesystem::path first(const std::vector<std::filesystem::path>& files) {
  return files.empty() ? std::filesystem::path("observe") : files.front();
}

}  // namespace

#ifndef SIGMAHEART_HAVE_VTK
bool have_vtk() { return false; }
PvdSeries read_pvd_series(const std::filesystem::path& pvd) { unavailable(pvd, "VTK", "libvtk9-dev"); }
TrackedMeshSeries read_tracked_meshes(const std::vector<std::filesystem::path>& files, const TrackedMeshReadOptions&) {
  unavailable(first(files), "VTK", "libvtk9-dev");
}
#endif

#ifndef SIGMAHEART_HAVE_NIFTI
bool have_nifti() { return false; }
LabelImageSeries read_label_images(const std::vector<std::filesystem::path>& files, int) {
  unavailable(first(files), "nifticlib", "libnifti2-dev");
}
void write_label_image(const std::filesystem::path& path, const model::fem::VoxelGrid&,
                       const std::vector<std::vector<std::uint8_t>>&, double) {
  unavailable(path, "nifticlib", "libnifti2-dev");
}
#endif

}  // namespace sigmaheart::app::io
