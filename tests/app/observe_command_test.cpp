// `sigmaheart observe` (app/commands/observe.cpp, docs/models.md s.5.1): surfaces in every mesh
// format give the library's volumes (the lv-3d round trip is in simulate_vtu_test.cpp, which runs
// the beat anyway); a 4D label image gives the sector volumes; bad input exits 2
// at the file (and frame) or the config key with nothing written, a tracking failure exits 1 with
// everything written.
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/io/label_image_io.h"
#include "app/io/observation_file.h"
#include "model/fem/cavity.h"
#include "model/fem/label_volumes.h"
#include "model/fem/mesh.h"
#include "model/fem/tracked_volumes.h"
#include "model/fem/vtk_output.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>

namespace sigmaheart::testing {
namespace {

using namespace model::fem;

CliRun cli3d(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, app::blackbox::cli_models());
  return {code, out.str(), err.str()};
}

bool have_formats() {
#if defined(SIGMAHEART_HAVE_VTK) && defined(SIGMAHEART_HAVE_NIFTI)
  return true;
#else
  return false;
#endif
}
#define REQUIRE_FORMATS() \
  if (!have_formats()) GTEST_SKIP() << "built without VTK or nifticlib (libvtk9-dev, libnifti2-dev)"

// Column `name` of an observation CSV, in the file's display unit (mL).
std::vector<double> column(const std::filesystem::path& csv, const std::string& name) {
  const app::io::ObservationCurves c = app::io::read_observation_csv(csv);
  const Eigen::VectorXd v = c.trajectory.channel(name) * 1e6;
  return {v.data(), v.data() + v.size()};
}

// ---------------------------------------------------------------------------------------------
// A deforming ellipsoid's endocardium in every surface format.

struct Surface {
  Eigen::MatrixXi faces;                 // oriented endocardial triangles
  std::vector<Eigen::MatrixX3d> frames;  // positions per frame [m]
  std::vector<double> V;                 // library volumes [m^3] per frame
};

Surface ellipsoid_surface(int frames) {
  EllipsoidMeshOptions mo;
  mo.n_longitudinal = 6;
  mo.n_circumferential = 24;
  mo.order = 1;
  const EllipsoidGeometry g = EllipsoidGeometry::human();
  const Mesh m = ellipsoid_mesh(g, mo);
  Surface s;
  std::vector<char> endo(m.face_tag.size());
  for (size_t f = 0; f < endo.size(); ++f) endo[f] = m.face_tag[f] == kEndocardium;
  Landmarks lm;
  lm.apex = {0, 0, -g.r_long_endo};
  lm.rv_anterior = {g.r_short_endo, 0, 0};
  const TrackedEndocardium t = make_tracked_endocardium(m, endo, m.nodes, true, lm);
  s.faces = t.surface.faces;
  for (int k = 0; k < frames; ++k) {
    const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * k / frames), sr = 1 - 0.2 * w, sl = 1 - 0.1 * w;
    Eigen::MatrixX3d x = m.nodes;
    x.col(0) *= sr;
    x.col(1) *= sr;
    x.col(2) *= sl;
    s.frames.push_back(x);
    s.V.push_back(cavity_volumes(t.surface, x, t.labels).cavity);
  }
  return s;
}

