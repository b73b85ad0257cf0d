// eikonal_demo: the healthy and LBBB activation of the human-sized LV ellipsoid, written for
// ParaView (docs/models.md s.4.6). Not a benchmark; it lives here with the other small programs.
//
//   build/bench/eikonal_demo [output_dir]        (default: eikonal_demo_out)
//
// Writes <dir>/healthy.vtu and <dir>/lbbb.vtu (quadratic tetrahedra; point data activation_time [s];
// cell data aha_segment, fibre, fast_layer) and the time series <dir>/<pattern>_wave.pvd with one
// VTU per 10 ms (point data depolarised = 1 where activation_time <= t). Prints the total activation
// time and the mean activation time per AHA segment. Files are written to a temporary name in the
// same directory and renamed. Exit codes: 0 success, 2 bad arguments, 3 a file could not be written.
#include "model/fem/cavity.h"
#include "model/fem/eikonal.h"
#include "model/fem/fibres.h"
#include "model/fem/mesh.h"
#include "model/fem/vtk_output.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace {

using namespace sigmaheart::model::fem;
namespace fs = std::filesystem;

// Writes through `fill` to a temporary file next to `path`, then renames it over `path`.
void write_atomically(const fs::path& path, const std::function<void(std::ostream&)>& fill) {
  std::string tmp_name = path.filename().string();
  tmp_name.insert(0, 1, '.');
  tmp_name.append(".eikonal_demo-").append(std::to_string(::getpid())).append(".tmp");
  const fs::path tmp = path.parent_path() / tmp_name;
  {
    std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
    if (!os) throw std::runtime_error("cannot write " + tmp.string());
    fill(os);
    os.flush();
    if (!os) {
      fs::remove(tmp);
      throw std::runtime_error("error while writing " + tmp.string());
    }
  }
  fs::rename(tmp, path);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 2 || (argc == 2 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help"))) {
    std::cerr << "usage: eikonal_demo [output_dir]\n";
    return argc > 2 ? 2 : 0;
  }
  const fs::path dir = argc == 2 ? fs::path(argv[1]) : fs::path("eikonal_demo_out");
  try {
    fs::create_directories(dir);
  } catch (const std::exception& e) {
    std::cerr << "eikonal_demo: cannot create " << dir << ": " << e.what() << "\n";
    return 3;
  }
  const auto geometry = EllipsoidGeometry::human();
  const Mesh mesh = ellipsoid_mesh(
      geometry, {.n_transmural = 4, .n_longitudinal = 12, .n_circumferential = 36, .order = 2});
  const auto frames = ellipsoid_fibres(mesh, geometry, FibreOptions{}, 1);
  const AhaLabels aha = aha_labels(mesh);
  std::cout << "LV ellipsoid (endo 25/45 mm, epi 35/55 mm): " << mesh.n_vertices << " vertices, " << mesh.n_tets()
            << " quadratic tetrahedra\n";
  try {
    for (auto pattern : {ActivationPattern::kHealthy, ActivationPattern::kLbbb}) {
      const std::string name = to_string(pattern);
      const EikonalOptions options = activation_pattern(mesh, frames, pattern);
      const EikonalResult r = solve_eikonal(mesh, options);
      // Mean activation time per AHA segment (element means).
      std::array<double, kAhaSegments> sum{}, count{};
      for (int e = 0; e < mesh.n_tets(); ++e) {
        double te = 0;
        for (int a = 0; a < 4; ++a) te += 0.25 * r.times[mesh.tets(e, a)];
        const auto s = static_cast<size_t>(aha.element_segment[static_cast<size_t>(e)] - 1);
        sum[s] += te;
        count[s] += 1;
      }
      std::printf("%-8s total activation time %.1f ms; mean per AHA segment 1..17 [ms]:", name.c_str(),
                  1e3 * r.total_activation_time());
      for (size_t s = 0; s < sum.size(); ++s) std::printf(" %.0f", count[s] > 0 ? 1e3 * sum[s] / count[s] : 0.0);
      std::printf("\n");

      Eigen::VectorXd fibre(3 * mesh.n_tets()), fast(mesh.n_tets());
      for (int e = 0; e < mesh.n_tets(); ++e) {
        fibre.segment(3 * e, 3) = frames[static_cast<size_t>(e)].col(0);
        const auto& v = options.velocities.size() == 1 ? options.velocities[0] : options.velocities[static_cast<size_t>(e)];
        fast[e] = pattern == ActivationPattern::kHealthy && v.fibre == ActivationPatternOptions{}.fast_endocardial_speed ? 1.0 : 0.0;
      }
      VtuDocument doc(mesh);
      doc.add_vertex_data("activation_time", r.times);
      doc.add_cell_labels("aha_segment", aha.element_segment);
      doc.add_cell_data("fibre", fibre, 3);
      doc.add_cell_data("fast_layer", fast);
      write_atomically(dir / (name + ".vtu"), [&](std::ostream& os) { doc.write(os); });

      std::vector<PvdEntry> steps;
      VtuDocument wave(mesh);  // refilled for every step
      const int n_steps = static_cast<int>(std::ceil(r.latest / 0.010)) + 1;
      for (int k = 0; k < n_steps; ++k) {
        const double t = 0.010 * k;
        Eigen::VectorXd dep(mesh.n_vertices);
        for (int v = 0; v < mesh.n_vertices; ++v) dep[v] = r.times[v] <= t ? 1.0 : 0.0;
        wave.clear_data();
        wave.add_vertex_data("activation_time", r.times);
        wave.add_vertex_data("depolarised", dep);
        char file[64];
        std::snprintf(file, sizeof file, "%s_wave_%03d.vtu", name.c_str(), k);
        write_atomically(dir / file, [&](std::ostream& os) { wave.write(os); });
        steps.push_back({t, file});
      }
      write_atomically(dir / (name + "_wave.pvd"), [&](std::ostream& os) { write_pvd(os, steps); });
    }
  } catch (const std::exception& e) {
    std::cerr << "eikonal_demo: " << e.what() << "\n";
    return 3;
  }
  std::cout << "wrote " << dir.string() << "/{healthy,lbbb}.vtu and {healthy,lbbb}_wave.pvd\n";
  return 0;
}
