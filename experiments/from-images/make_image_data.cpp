// The image-like data of experiments/from-images (README.md) from one lv-3d beat written by
// `sigmaheart simulate --vtu` (and its results file):
//  - exact.csv: the simulator's own V_lv, V_seg01..17 interpolated (linearly in time) at the frames;
//  - mesh/lv.pvd: the beat resampled at the frames (positions linear in time between the
//    simulator's steps), every endocardial node moved along its normal by Gaussian noise of
//    `noise` mm (independent per node and frame, as a tracking error), binary VTU with the
//    `endocardium` point label;
//  - seg.nii.gz: the noise-free resampled cavity (endocardium closed by the flat lid at the base
//    ring) voxelised by voxel centres in a short-axis stack (slices normal to the long axis, a
//    random sub-voxel offset), label 1, 4D NIfTI;
//  - observe-mesh.yaml, observe-image.yaml: the observe configs with the landmarks a reader would
//    click on frame 0 (rounded to 1 mm).
//   make_image_data BEAT.pvd BEAT.h5 OUT_DIR [frames=25] [noise_mm=1.5] [voxel_mm=1.5,1.5,8] [seed=43]
#include "app/io/hdf5_writer.h"
#include "app/io/label_image_io.h"
#include "app/io/observation_file.h"
#include "app/io/atomic_file.h"
#include "app/io/mesh_io.h"
#include "app/io/tracked_mesh_io.h"
#include "model/fem/cavity.h"
#include "model/fem/element.h"
#include "model/fem/tracked_volumes.h"
#include "model/fem/vtk_output.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

namespace {

using namespace sigmaheart;
using namespace sigmaheart::model::fem;

// Positions at time t of a beat sampled at `times` (linear between samples).
Eigen::MatrixX3d at_time(const std::vector<double>& times, const std::vector<Eigen::MatrixX3d>& x, double t) {
  size_t j = 0;
  while (j + 2 < times.size() && times[j + 1] < t) ++j;
  const double w = std::clamp((t - times[j]) / (times[j + 1] - times[j]), 0.0, 1.0);
  return (1 - w) * x[j] + w * x[j + 1];
}

// Linear triangles of the closed cavity at positions x: each (quadratic) endocardial face on an
// n x n sub-grid, the lid as a fan from the ring's centre over the rim's sub-edges.
std::vector<std::array<Eigen::Vector3d, 3>> closed_cavity(const TrackedEndocardium& e, const Eigen::MatrixX3d& x, int n) {
  const Mesh& s = e.surface;
  std::vector<std::array<Eigen::Vector3d, 3>> tris;
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Eigen::MatrixXd xf(s.nodes_per_face(), 3);
  auto point = [&](double a, double b) {
    tri_shape(s.order, Eigen::Vector2d(a, b), N, dN);
    return Eigen::Vector3d(xf.transpose() * N);
  };
  std::map<std::pair<int, int>, std::pair<int, int>> edges;  // corner pair -> (uses, face)
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f) {
    for (int k = 0; k < s.nodes_per_face(); ++k) xf.row(k) = x.row(s.faces(f, k));
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        const double h = 1.0 / n;
        tris.push_back({point(i * h, j * h), point((i + 1) * h, j * h), point(i * h, (j + 1) * h)});
        if (i + j + 1 < n) tris.push_back({point((i + 1) * h, j * h), point((i + 1) * h, (j + 1) * h), point(i * h, (j + 1) * h)});
      }
    for (int k = 0; k < 3; ++k) {
      const int a = s.faces(f, k), b = s.faces(f, (k + 1) % 3);
      auto& u = edges[{std::min(a, b), std::max(a, b)}];
      ++u.first;
      u.second = static_cast<int>(f);
    }
  }
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int r : e.labels.base_ring) c += x.row(r).transpose();
  c /= static_cast<double>(e.labels.base_ring.size());
  for (const auto& [key, use] : edges) {
    if (use.first != 1) continue;
    const Eigen::Index f = use.second;
    for (int k = 0; k < s.nodes_per_face(); ++k) xf.row(k) = x.row(s.faces(f, k));
    // The edge in the face's parameters: corners (0,0), (1,0), (0,1).
    int ka = 0;
    while (!(std::minmax(s.faces(f, ka), s.faces(f, (ka + 1) % 3)) == std::minmax(key.first, key.second))) ++ka;
    const Eigen::Vector2d corner[3] = {{0, 0}, {1, 0}, {0, 1}};
    const Eigen::Vector2d p0 = corner[ka], p1 = corner[(ka + 1) % 3];
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d a = p0 + (p1 - p0) * (static_cast<double>(i) / n), b = p0 + (p1 - p0) * (static_cast<double>(i + 1) / n);
      tris.push_back({point(a(0), a(1)), point(b(0), b(1)), c});
    }
  }
  return tris;
}