// The surface's frame k in a format, coordinates in mm (the configs' default unit).
void write_surface(const std::filesystem::path& p, const Surface& s, int k, bool damage = false) {
  const Eigen::MatrixX3d x = s.frames[static_cast<size_t>(k)] * 1e3;
  Eigen::MatrixXi F = s.faces;
  if (damage) F(0, 2) = F(5, 2);  // a connectivity change
  std::ofstream o(p);
  o.precision(17);
  const std::string ext = p.extension().string();
  if (ext == ".obj") {
    for (Eigen::Index i = 0; i < x.rows(); ++i) o << "v " << x(i, 0) << " " << x(i, 1) << " " << x(i, 2) << "\n";
    for (Eigen::Index f = 0; f < F.rows(); ++f) o << "f " << F(f, 0) + 1 << " " << F(f, 1) + 1 << " " << F(f, 2) + 1 << "\n";
  } else if (ext == ".stl") {
    o << "solid lv\n";
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      o << " facet normal 0 0 0\n  outer loop\n";
      for (int j = 0; j < 3; ++j) o << "   vertex " << x(F(f, j), 0) << " " << x(F(f, j), 1) << " " << x(F(f, j), 2) << "\n";
      o << "  endloop\n endfacet\n";
    }
    o << "endsolid lv\n";
  } else if (ext == ".vtk") {
    o << "# vtk DataFile Version 3.0\nlv\nASCII\nDATASET POLYDATA\nPOINTS " << x.rows() << " double\n";
    for (Eigen::Index i = 0; i < x.rows(); ++i) o << x(i, 0) << " " << x(i, 1) << " " << x(i, 2) << "\n";
    o << "POLYGONS " << F.rows() << " " << 4 * F.rows() << "\n";
    for (Eigen::Index f = 0; f < F.rows(); ++f) o << "3 " << F(f, 0) << " " << F(f, 1) << " " << F(f, 2) << "\n";
  } else {  // .vtp
    o << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n<PolyData>\n"
      << "<Piece NumberOfPoints=\"" << x.rows() << "\" NumberOfPolys=\"" << F.rows() << "\">\n<Points>\n"
      << "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
    for (Eigen::Index i = 0; i < x.rows(); ++i) o << x(i, 0) << " " << x(i, 1) << " " << x(i, 2) << "\n";
    o << "</DataArray>\n</Points>\n<Polys>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (Eigen::Index f = 0; f < F.rows(); ++f) o << F(f, 0) << " " << F(f, 1) << " " << F(f, 2) << "\n";
    o << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (Eigen::Index f = 0; f < F.rows(); ++f) o << 3 * (f + 1) << "\n";
    o << "</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n";
  }
}

constexpr const char* kLandmarksMm = "  landmarks: {apex: [0, 0, -45], base: rim, rv_anterior: [25, 0, 0]}\n";

std::string surface_config(const std::string& files, const std::string& extra = "") {
  return "name: surface\nobserve:\n  meshes: " + files + "\n" + kLandmarksMm + "  timing: {heart_rate: 75 bpm}\n" + extra;
}

TEST(Observe, EverySurfaceFormatGivesTheLibrarysVolumes) {
  REQUIRE_FORMATS();
  const Surface s = ellipsoid_surface(6);
  for (const std::string ext : {".vtp", ".vtk", ".stl", ".obj"}) {
    const auto dir = scratch_dir();
    for (int k = 0; k < 6; ++k) write_surface(dir / ("lv_" + std::to_string(k) + ext), s, k);
    write_file(dir / "o.yaml", surface_config("\"lv_*" + ext + "\""));
    const CliRun r = cli3d({"observe", (dir / "o.yaml").string(), "-o", (dir / "o.csv").string()});
    ASSERT_EQ(r.code, 0) << ext << ": " << r.err;
    const std::vector<double> V = column(dir / "o.csv", "V_lv");
    ASSERT_EQ(V.size(), 6u);
    // STL stores single-precision coordinates, and VTK reads OBJ's in single precision.
    const double tolerance = ext == ".stl" || ext == ".obj" ? 1e-6 : 1e-12;
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(V[static_cast<size_t>(k)] / (s.V[static_cast<size_t>(k)] * 1e6), 1.0, tolerance) << ext << " frame " << k;
    const app::io::ObservationCurves c = app::io::read_observation_csv(dir / "o.csv");
    EXPECT_NEAR(c.trajectory.times(1), 0.8 / 6, 1e-12);  // 75 bpm over 6 frames
  }
}

