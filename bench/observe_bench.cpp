// `sigmaheart observe` end to end (config, reading, volumes, checks, CSV and HDF5 written) on
// 30 frames: tracked endocardial surfaces of ~10 000 and ~100 000 triangles (binary legacy .vtk,
// the human-sized ellipsoid contracting and twisting), and a 4D NIfTI label image of
// 256 x 256 x 12 voxels x 30 frames (1.25 x 1.25 x 8 mm). Also the libraries alone (no files):
// the 30 frames' volumes, the 30 frames' sectors.
//   build/bench/observe_bench --benchmark_counters_tabular=true
#include "app/cli.h"
#include "app/io/label_image_io.h"
#include "model/fem/cavity.h"
#include "model/fem/label_volumes.h"
#include "model/fem/mesh.h"
#include "model/fem/tracked_volumes.h"

#include <benchmark/benchmark.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

namespace {

using namespace sigmaheart;
using namespace sigmaheart::model::fem;

constexpr int kFrames = 30;

std::filesystem::path scratch(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() / ("sigmaheart-observe-bench-" + name);
  std::filesystem::create_directories(d);
  return d;
}

// The endocardium of an ellipsoid mesh with about `triangles` faces, and its frames [m].
struct Series {
  Mesh mesh;
  TrackedEndocardium endo;
  std::vector<Eigen::MatrixX3d> frames;
};

Series series(int triangles) {
  EllipsoidMeshOptions mo;
  mo.order = 1;
  mo.n_longitudinal = 3 * static_cast<int>(std::lround(std::sqrt(triangles / 2.0 / 2.25) / 3));
  mo.n_circumferential = 24 * static_cast<int>(std::lround(triangles / 2.0 / mo.n_longitudinal / 24));
  const EllipsoidGeometry g = EllipsoidGeometry::human();
  Series s;
  s.mesh = ellipsoid_mesh(g, mo);
  std::vector<char> endo(s.mesh.face_tag.size());
  for (size_t f = 0; f < endo.size(); ++f) endo[f] = s.mesh.face_tag[f] == kEndocardium;
  Landmarks lm;
  lm.apex = {0, 0, -g.r_long_endo};
  lm.rv_anterior = {g.r_short_endo, 0, 0};
  s.endo = make_tracked_endocardium(s.mesh, endo, s.mesh.nodes, true, lm);
  for (int k = 0; k < kFrames; ++k) {
    const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * k / kFrames), b = 0.2 * w;
    Eigen::MatrixX3d x = s.mesh.nodes;
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      const double a = b * (x(i, 2) + g.r_long_endo) / (g.z_base + g.r_long_endo), px = x(i, 0), py = x(i, 1);
      x(i, 0) = (1 - 0.2 * w) * (std::cos(a) * px - std::sin(a) * py);
      x(i, 1) = (1 - 0.2 * w) * (std::sin(a) * px + std::cos(a) * py);
      x(i, 2) *= 1 - 0.1 * w;
    }
    s.frames.push_back(std::move(x));
  }
  return s;
}

template <class T>
void put_big_endian(std::ostream& o, T v) {
  auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(v);
  if constexpr (std::endian::native == std::endian::little) std::reverse(bytes.begin(), bytes.end());
  o.write(bytes.data(), sizeof(T));
}

// Binary legacy VTK POLYDATA (big-endian, Kitware "VTK File Formats"), coordinates in mm.
void write_vtk(const std::filesystem::path& p, const Eigen::MatrixXi& faces, const Eigen::MatrixX3d& x) {
  std::ofstream o(p, std::ios::binary);
  o << "# vtk DataFile Version 3.0\nlv\nBINARY\nDATASET POLYDATA\nPOINTS " << x.rows() << " double\n";
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    for (int d = 0; d < 3; ++d) put_big_endian(o, x(i, d) * 1e3);
  o << "\nPOLYGONS " << faces.rows() << " " << 4 * faces.rows() << "\n";
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    put_big_endian(o, std::int32_t{3});
    for (int j = 0; j < 3; ++j) put_big_endian(o, static_cast<std::int32_t>(faces(f, j)));
  }
  o << "\n";
}

std::filesystem::path mesh_config(int triangles) {
  static std::map<int, std::filesystem::path> made;
  if (auto it = made.find(triangles); it != made.end()) return it->second;
  const Series s = series(triangles);
  const auto dir = scratch("mesh-" + std::to_string(triangles));
  for (int k = 0; k < kFrames; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "lv_%02d.vtk", k);
    write_vtk(dir / name, s.endo.surface.faces, s.frames[static_cast<size_t>(k)]);
  }
  std::ofstream(dir / "o.yaml") << "name: bench\nobserve:\n  meshes: \"lv_*.vtk\"\n"
                                << "  landmarks: {apex: [0, 0, -45], base: rim, rv_anterior: [25, 0, 0]}\n"
                                << "  timing: {heart_rate: 60 bpm}\n  checks: {jump_fraction: 0.5}\n";
  return made[triangles] = dir / "o.yaml";
}

