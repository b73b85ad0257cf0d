// Eikonal solve time vs mesh size: the healthy and LBBB activation patterns on the human-sized LV
// ellipsoid (linear tetrahedra) at three refinements (docs/models.md s.4.6). Counters: vertices,
// tetrahedra, heap pops per vertex (1 = no correction needed), total activation time [ms].
//   build/bench/eikonal_bench --benchmark_counters_tabular=true
#include "model/fem/eikonal.h"
#include "model/fem/fibres.h"
#include "model/fem/mesh.h"

#include <benchmark/benchmark.h>

namespace {

using namespace sigmaheart::model::fem;

struct Lv {
  Mesh mesh;
  EikonalOptions options;
  Lv(int level, ActivationPattern pattern) {
    EllipsoidMeshOptions mo;  // level 1, 2, 3: 4x12x36, 6x18x54, 8x24x72 element layers
    mo.n_transmural = 2 * level + 2;
    mo.n_longitudinal = 6 * level + 6;
    mo.n_circumferential = 18 * level + 18;
    mo.order = 1;
    const auto g = EllipsoidGeometry::human();
    mesh = ellipsoid_mesh(g, mo);
    options = activation_pattern(mesh, ellipsoid_fibres(mesh, g, FibreOptions{}, 1), pattern);
  }
};

void run(benchmark::State& st, ActivationPattern pattern) {
  const Lv lv(static_cast<int>(st.range(0)), pattern);
  EikonalResult r;
  for (auto _ : st) {
    r = solve_eikonal(lv.mesh, lv.options);
    benchmark::DoNotOptimize(r.times.data());
  }
  st.SetComplexityN(lv.mesh.n_vertices);
  st.counters["vertices"] = lv.mesh.n_vertices;
  st.counters["tets"] = lv.mesh.n_tets();
  st.counters["pops_per_vertex"] = static_cast<double>(r.heap_pops) / lv.mesh.n_vertices;
  st.counters["total_ms"] = 1e3 * r.total_activation_time();
}

void BM_EikonalHealthy(benchmark::State& st) { run(st, ActivationPattern::kHealthy); }
void BM_EikonalLbbb(benchmark::State& st) { run(st, ActivationPattern::kLbbb); }

BENCHMARK(BM_EikonalHealthy)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Complexity(benchmark::oNLogN);
BENCHMARK(BM_EikonalLbbb)->DenseRange(1, 3)->Unit(benchmark::kMillisecond)->Complexity(benchmark::oNLogN);

}  // namespace

BENCHMARK_MAIN();