// A .pvd series named by a config given by a relative path: the .pvd is found beside the config,
// its files beside the .pvd, its times kept; `validate` checks an observe config without simulator.
TEST(Observe, ASeriesIsFoundRelativeToTheConfigAndValidated) {
  REQUIRE_FORMATS();
  const Surface s = ellipsoid_surface(4);
  const auto dir = scratch_dir();
  std::filesystem::create_directories(dir / "frames");
  std::string pvd = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
  for (int k = 0; k < 4; ++k) {
    write_surface(dir / "frames" / ("lv_" + std::to_string(k) + ".vtp"), s, k);
    pvd += "<DataSet timestep=\"" + std::to_string(0.2 * k) + "\" group=\"\" part=\"0\" file=\"lv_" + std::to_string(k) + ".vtp\"/>\n";
  }
  write_file(dir / "frames" / "lv.pvd", pvd + "</Collection>\n</VTKFile>\n");
  write_file(dir / "o.yaml", "name: series\nobserve:\n  meshes: frames/lv.pvd\n" + std::string(kLandmarksMm));
  const auto config = std::filesystem::relative(dir / "o.yaml");
  ASSERT_TRUE(config.is_relative());
  const CliRun v = cli3d({"validate", config.string()});
  EXPECT_EQ(v.code, 0) << v.err;
  EXPECT_NE(v.out.find("ok (observe"), std::string::npos) << v.out;
  const CliRun r = cli3d({"observe", config.string(), "-o", (dir / "o.csv").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const app::io::ObservationCurves c = app::io::read_observation_csv(dir / "o.csv");
  EXPECT_NEAR(c.trajectory.times(3), 0.6, 1e-12);
  EXPECT_NEAR(c.trajectory.channel("V_lv")(2) / s.V[2], 1.0, 1e-12);
}

// A pressure trace is merged at the frame times; the ECG-trigger offset shifts the times.
TEST(Observe, APressureTraceIsMergedAndTheTriggerOffsetShiftsTheTimes) {
  REQUIRE_FORMATS();
  const Surface s = ellipsoid_surface(6);
  const auto dir = scratch_dir();
  for (int k = 0; k < 6; ++k) write_surface(dir / ("lv_" + std::to_string(k) + ".obj"), s, k);
  write_file(dir / "p.csv", "time [ms], P_lv [mmHg]\n0, 10\n400, 130\n900, 10\n");
  write_file(dir / "o.yaml", "name: surface\nobserve:\n  meshes: \"lv_*.obj\"\n" + std::string(kLandmarksMm) +
                                 "  timing: {heart_rate: 75 bpm, trigger_offset: 20 ms}\n  pressure: {file: p.csv}\n");
  const CliRun r = cli3d({"observe", (dir / "o.yaml").string(), "-o", (dir / "o.csv").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const app::io::ObservationCurves c = app::io::read_observation_csv(dir / "o.csv");
  EXPECT_NEAR(c.trajectory.times(0), 0.020, 1e-12);
  const Eigen::VectorXd P = c.trajectory.channel("P_lv") / 133.322;  // model/units.h
  EXPECT_NEAR(P(0), 10 + 120 * 20.0 / 400, 1e-6);
  EXPECT_NE(read_file(dir / "o.csv").find("trigger offset 20 ms"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Label images: a 4D NIfTI of a shrinking ellipsoidal blood pool.

TEST(Observe, ALabelImageGivesTheSectorVolumes) {
  REQUIRE_FORMATS();
  const auto dir = scratch_dir();
  VoxelGrid g;
  g.dims = {40, 40, 9};
  g.edges = Eigen::Vector3d(1.5e-3, 1.5e-3, 8e-3).asDiagonal();
  g.origin = {-29.25e-3, -29.25e-3, -52e-3};
  std::vector<std::vector<std::uint8_t>> frames;
  for (int t = 0; t < 4; ++t) {
    const double sr = 1 - 0.1 * t;
    std::vector<std::uint8_t> f(static_cast<size_t>(g.voxels()), 0);
    for (int k = 0; k < 9; ++k)
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
          const Eigen::Vector3d p = g.centre(i, j, k);
          const double rs = 25e-3 * sr, rl = 45e-3;
          if (p.z() <= 13e-3 && p.z() >= -rl && p.x() * p.x() + p.y() * p.y() <= rs * rs * (1 - p.z() * p.z() / (rl * rl)))
            f[static_cast<size_t>(i + 40 * (j + 40 * k))] = 3;
        }
    frames.push_back(f);
  }
  app::io::write_label_image(dir / "seg.nii.gz", g, frames, 0.05);
  const std::string cfg =
      "name: image\nobserve:\n  images: seg.nii.gz\n  label: 3\n"
      "  landmarks: {apex: [0, 0, -45], base: [[20, 0, 13], [-10, 17.32, 13], [-10, -17.32, 13]], rv_anterior: [25, 0, 0]}\n";
  write_file(dir / "o.yaml", cfg);
  const CliRun r = cli3d({"observe", (dir / "o.yaml").string(), "-o", (dir / "o.csv").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const app::io::ObservationCurves c = app::io::read_observation_csv(dir / "o.csv");
  EXPECT_NEAR(c.trajectory.times(1), 0.05, 1e-9);  // the header's frame interval (NIfTI-1: float32)
  Landmarks lm;
  lm.apex = {0, 0, -45e-3};
  lm.base = {{20e-3, 0, 13e-3}, {-10e-3, 17.32e-3, 13e-3}, {-10e-3, -17.32e-3, 13e-3}};
  lm.rv_anterior = {25e-3, 0, 0};
  const ImageAhaFrame f = image_aha_frame(lm, g);
  for (int t = 0; t < 4; ++t) {
    const SectorVolumes v = sector_volumes(g, frames[static_cast<size_t>(t)].data(), f);  // label 3 != 0: the pool
    EXPECT_NEAR(c.trajectory.channel("V_lv")(t) / v.cavity, 1.0, 1e-12);
    EXPECT_NEAR(c.trajectory.channel("V_seg08")(t) / v.regional[7], 1.0, 1e-12);
  }
  // The wrong label: exit 2 at the file and frame, with the labels the image has.
  write_file(dir / "bad.yaml", cfg.substr(0, cfg.find("label: 3")) + "label: 1" + cfg.substr(cfg.find("label: 3") + 8));
  const CliRun b = cli3d({"observe", (dir / "bad.yaml").string(), "-o", (dir / "bad.csv").string()});
  EXPECT_EQ(b.code, 2);
  EXPECT_NE(b.err.find("seg.nii.gz"), std::string::npos) << b.err;
  EXPECT_NE(b.err.find("frame 0"), std::string::npos) << b.err;
  EXPECT_NE(b.err.find("no voxel carries the LV label 1 (labels present: 0, 3)"), std::string::npos) << b.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.csv"));
}

// ---------------------------------------------------------------------------------------------
// Bad input: exit 2 at the file and frame (or the config key), nothing written.

struct BadCase {
  std::string what;
  std::function<void(const std::filesystem::path&, const Surface&)> make;  // files + o.yaml in dir
  std::vector<std::string> words;                                          // in stderr
};

TEST(Observe, BadInputIsExitTwoAtTheFileAndFrameWithNothingWritten) {
  REQUIRE_FORMATS();
  const Surface s = ellipsoid_surface(4);
  auto frames = [&](const std::filesystem::path& d, int damaged, double scale = 1.0) {
    for (int k = 0; k < 4; ++k) {
      Surface t = s;
      if (k == damaged) t.frames[static_cast<size_t>(k)] *= scale;
      write_surface(d / ("lv_" + std::to_string(k) + ".obj"), t, k, k == damaged && scale == 1.0);
    }
  };
  const std::vector<BadCase> cases = {
      {"connectivity", [&](auto d, auto&) { frames(d, 2); write_file(d / "o.yaml", surface_config("\"lv_*.obj\"")); },
       {"lv_2.obj", "frame 2", "the connectivity must be the same in every frame"}},
      {"mixed units", [&](auto d, auto&) { frames(d, 3, 1e-3); write_file(d / "o.yaml", surface_config("\"lv_*.obj\"")); },
       {"lv_3.obj", "frame 3", "mixed units"}},
      {"missing landmark", [&](auto d, auto&) {
         frames(d, -1);
         write_file(d / "o.yaml", "name: x\nobserve:\n  meshes: \"lv_*.obj\"\n  landmarks: {apex: [0, 0, -45]}\n  timing: {heart_rate: 60 bpm}\n");
       },
       {"o.yaml:4:", "rv_anterior"}},
      {"landmark outside", [&](auto d, auto&) {
         frames(d, -1);
         write_file(d / "o.yaml", "name: x\nobserve:\n  meshes: \"lv_*.obj\"\n  landmarks:\n    apex: [0, 0, -45000]\n"
                                  "    rv_anterior: [25, 0, 0]\n  timing: {heart_rate: 60 bpm}\n");
       },
       {"o.yaml:5:", "apex is", "from the mesh's surface"}},
      {"times", [&](auto d, auto&) {
         frames(d, -1);
         write_file(d / "lv.pvd", "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n"
                                  "<DataSet timestep=\"0\" file=\"lv_0.obj\"/>\n<DataSet timestep=\"0.2\" file=\"lv_1.obj\"/>\n"
                                  "<DataSet timestep=\"0.1\" file=\"lv_2.obj\"/>\n</Collection>\n</VTKFile>\n");
         write_file(d / "o.yaml", "name: x\nobserve:\n  meshes: lv.pvd\n" + std::string(kLandmarksMm));
       },
       {"lv.pvd", "DataSet 2", "times must increase strictly"}},
      {"no times", [&](auto d, auto&) {
         frames(d, -1);
         write_file(d / "o.yaml", "name: x\nobserve:\n  meshes: \"lv_*.obj\"\n" + std::string(kLandmarksMm));
       },
       {"o.yaml:", "heart_rate"}},
      {"pressure", [&](auto d, auto&) {
         frames(d, -1);
         write_file(d / "p.csv", "time [ms], P_lv [mmHg]\n0, 10\n100, 20\n200, 10\n");
         write_file(d / "o.yaml", surface_config("\"lv_*.obj\"", "  pressure: {file: p.csv}\n"));
       },
       {"o.yaml:6:", "outside the pressure trace"}},
  };
  for (const auto& c : cases) {
    const auto dir = scratch_dir();
    c.make(dir, s);
    const CliRun r = cli3d({"observe", (dir / "o.yaml").string(), "-o", (dir / "o.csv").string()});
    EXPECT_EQ(r.code, 2) << c.what << ": " << r.err << r.out;
    for (const auto& w : c.words) EXPECT_NE(r.err.find(w), std::string::npos) << c.what << ": '" << w << "' not in " << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "o.csv")) << c.what;
    EXPECT_FALSE(std::filesystem::exists(dir / "o.h5")) << c.what;
    EXPECT_EQ(temporaries_in(dir), 0) << c.what;
  }
}

// A node dragged far away in one frame (a tracking failure): exit 1, named with its segment and
// frame, the curves still written.
TEST(Observe, ATrackingFailureIsExitOneWithTheSegmentAndFrameNamed) {
  REQUIRE_FORMATS();
  Surface s = ellipsoid_surface(6);
  const auto dir = scratch_dir();
  // Every node of basal segment 1 (phi in [-60, 0), h > 2/3) pulled 15 mm outward in frame 3.
  for (Eigen::Index i = 0; i < s.frames[3].rows(); ++i) {
    const Eigen::Vector3d p = s.frames[0].row(i);
    const double phi = std::atan2(p.y(), p.x()) * 180 / std::numbers::pi;
    if (p.z() > -5e-3 && phi > -55 && phi < -5) s.frames[3].row(i) += Eigen::Vector3d(p.x(), p.y(), 0).normalized().transpose() * 15e-3;
  }
  for (int k = 0; k < 6; ++k) write_surface(dir / ("lv_" + std::to_string(k) + ".obj"), s, k);
  write_file(dir / "o.yaml", surface_config("\"lv_*.obj\""));
  const CliRun r = cli3d({"observe", (dir / "o.yaml").string(), "-o", (dir / "o.csv").string()});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("frame 2: V_seg01: jumps by"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "o.csv"));
  EXPECT_NE(read_file(dir / "o.csv").find("tracking checks FAILED"), std::string::npos);
}

}  // namespace
}  // namespace sigmaheart::testing
