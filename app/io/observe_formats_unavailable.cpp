// The image formats of `sigmaheart observe` when the build found no library for them
// (app/CMakeLists.txt): the readers exit 2 and say what to install.
#include "app/errors.h"
#include "app/io/label_image_io.h"
#include "app/io/tracked_mesh_io.h"

namespace sigmaheart::app::io {

#ifndef SIGMAHEART_HAVE_VTK
namespace {
[[noreturn]] void no_vtk(const std::filesystem::path& file) {
  throw InputError(file.string(), 0, 0, "built without VTK: install libvtk9-dev and rebuild (scripts/setup installs it)");
}
}  // namespace
bool have_vtk() { return false; }
PvdSeries read_pvd_series(const std::filesystem::path& pvd) { no_vtk(pvd); }
TrackedMeshSeries read_tracked_meshes(const std::vector<std::filesystem::path>& files, const TrackedMeshReadOptions&) {
  no_vtk(files.empty() ? std::filesystem::path("observe") : files.front());
}
#endif

#ifndef SIGMAHEART_HAVE_NIFTI
namespace {
[[noreturn]] void no_nifti(const std::filesystem::path& file) {
  throw InputError(file.string(), 0, 0, "built without nifticlib: install libnifti2-dev and rebuild (scripts/setup installs it)");
}
}  // namespace
bool have_nifti() { return false; }
LabelImageSeries read_label_images(const std::vector<std::filesystem::path>& files, int) {
  no_nifti(files.empty() ? std::filesystem::path("observe") : files.front());
}
void write_label_image(const std::filesystem::path& path, const model::fem::VoxelGrid&,
                       const std::vector<std::vector<std::uint8_t>>&, double) {
  no_nifti(path);
}
#endif

}  // namespace sigmaheart::app::io