void run_observe(benchmark::State& st, const std::filesystem::path& config) {
  const auto out = config.parent_path() / "o.csv";
  for (auto _ : st) {
    std::ostringstream o, e;
    const int code = app::run_cli({"observe", config.string(), "-o", out.string()}, o, e);
    if (code != 0) st.SkipWithError(("observe failed: " + e.str()).c_str());
  }
}

void BM_ObserveSurfaceFiles(benchmark::State& st) {
  const int triangles = static_cast<int>(st.range(0));
  const auto config = mesh_config(triangles);
  run_observe(st, config);
  st.counters["frames"] = kFrames;
  st.counters["triangles"] = static_cast<double>(series(triangles).endo.surface.faces.rows());
}
BENCHMARK(BM_ObserveSurfaceFiles)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_VolumesOfThirtyFrames(benchmark::State& st) {
  const Series s = series(static_cast<int>(st.range(0)));
  for (auto _ : st)
    for (const auto& x : s.frames) benchmark::DoNotOptimize(cavity_volumes(s.endo.surface, x, s.endo.labels).cavity);
  st.counters["triangles"] = static_cast<double>(s.endo.surface.faces.rows());
}
BENCHMARK(BM_VolumesOfThirtyFrames)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

// The blood pool of the contracting ellipsoid in a 256 x 256 x 12 grid, 30 frames.
struct Image {
  VoxelGrid grid;
  std::vector<std::vector<std::uint8_t>> frames;
  Image() {
    grid.dims = {256, 256, 12};
    grid.edges = Eigen::Vector3d(1.25e-3, 1.25e-3, 8e-3).asDiagonal();
    grid.origin = {-160e-3, -160e-3, -70e-3};
    for (int t = 0; t < kFrames; ++t) {
      const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * t / kFrames), rs = 25e-3 * (1 - 0.2 * w), rl = 45e-3 * (1 - 0.1 * w);
      std::vector<std::uint8_t> f(static_cast<size_t>(grid.voxels()), 0);
      for (int k = 0; k < 12; ++k)
        for (int j = 0; j < 256; ++j)
          for (int i = 0; i < 256; ++i) {
            const Eigen::Vector3d p = grid.centre(i, j, k);
            if (p.z() <= 13e-3 && p.z() >= -rl && p.x() * p.x() + p.y() * p.y() <= rs * rs * (1 - p.z() * p.z() / (rl * rl)))
              f[static_cast<size_t>(i + 256 * (j + 256 * static_cast<long long>(k)))] = 1;
          }
      frames.push_back(std::move(f));
    }
  }
};

const Image& image() {
  static const Image im;
  return im;
}

void BM_ObserveNifti4D(benchmark::State& st) {
  const auto dir = scratch("nifti");
  static const bool written = [&] {
    app::io::write_label_image(dir / "seg.nii.gz", image().grid, image().frames, 0.033);
    std::ofstream(dir / "o.yaml") << "name: bench\nobserve:\n  images: seg.nii.gz\n  label: 1\n"
                                  << "  landmarks: {apex: [0, 0, -45], base: [[20, 0, 13], [-10, 17.32, 13], [-10, -17.32, 13]],"
                                  << " rv_anterior: [25, 0, 0]}\n  checks: {jump_fraction: 0.5}\n";
    return true;
  }();
  benchmark::DoNotOptimize(written);
  run_observe(st, dir / "o.yaml");
  st.counters["voxels"] = 256.0 * 256 * 12 * kFrames;
}
BENCHMARK(BM_ObserveNifti4D)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_SectorsOfThirtyFrames(benchmark::State& st) {
  const Image& im = image();
  Landmarks lm;
  lm.apex = {0, 0, -45e-3};
  lm.base = {{20e-3, 0, 13e-3}, {-10e-3, 17.32e-3, 13e-3}, {-10e-3, -17.32e-3, 13e-3}};
  lm.rv_anterior = {25e-3, 0, 0};
  const ImageAhaFrame f = image_aha_frame(lm, im.grid);
  for (auto _ : st)
    for (const auto& m : im.frames) benchmark::DoNotOptimize(sector_volumes(im.grid, m.data(), f).cavity);
}
BENCHMARK(BM_SectorsOfThirtyFrames)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