// Voxel centres inside the closed surface (parity of the crossings of a ray along k per column).
// The grid is axis-aligned: index = (x - origin) / spacing.
std::vector<std::uint8_t> voxelise(const std::vector<std::array<Eigen::Vector3d, 3>>& tris, const VoxelGrid& g) {
  const int nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const Eigen::Vector3d h = g.edges.diagonal();
  std::vector<std::vector<double>> cross(static_cast<size_t>(nx) * ny);
  for (const auto& t : tris) {
    std::array<Eigen::Vector3d, 3> q;
    for (int k = 0; k < 3; ++k) q[static_cast<size_t>(k)] = (t[static_cast<size_t>(k)] - g.origin).cwiseQuotient(h);
    const double x0 = std::min({q[0].x(), q[1].x(), q[2].x()}), x1 = std::max({q[0].x(), q[1].x(), q[2].x()});
    const double y0 = std::min({q[0].y(), q[1].y(), q[2].y()}), y1 = std::max({q[0].y(), q[1].y(), q[2].y()});
    const double det = (q[1].x() - q[0].x()) * (q[2].y() - q[0].y()) - (q[2].x() - q[0].x()) * (q[1].y() - q[0].y());
    if (det == 0) continue;
    for (int i = std::max(0, static_cast<int>(std::ceil(x0))); i <= std::min(nx - 1, static_cast<int>(std::floor(x1))); ++i)
      for (int j = std::max(0, static_cast<int>(std::ceil(y0))); j <= std::min(ny - 1, static_cast<int>(std::floor(y1))); ++j) {
        const double a = ((q[1].x() - i) * (q[2].y() - j) - (q[2].x() - i) * (q[1].y() - j)) / det;
        const double b = ((q[2].x() - i) * (q[0].y() - j) - (q[0].x() - i) * (q[2].y() - j)) / det;
        const double c = 1 - a - b;
        if (a < 0 || b < 0 || c < 0) continue;
        cross[static_cast<size_t>(i + nx * j)].push_back(a * q[0].z() + b * q[1].z() + c * q[2].z());
      }
  }
  std::vector<std::uint8_t> mask(static_cast<size_t>(g.voxels()), 0);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      auto& z = cross[static_cast<size_t>(i + nx * j)];
      std::sort(z.begin(), z.end());
      for (size_t p = 0; p + 1 < z.size(); p += 2)
        for (int k = std::max(0, static_cast<int>(std::ceil(z[p]))); k <= std::min(nz - 1, static_cast<int>(std::floor(z[p + 1]))); ++k)
          mask[static_cast<size_t>(i + nx * (j + static_cast<long long>(ny) * k))] = 1;
    }
  return mask;
}

