// Therapy prediction (docs/estimation.md s.12):
//  - the lead-site map over the 17 segments with posterior propagation on the regional model (the
//    target of issue 47: under 30 s on 2 threads): an LBBB heart, a posterior over the 17
//    contractilities (eta std 0.1, the spread of a personalisation), star sigma points (35) or a
//    simplex (18), the baseline and 17 BiV sites: 630 or 324 regional runs at dt 2 ms (args: threads,
//    dt [ms], 1 for the simplex);
//  - one paced 3D beat of lv-3d (the eikonal solve with the leads, then one beat) on the coarse
//    quadratic mesh and on the fine linear one (docs/models.md s.4.8);
//  - the activation input on the Caruel et al. 2014 case of svZeroDSolver (the sphere with its
//    inputs as far as ours has them): dP/dt max and the isovolumic contraction with the square
//    wave and with the ramped u(t) (counters dPdt_max [mmHg/s], ivc [ms]).
// Run: build/bench/therapy_bench [--benchmark_filter=Map|Beat3D|Caruel]
#include "estimation/therapy/therapy.h"
#include "model/activation/paced_simulator.h"
#include "model/fem/electromechanics.h"
#include "model/lumped/regional.h"
#include "model/lumped/sphere.h"
#include "observers/global_indices.h"

#include <benchmark/benchmark.h>

#include <omp.h>

