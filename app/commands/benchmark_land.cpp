// `sigmaheart benchmark land --problem 1|2|3 [--refinement K ...] [-o OUT.csv] [--vtu DIR]`:
// the cardiac mechanics verification benchmark of Land et al. 2015 (Proc R Soc A 471:20150641)
// on the 3D finite-element ventricle of model/fem. Prints one table row per refinement (ours
// beside the published reference, unknowns, Newton iterations, run time); optionally writes the
// table as CSV and the deformed state as ParaView files.
#include "app/commands/commands.h"
#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/mesh_io.h"
#include "model/fem/cavity.h"
#include "model/fem/land_benchmark.h"

#include <filesystem>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app {

namespace {

struct BenchmarkOptions {
  int problem = 2;
  std::vector<int> refinements = {1};
  int load_steps = 0;
  int quadrature = 5;
  std::string base = "fixed";
  std::filesystem::path output;  // CSV, optional
  std::filesystem::path vtu;     // directory, optional
};

// The published spread of the codes' finest solutions (LandReference), with its figure.
std::string reference_text(int problem) {
  using R = model::fem::LandReference;
  const auto range = [](const model::fem::LandRange& r, int digits) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(digits) << r.low << ".." << r.high;
    return s.str();
  };
  std::ostringstream os;
  if (problem == 1) os << "z of (10, 0.5, 1) " << range(R::kProblem1Deflection, 3) << " mm, fig. 3";
  if (problem == 2)
    os << "apex z endo " << range(R::kProblem2EndoApex, 2) << ", epi " << range(R::kProblem2EpiApex, 2)
       << " mm, fig. 6";
  if (problem == 3)
    os << "apex z endo " << range(R::kProblem3EndoApex, 2) << ", epi " << range(R::kProblem3EpiApex, 2)
       << " mm, fig. 9";
  return os.str();
}

int run_land(const BenchmarkOptions& o, CommandContext& ctx) {
  model::fem::LandOptions lo;
  lo.problem = o.problem;
  lo.load_steps = o.load_steps;
  lo.quadrature_degree = o.quadrature;
  try {
    lo.base = model::fem::parse_base_condition(o.base);
  } catch (const std::invalid_argument& e) {
    throw InputError("--base", 0, 0, e.what());
  }
  ctx.out << "Land et al. 2015, problem " << o.problem << " (spread of the codes' finest solutions: "
          << reference_text(o.problem) << ")\n";
  ctx.out << std::setw(3) << "K" << std::setw(9) << "tets" << std::setw(10) << "unknowns" << std::setw(13)
          << (o.problem == 1 ? "z_point[mm]" : "endo_z[mm]") << std::setw(13) << (o.problem == 1 ? "" : "epi_z[mm]")
          << std::setw(8) << "newton" << std::setw(10) << "time[s]" << "\n";
  std::ostringstream csv;
  csv << "problem,refinement,tets,unknowns,primary_mm,secondary_mm,newton_iterations,seconds,converged\n";
  bool all_ok = true;
  for (int k : o.refinements) {
    lo.refinement = k;
    if (auto m = lo.validate(); !m.empty()) throw InputError("--refinement", 0, 0, m);
    const model::fem::LandResult r = model::fem::run_land_problem(lo, [&](double lam, int it, double res) {
      ctx.err << "\r  K=" << k << " load " << std::fixed << std::setprecision(3) << lam << " (" << it
              << " Newton, |R| " << std::scientific << std::setprecision(1) << res << ")" << std::defaultfloat
              << std::flush;
    });
    ctx.err << "\n";
    ctx.out << std::setw(3) << k << std::setw(9) << r.n_tets << std::setw(10) << r.n_unknowns << std::fixed
            << std::setprecision(4) << std::setw(13) << r.primary << std::setw(13);
    if (o.problem == 1) ctx.out << "";
    else ctx.out << r.secondary;
    ctx.out << std::setw(8) << r.summary.newton_iterations << std::setprecision(1) << std::setw(10) << r.seconds
            << std::defaultfloat << (r.summary.converged ? "" : "  FAILED: " + r.summary.message) << "\n";
    csv << o.problem << ',' << k << ',' << r.n_tets << ',' << r.n_unknowns << ',' << r.primary << ','
        << r.secondary << ',' << r.summary.newton_iterations << ',' << r.seconds << ','
        << (r.summary.converged ? 1 : 0) << '\n';
    all_ok = all_ok && r.summary.converged;
    if (!o.vtu.empty()) {
      std::filesystem::create_directories(o.vtu);
      const std::string stem = "land_p" + std::to_string(o.problem) + "_k" + std::to_string(k);
      io::VtuFields f;
      f.displacement = &r.state.u;
      f.pressure = &r.state.p;
      f.fibres = &r.element_fibres;
      std::vector<int> aha;
      if (o.problem != 1) {
        aha = model::fem::aha_labels(r.mesh).element_segment;
        f.aha = &aha;
      }
      io::write_vtu((o.vtu / (stem + ".vtu")).string(), r.mesh, f);
      io::write_pvd((o.vtu / (stem + ".pvd")).string(), {{1.0, stem + ".vtu"}});
    }
  }
  if (!o.output.empty()) {
    io::write_text_file(o.output, [&](std::ostream& f) { f << csv.str(); });
  }
  if (!all_ok) throw RunFailure("the Newton solve failed for at least one refinement (see the table)");
  return kExitOk;
}

}  // namespace

void add_land_benchmark(CLI::App& bench, CommandContext& ctx) {
  auto [land, opts] = add_command(bench, ctx, "land", "Land et al. 2015 cardiac mechanics benchmark (3D FEM)", run_land);
  land->add_option("--problem", opts->problem, "Problem 1 (beam), 2 (inflation) or 3 (inflation + contraction)")
      ->check(CLI::Range(1, 3));
  land->add_option("--refinement", opts->refinements, "Mesh refinement level(s) K >= 1 (repeat or comma-separate)")
      ->delimiter(',');
  land->add_option("--load-steps", opts->load_steps, "Load increments (0: problem default)");
  land->add_option("--quadrature", opts->quadrature, "Tetrahedron quadrature degree (2 or 5)");
  land->add_option("--base", opts->base, "Base condition: fixed or sliding");
  land->add_option("-o,--output", opts->output, "Write the result table as CSV");
  land->add_option("--vtu", opts->vtu, "Write the deformed state as ParaView files into this directory");
}

}  // namespace sigmaheart::app