// A point in `unit` (m: 0.001 steps, mm: 1 steps), rounded to 1 mm as a reader would click it.
std::string point(const Eigen::Vector3d& p, double unit) {
  std::ostringstream s;
  auto r = [&](double v) { return std::round(v * 1e3) * 1e-3 / unit + 0.0; };  // + 0.0: no "-0"
  s << "[" << r(p.x()) << ", " << r(p.y()) << ", " << r(p.z()) << "]";
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: make_image_data BEAT.pvd BEAT.h5 OUT_DIR [frames=25] [noise_mm=1.5] [voxel_mm=1.5,1.5,8] [seed=43]\n");
    return 2;
  }
  const std::filesystem::path pvd = argv[1], h5 = argv[2], out = argv[3];
  const int frames = argc > 4 ? std::atoi(argv[4]) : 25;
  const double noise = (argc > 5 ? std::atof(argv[5]) : 1.5) * 1e-3;
  double vx = 1.5, vy = 1.5, vz = 8;
  if (argc > 6) std::sscanf(argv[6], "%lf,%lf,%lf", &vx, &vy, &vz);
  const unsigned seed = argc > 7 ? static_cast<unsigned>(std::atoi(argv[7])) : 43u;
  try {
    std::filesystem::create_directories(out / "mesh");
    const app::io::PvdSeries series = app::io::read_pvd_series(pvd);
    app::io::TrackedMeshReadOptions ro;
    ro.length_unit = 1.0;
    ro.displacement = "displacement";
    ro.point_label = "endocardium";
    const app::io::TrackedMeshSeries m = app::io::read_tracked_meshes(series.files, ro);
    const double T = series.times.back();
    const Eigen::MatrixX3d x_ref = m.points[0] - m.displacement[0];
    std::vector<char> endo(static_cast<size_t>(m.mesh.faces.rows()), 0);
    for (Eigen::Index f = 0; f < m.mesh.faces.rows(); ++f) {
      bool all = true;
      for (int j = 0; j < m.mesh.faces.cols(); ++j) all = all && m.point_label(m.mesh.faces(f, j)) == 1.0;
      endo[static_cast<size_t>(f)] = all;
    }
    // The simulator's frame: apex and base from the undeformed mesh (landmarks for the checks only).
    Landmarks lm;
    double zmin = 1e9;
    for (Eigen::Index i = 0; i < x_ref.rows(); ++i)
      if (m.point_label(i) == 1.0 && x_ref(i, 2) < zmin) {
        zmin = x_ref(i, 2);
        lm.apex = x_ref.row(i);
      }
    lm.rv_anterior = Eigen::Vector3d(x_ref.col(0).maxCoeff() * 0.8, 0, 0);
    TrackedOptions to;
    to.landmark_tolerance = 0.05;
    const TrackedEndocardium e = make_tracked_endocardium(m.mesh, endo, x_ref, true, lm, to);

    // Frames, the exact channels at them.
    std::vector<double> t(static_cast<size_t>(frames));
    std::vector<Eigen::MatrixX3d> x(static_cast<size_t>(frames));
    for (int k = 0; k < frames; ++k) {
      t[static_cast<size_t>(k)] = T * k / frames;
      x[static_cast<size_t>(k)] = at_time(series.times, m.points, t[static_cast<size_t>(k)]);
    }
    app::io::Hdf5Reader sim(h5);
    model::Trajectory exact;
    exact.times = Eigen::Map<Eigen::VectorXd>(t.data(), frames);
    const Eigen::VectorXd st = sim.read_vector("/trajectories/simulated/time");
    std::vector<std::string> names = {"V_lv"};
    for (int s = 1; s <= 17; ++s) names.push_back(std::string("V_seg") + (s < 10 ? "0" : "") + std::to_string(s));
    exact.values.resize(frames, static_cast<Eigen::Index>(names.size()));
    for (size_t c = 0; c < names.size(); ++c) {
      exact.channels.push_back({names[c], "m^3", ""});
      const Eigen::VectorXd v = sim.read_vector("/trajectories/simulated/" + names[c]) * 1e-6;  // mL -> m^3
      for (int k = 0; k < frames; ++k) {
        Eigen::Index j = 0;
        while (j + 2 < st.size() && st(j + 1) < t[static_cast<size_t>(k)]) ++j;
        const double w = (t[static_cast<size_t>(k)] - st(j)) / (st(j + 1) - st(j));
        exact.values(k, static_cast<Eigen::Index>(c)) = (1 - w) * v(j) + w * v(j + 1);
      }
    }
    app::io::write_observation_csv(out / "exact.csv", exact, "ms", std::vector<std::string>(names.size(), "mL"),
                                   {"the simulator's own channels (" + h5.string() + ") interpolated at " + std::to_string(frames) +
                                    " frames; times after the beat's onset (the ECG trigger)"});

    // The noisy tracked series: each endocardial node along the surface's normal at that frame.
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> gauss(0.0, noise);
    std::vector<std::pair<double, std::string>> steps;
    Eigen::VectorXd label = m.point_label;
    for (int k = 0; k < frames; ++k) {
      const Eigen::MatrixX3d& xk = x[static_cast<size_t>(k)];
      Eigen::MatrixX3d normal = Eigen::MatrixX3d::Zero(xk.rows(), 3);
      for (Eigen::Index f = 0; f < e.surface.faces.rows(); ++f) {
        const Eigen::Vector3d p0 = xk.row(e.surface.faces(f, 0)), p1 = xk.row(e.surface.faces(f, 1)), p2 = xk.row(e.surface.faces(f, 2));
        const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
        for (int j = 0; j < e.surface.faces.cols(); ++j) normal.row(e.surface.faces(f, j)) += n.transpose();
      }
      Eigen::MatrixX3d noisy = xk;
      for (Eigen::Index i = 0; i < xk.rows(); ++i)
        if (label(i) == 1.0) noisy.row(i) += gauss(rng) * normal.row(i).normalized();
      VtuDocument doc(m.mesh);
      doc.set_points(noisy);
      doc.add_point_data("endocardium", label);
      char name[32];
      std::snprintf(name, sizeof name, "lv_%04d.vtu", k);
      app::io::write_text_file(out / "mesh" / name, [&](std::ostream& os) { doc.write(os); });
      steps.emplace_back(t[static_cast<size_t>(k)], name);
    }
    app::io::write_pvd((out / "mesh" / "lv.pvd").string(), steps);

    // The label image: short-axis stack around the cavity, a sub-voxel offset.
    std::uniform_real_distribution<double> u(0.0, 1.0);
    VoxelGrid g;
    g.edges = Eigen::Vector3d(vx, vy, vz).asDiagonal();
    g.edges *= 1e-3;
    const Eigen::Vector3d lo = x_ref.colwise().minCoeff().transpose() - Eigen::Vector3d(10e-3, 10e-3, 12e-3);
    const Eigen::Vector3d hi = x_ref.colwise().maxCoeff().transpose() + Eigen::Vector3d(10e-3, 10e-3, 12e-3);
    for (int d = 0; d < 3; ++d) g.dims[static_cast<size_t>(d)] = static_cast<int>(std::ceil((hi(d) - lo(d)) / g.edges(d, d)));
    g.origin = lo + Eigen::Vector3d(u(rng) * g.edges(0, 0), u(rng) * g.edges(1, 1), u(rng) * g.edges(2, 2));
    std::vector<std::vector<std::uint8_t>> masks;
    for (int k = 0; k < frames; ++k) masks.push_back(voxelise(closed_cavity(e, x[static_cast<size_t>(k)], 4), g));
    app::io::write_label_image(out / "seg.nii.gz", g, masks, T / frames);

    // Landmarks a reader would click on frame 0 (1 mm), the configs: the apex where the tracked
    // mesh's apex node is (the material apex, as the simulator's), the ring, the RV insertion at
    // phi = 0 (+x) at mid height.
    const Eigen::MatrixX3d& x0 = x[0];
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int r : e.labels.base_ring) c += x0.row(r).transpose();
    c /= static_cast<double>(e.labels.base_ring.size());
    Eigen::Index apex_node = 0;
    for (Eigen::Index i = 0; i < x_ref.rows(); ++i)
      if (label(i) == 1.0 && x_ref(i, 2) < x_ref(apex_node, 2)) apex_node = i;
    const Eigen::Vector3d apex = x0.row(apex_node);
    double rmax = 0;
    for (int r : e.labels.base_ring) rmax = std::max(rmax, (x0.row(r).transpose() - c).head<2>().norm());
    const Eigen::Vector3d rv(c.x() + 0.9 * rmax, c.y(), 0.5 * (apex.z() + c.z()));
    std::ostringstream base;
    for (int a = 0; a < 3; ++a) {
      const double ang = 0.3 + 2.0944 * a;
      base << (a ? ", " : "") << point(c + 0.95 * rmax * Eigen::Vector3d(std::cos(ang), std::sin(ang), 0), 1e-3);
    }
    std::ofstream(out / "observe-mesh.yaml")
        << "# experiments/from-images: the noisy tracked meshes (made by make_image_data)\nname: from-meshes\nobserve:\n"
        << "  meshes: mesh/lv.pvd\n  units: m\n  endocardium: {point_label: endocardium}\n"
        << "  landmarks: {apex: " << point(apex, 1.0) << ", base: rim, rv_anterior: " << point(rv, 1.0) << "}\n";
    std::ofstream(out / "observe-image.yaml")
        << "# experiments/from-images: the label image (made by make_image_data)\nname: from-image\nobserve:\n"
        << "  images: seg.nii.gz\n  label: 1\n"
        << "  landmarks: {apex: " << point(apex, 1e-3) << ", base: [" << base.str() << "], rv_anterior: " << point(rv, 1e-3) << "}\n";
    std::printf("%d frames over %.4g s: exact.csv, mesh/lv.pvd (noise %.2g mm), seg.nii.gz (%d x %d x %d voxels of %.3g x %.3g x %.3g mm)\n",
                frames, T, noise * 1e3, g.dims[0], g.dims[1], g.dims[2], vx, vy, vz);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "make_image_data: %s\n", ex.what());
    return 1;
  }
  return 0;
}