namespace {

namespace th = sigmaheart::estimation::therapy;
namespace act = sigmaheart::model::activation;
using sigmaheart::model::lumped::ActivationPattern;
using sigmaheart::model::lumped::RegionalOptions;
using sigmaheart::model::lumped::RegionalVentricle;

// The lead-site map with the posterior propagated: range(0) threads, range(1) dt [ms], range(2) 1
// simplex (else star). BM_LeadSiteMapRegional with warm starts across the points (the default),
// BM_LeadSiteMapRegionalCold every run from the relaxed state.
void lead_site_map_regional(benchmark::State& bench, bool warm) {
  RegionalOptions o;
  o.activation = ActivationPattern::kLbbb;
  o.numerics.dt = bench.range(1) * 1e-3;
  const RegionalVentricle model(o);
  const auto& space = model.parameters();
  sigmaheart::estimation::Posterior post;
  std::vector<std::vector<int>> estimated;
  for (int i : space.regional("contractility")) {
    estimated.push_back({i});
    post.names.push_back(space[i].name);
    post.units.push_back(space[i].unit);
    post.transforms.push_back({sigmaheart::estimation::TransformKind::kLog, space[i].nominal});
  }
  const int p = static_cast<int>(estimated.size());
  post.eta_mean = Eigen::VectorXd::Zero(p);
  post.eta_covariance = 0.01 * Eigen::MatrixXd::Identity(p, p);
  th::TherapyOptions opts;
  opts.ensemble.threads = static_cast<int>(bench.range(0));
  if (bench.range(2) == 1) opts.propagation.sigma.rule = sigmaheart::estimation::SigmaRule::kSimplex;
  opts.av_sweep.clear();
  opts.vv_sweep.clear();
  opts.warm_starts = warm ? th::TherapyOptions::WarmStarts::kAuto : th::TherapyOptions::WarmStarts::kNever;
  th::TherapySummary s;
  for (auto _ : bench) {
    s = th::run_therapy_study(model, space.nominal(), estimated, post, opts);
    benchmark::DoNotOptimize(s.best);
  }
  bench.counters["runs"] = s.simulations;
  bench.counters["beats"] = static_cast<double>(s.beats);
  bench.counters["beats_per_run"] = s.simulations > 0 ? static_cast<double>(s.beats) / s.simulations : 0.0;
  bench.counters["cold_retries"] = s.cold_retries;
  bench.counters["failures"] = s.failures;
  bench.counters["best_segment"] = s.best + 1;
  bench.counters["best_ahr"] = s.best >= 0 ? s.map[static_cast<size_t>(s.best)].change_moments.mean(0) : 0.0;
  bench.SetLabel(std::to_string(bench.range(0)) + " threads, dt " + std::to_string(bench.range(1)) + " ms, " +
                 std::to_string(s.points.count()) + " points");
}
void BM_LeadSiteMapRegional(benchmark::State& bench) { lead_site_map_regional(bench, true); }
void BM_LeadSiteMapRegionalCold(benchmark::State& bench) { lead_site_map_regional(bench, false); }
// Both maps: (threads, dt [ms], rule: 0 star, 1 simplex), one iteration, process CPU beside the wall.
void map_runs(benchmark::internal::Benchmark* b) {
  b->Args({2, 2, 0})->Args({2, 2, 1})->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime()->MeasureProcessCPUTime();
}
BENCHMARK(BM_LeadSiteMapRegional)->Apply(map_runs);
BENCHMARK(BM_LeadSiteMapRegionalCold)->Apply(map_runs);

// One paced beat of lv-3d: 0 coarse quadratic (dt 10 ms), 1 fine linear (dt 5 ms).
void BM_TherapyBeat3D(benchmark::State& bench) {
  sigmaheart::model::fem::LeftVentricle3DOptions o;
  o.activation = sigmaheart::model::fem::ActivationSource::kLbbb;
  o.min_beats = 1;
  o.max_beats = 1;
  if (bench.range(0) == 1) {
    o.n_transmural = 3, o.n_longitudinal = 18, o.n_circumferential = 36;
    o.element_order = 1, o.bulk_modulus = 1e7, o.quadrature_degree = 1, o.dt = 5e-3;
  } else {
    o.dt = 1e-2;
  }
  omp_set_num_threads(1);
  sigmaheart::model::fem::LeftVentricle3D model(o);
  act::PacingPlan plan;
  plan.stimuli = {{"RV", {9, act::Surface::kEpicardium, {}}, -0.04}, {"LV", {5, act::Surface::kEpicardium, {}}, -0.04}};
  const Eigen::VectorXd theta = model.parameters().nominal();
  for (auto _ : bench) {
    act::PacedSimulator paced(model, plan);
    const auto r = paced.run(theta);  // one beat: kNotPeriodic by design
    benchmark::DoNotOptimize(r.trajectory.values.data());
  }
  bench.SetLabel(bench.range(0) == 1 ? "fine linear (11 340 tets), dt 5 ms" : "coarse P2 (396 tets), dt 10 ms");
}
BENCHMARK(BM_TherapyBeat3D)->Arg(0)->Arg(1)->Unit(benchmark::kSecond)->Iterations(1);

// The svZeroDSolver Caruel case on our sphere: range(0) 0 square, 1 ramped.
void BM_CaruelActivationShape(benchmark::State& bench) {
  sigmaheart::model::lumped::SphereOptions o;
  if (bench.range(0) == 1) o.activation_input.shape = sigmaheart::model::bcs::ActivationShape::kRamped;
  auto space = sigmaheart::model::lumped::LumpedSphere::default_parameters();
  // chamber_sphere_straindependent_Caruel.json: the wall, the active law (E_s, mu, alpha, k_0,
  // sigma_0; u(t) as tabulated: k_ATP 35, k_RS 12, APD 0.24 s), the exponential passive law's I1 term
  // (C0 1.9 kPa, C1 0.11; ours has no fibre term), the valves' open resistances, the Windkessel and
  // the constant 800 Pa atrium, period 0.8 s.
  const std::pair<const char*, double> values[] = {
      {"R0", 0.0236}, {"d0", 0.0142}, {"eta", 70.0}, {"c1", 0.0}, {"c2", 0.0}, {"c_exp", 1900.0}, {"b_exp", 0.11},
      {"Es", 3e7}, {"mu", 70.0}, {"alpha", 1.5}, {"k0", 1e5}, {"sigma0", 1.24e5}, {"k_ATP", 35.0}, {"k_RS", 12.0},
      {"APD", 0.24}, {"period", 0.8}, {"K_at", 1.0 / 1.1e5}, {"K_ar", 1.0 / 7.7e4}, {"K_p", 5e-10}, {"R_p", 8e6},
      {"C_p", 2.5e-9}, {"R_d", 1e8}, {"C_d", 1e-8}, {"P_sv", 1000.0}, {"P_at0", 800.0}, {"P_at_kick", 0.0}};
  for (const auto& [name, v] : values) space.set_nominal(name, v);
  sigmaheart::model::lumped::LumpedSphere sphere(o, space);
  sigmaheart::model::RunResult r;
  for (auto _ : bench) r = sphere.run(space.nominal());
  if (!r.status.ok()) {
    bench.SkipWithError(r.status.message.c_str());
    return;
  }
  const sigmaheart::observers::GlobalIndices gi({{"dPdt_max", "EDV", "EF"}}, sphere.channels());
  Eigen::VectorXd z(3);
  (void)gi.observe(r.trajectory, z);
  const Eigen::VectorXd phase = r.trajectory.channel("phase");
  int ivc = 0;
  for (Eigen::Index k = 0; k < phase.size(); ++k) ivc += phase(k) == 1.0 ? 1 : 0;
  bench.counters["dPdt_max"] = z(0) / 133.322;
  bench.counters["EDV_mL"] = z(1) * 1e6;
  bench.counters["EF"] = z(2);
  bench.counters["ivc_ms"] = ivc * o.dt * 1e3;
  bench.SetLabel(bench.range(0) == 1 ? "ramped u(t)" : "square u(t)");
}
BENCHMARK(BM_CaruelActivationShape)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
