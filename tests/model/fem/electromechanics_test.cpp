// The 3D electromechanical beat (model/fem/electromechanics.h) on the coarse mesh: the passive
// law's tangent, a closing beat with the phases in order, isovolumic phases that hold the volume,
// indices in wide physiological ranges, the activation input, and bad numerics reported at their
// key. The simulator contract and the periodic run are in electromechanics_slow_test.cpp.
#include "model/fem/electromechanics.h"
#include "model/fem/register.h"

#include "tests/model/map_options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <map>
#include <random>

namespace sigmaheart::model::fem {
namespace {

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

using sigmaheart::model::testing::MapOptions;

std::string error_of(const std::map<std::string, std::string>& values) {
  try {
    read_lv3d_options(MapOptions(values).named("simulator.numerics"));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(Lv3dRegistration, BadNumericsAreReportedAtTheirKey) {
  EXPECT_EQ(error_of({{"dt", "0.5"}}), "dt: simulator.numerics: dt = 0.5 s must lie in [1e-05, 0.05] s");
  EXPECT_EQ(error_of({{"max_beats", "0"}}), "max_beats: simulator.numerics: max_beats must be in [min_beats, 1000]");
  EXPECT_EQ(error_of({{"mesh", "huge"}}), "mesh: bad choice");
  EXPECT_EQ(error_of({{"dtt", "1e-3"}}), "dtt: unknown key 'dtt'");
  EXPECT_EQ(error_of({{"quadrature_degree", "3"}}),
            "quadrature_degree: simulator.numerics: quadrature_degree must be 1, 2 or 5");
  EXPECT_EQ(error_of({{"quadrature_degree", "1"}}),
            "quadrature_degree: simulator.numerics: quadrature_degree 1 needs element_order 1 (one point "
            "under-integrates quadratic tetrahedra)");
  EXPECT_EQ(error_of({{"conduction_velocity", "-1"}}),
            "conduction_velocity: simulator.numerics: conduction_velocity = -1 m/s must lie in (0.01, 100) m/s");
  EXPECT_EQ(error_of({{"linear_tolerance", "0.5"}}),
            "linear_tolerance: simulator.numerics: linear_tolerance = 0.5 must lie in [1e-14, 0.1]");
  EXPECT_EQ(read_lv3d_options(MapOptions({{"linear_solver", "sparselu"}, {"linear_tolerance", "1e-2"}})).linear_tolerance,
            1e-2);
  EXPECT_EQ(error_of({{"mesh", "medium"}, {"dt", "2e-3"}}), "");
  EXPECT_EQ(error_of({{"coarse_correction", "true"}}),
            "coarse_correction: simulator.numerics: coarse_correction needs linear_solver amg (the direct solvers have "
            "no preconditioner to correct)");
  EXPECT_EQ(error_of({{"coarse_correction", "yes"}}), "coarse_correction: expected true or false");
  if (linear_solver_available(LinearSolver::kAmg)) {
    // The coarse correction defaults to on for the scalable set-up only (amg, grad-div, linear).
    const std::map<std::string, std::string> scalable = {
        {"linear_solver", "amg"}, {"grad_div", "1"}, {"element_order", "1"}, {"bulk_modulus", "1e7"}};
    EXPECT_TRUE(read_lv3d_options(MapOptions(scalable)).coarse_correction);
    auto with = [&](const std::string& key, const std::string& value) {
      std::map<std::string, std::string> m = scalable;
      m[key] = value;
      return read_lv3d_options(MapOptions(m)).coarse_correction;
    };
    EXPECT_FALSE(with("coarse_correction", "false"));
    EXPECT_FALSE(with("grad_div", "0"));
    EXPECT_FALSE(with("element_order", "2"));
    EXPECT_TRUE(read_lv3d_options(MapOptions({{"linear_solver", "amg"}, {"coarse_correction", "true"}})).coarse_correction);
    EXPECT_FALSE(read_lv3d_options(MapOptions(std::map<std::string, std::string>{{"linear_solver", "amg"}})).coarse_correction);
  }
  EXPECT_FALSE(read_lv3d_options(MapOptions({{"linear_solver", "sparselu"}, {"grad_div", "1"}})).coarse_correction);
  EXPECT_EQ(error_of({{"exact_displacement_solve", "true"}}),
            "exact_displacement_solve: simulator.numerics: exact_displacement_solve needs linear_solver amg (it "
            "replaces the V-cycle of its preconditioner)");
  EXPECT_EQ(error_of({{"grad_div", "-1"}}), "grad_div: simulator.numerics: grad_div must be finite and >= 0");
  EXPECT_EQ(read_lv3d_options(MapOptions({{"linear_solver", "sparselu"}, {"grad_div", "1"}})).grad_div, 1.0);
  EXPECT_EQ(error_of({{"element_order", "3"}}),
            "element_order: simulator.numerics: element_order must be 1 (linear) or 2 (quadratic)");
  EXPECT_EQ(error_of({{"element_order", "1"}}),
            "bulk_modulus: simulator.numerics: bulk_modulus must be > 0 with element_order 1 (P1-P1 is not inf-sup "
            "stable at exact incompressibility)");
  EXPECT_EQ(error_of({{"bulk_modulus", "-1"}}),
            "bulk_modulus: simulator.numerics: bulk_modulus must be finite and >= 0 [Pa]");
  EXPECT_EQ(error_of({{"pressure_stabilization", "0.1"}}),
            "pressure_stabilization: simulator.numerics: pressure_stabilization needs element_order 1 (Taylor-Hood "
            "tetrahedra are inf-sup stable)");
  EXPECT_EQ(error_of({{"element_order", "1"}, {"bulk_modulus", "1e7"}, {"pressure_stabilization", "-1"}}),
            "pressure_stabilization: simulator.numerics: pressure_stabilization must be finite and >= 0");
  EXPECT_EQ(read_lv3d_options(MapOptions({{"element_order", "1"}, {"bulk_modulus", "1e7"}, {"pressure_stabilization", "0.1"}}))
                .pressure_stabilization,
            0.1);
  const LeftVentricle3DOptions linear =
      read_lv3d_options(MapOptions({{"element_order", "1"}, {"bulk_modulus", "1e7"}}));
  EXPECT_EQ(linear.element_order, 1);
  EXPECT_EQ(linear.bulk_modulus, 1e7);
  LeftVentricle3DOptions too_coarse;
  too_coarse.n_circumferential = 6;  // inverts curved elements at the apex
  EXPECT_EQ(too_coarse.validate(), "n_circumferential must be a multiple of 6 in 12..120 (AHA 60-degree sectors)");
  EXPECT_THROW(LeftVentricle3D{too_coarse}, std::invalid_argument);
  const LeftVentricle3DOptions o = read_lv3d_options(MapOptions({{"mesh", "fine"}, {"activation", "apex_distance"}}));
  EXPECT_EQ(o.n_transmural, 3);
  EXPECT_EQ(o.n_circumferential, 36);
  EXPECT_EQ(o.activation, ActivationSource::kApexDistance);
  EXPECT_EQ(o.active_stress, ActiveStress::kFibre);
  EXPECT_EQ(o.geometry.r_long_endo, EllipsoidGeometry::human().r_long_endo);
  // The thin-shell comparison's keys (docs/models.md s.4.8).
  EXPECT_EQ(read_lv3d_options(MapOptions(std::map<std::string, std::string>{{"active_stress", "tangent_isotropic"}}))
                .active_stress,
            ActiveStress::kTangentIsotropic);
  EXPECT_EQ(error_of({{"active_stress", "both"}}), "active_stress: bad choice");
  EXPECT_EQ(error_of({{"geometry", "sphere"}}),
            "geometry: simulator.numerics.geometry: expected a map of r_short_endo, r_long_endo, r_short_epi, "
            "r_long_epi, z_base [m]");
  LeftVentricle3DOptions inverted;
  inverted.geometry.r_short_epi = 0.5 * inverted.geometry.r_short_endo;
  EXPECT_EQ(inverted.validate(), "geometry: epicardial radii must exceed the endocardial ones");
}

TEST(Lv3dRegistration, ParametersAreTaggedWithOneContractilityPerAhaSegment) {
  ModelRegistry registry;
  register_fem_models(registry);
  const ModelSetup* setup = registry.find("lv-3d");
  ASSERT_NE(setup, nullptr);
  const ParameterSpace space = setup->configure_defaults().parameters();
  for (const Parameter& p : space.all()) {
    EXPECT_TRUE(contains(parameter_families(), p.family)) << p.name << " family '" << p.family << "'";
  }
  const auto seg = space.regional("contractility");
  ASSERT_EQ(seg.size(), 17u);
  for (int k = 0; k < 17; ++k) EXPECT_EQ(space[seg[static_cast<size_t>(k)]].segment, k + 1);
  // The lumped sphere's names and units wherever the 3D model has the quantity.
  for (const char* name : {"k_ATP", "k_RS", "APD", "period", "R_p", "C_cav", "c1", "eta"}) {
    EXPECT_TRUE(space.index(name).has_value()) << name;
  }
  const auto sim = setup->configure_defaults().make();
  for (const Channel& c : sim->channels())
    if (c.name.rfind("V_seg", 0) == 0) {
      EXPECT_EQ(c.family, "regional_volume");
    }
  EXPECT_EQ(sim->channels().size(), 8u + 17u);
}

TEST(LeftVentricle3D, ActivationTimesComeFromTheChosenSource) {
  LeftVentricle3D sync;
  const auto& t0 = sync.activation_times();
  ASSERT_EQ(static_cast<int>(t0.size()), sync.n_quadrature_points());
  EXPECT_EQ(*std::max_element(t0.begin(), t0.end()), 0.0);

  LeftVentricle3DOptions o;
  o.activation = ActivationSource::kApexDistance;
  o.conduction_velocity = 0.5;
  LeftVentricle3D apex(o);
  const auto& t1 = apex.activation_times();
  // The farthest quadrature point lies inside the wall: below the farthest vertex's distance
  // (human ellipsoid: epicardial base ring ~ 64 mm from the endocardial apex) over 0.5 m/s.
  double far = 0.0;
  for (int v = 0; v < apex.mesh().n_vertices; ++v)
    far = std::max(far, (apex.mesh().nodes.row(v).transpose() - apex.labels().frame.apex).norm());
  const double latest = *std::max_element(t1.begin(), t1.end());
  EXPECT_GT(latest, 0.8 * far / 0.5);
  EXPECT_LE(latest, far / 0.5 + 1e-12);
  EXPECT_GT(far, 0.05);
  EXPECT_LT(far, 0.08);

  // The eikonal patterns (docs/models.md s.4.6) on the same coarse mesh: the healthy wave starts
  // in the septum and anterior wall and ends within ~100 ms; in LBBB the septum (AHA 2, 3, 8, 9)
  // is activated from the right and the lateral wall (5, 6, 11, 12) last, later than in health.
  auto mean_by_region = [](const LeftVentricle3D& sim, std::initializer_list<int> segments) {
    const auto& t = sim.activation_times();
    const int nq = sim.n_quadrature_points() / sim.mesh().n_tets();
    double sum = 0.0;
    int n = 0;
    for (int e = 0; e < sim.mesh().n_tets(); ++e) {
      const int seg = sim.labels().element_segment[static_cast<size_t>(e)];
      if (std::find(segments.begin(), segments.end(), seg) == segments.end()) continue;
      for (int q = 0; q < nq; ++q, ++n) sum += t[static_cast<size_t>(e * nq + q)];
    }
    return sum / n;
  };
  o.activation = ActivationSource::kHealthy;
  LeftVentricle3D healthy(o);
  o.activation = ActivationSource::kLbbb;
  LeftVentricle3D lbbb(o);
  const double healthy_latest = *std::max_element(healthy.activation_times().begin(), healthy.activation_times().end());
  const double lbbb_latest = *std::max_element(lbbb.activation_times().begin(), lbbb.activation_times().end());
  EXPECT_GT(healthy_latest, 0.03);
  EXPECT_LT(healthy_latest, 0.12);
  EXPECT_GT(lbbb_latest, healthy_latest + 0.03);
  const double lbbb_septal = mean_by_region(lbbb, {2, 3, 8, 9});
  const double lbbb_lateral = mean_by_region(lbbb, {5, 6, 11, 12});
  EXPECT_GT(lbbb_lateral, lbbb_septal + 0.04) << "septal " << lbbb_septal << " s, lateral " << lbbb_lateral << " s";
  EXPECT_GT(lbbb_lateral, mean_by_region(healthy, {5, 6, 11, 12}) + 0.03);

  // Prescribed per vertex: a linear field is interpolated exactly at the quadrature points.
  std::vector<double> vt(static_cast<size_t>(sync.mesh().n_vertices));
  for (int v = 0; v < sync.mesh().n_vertices; ++v) vt[static_cast<size_t>(v)] = 1.0 + sync.mesh().nodes(v, 2);
  sync.set_activation_times(vt);
  EXPECT_EQ(sync.options().activation, ActivationSource::kPrescribed);
  const auto& t2 = sync.activation_times();
  EXPECT_GT(*std::min_element(t2.begin(), t2.end()), 1.0 - 0.06);
  EXPECT_LT(*std::max_element(t2.begin(), t2.end()), 1.0 + 0.02);
  EXPECT_THROW(sync.set_activation_times({1.0, 2.0}), std::invalid_argument);
  vt[3] = -1.0;
  EXPECT_THROW(sync.set_activation_times(vt), std::invalid_argument);
  // A time past the period is refused at run time as a Status.
  for (double& t : vt) t = 2.0;
  sync.set_activation_times(vt);
  const RunResult r = sync.run(sync.parameters().nominal());
  EXPECT_EQ(r.status.code, StatusCode::kInvalidArgument);
  EXPECT_NE(r.status.message.find("activation time"), std::string::npos) << r.status.message;
}

// Two beats from the unloaded mesh on the coarse preset (396 tetrahedra, dt 20 ms); the checks run
// on the second beat (the first starts from the static inflation, without the atrial kick's
// filling). About 20 s of CPU; the periodic run to 1e-3 is in the slow tier.
void check_coarse_beat(LeftVentricle3DOptions o) {
  o.dt = 0.02;
  o.min_beats = 2;
  o.max_beats = 2;
  o.periodic_tolerance = 1.0;  // closure is checked below
  LeftVentricle3D lv(o);
  const RunResult r = lv.run(lv.parameters().nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_EQ(r.info.beats, 2);
  const Trajectory& tr = r.trajectory;
  EXPECT_DOUBLE_EQ(tr.times(tr.samples() - 1), 0.85);
  const Eigen::VectorXd V = tr.channel("V_lv"), P = tr.channel("P_lv"), ph = tr.channel("phase");
  const double EDV = V.maxCoeff(), ESV = V.minCoeff(), SV = EDV - ESV;
  std::printf("EDV %.2f mL, ESV %.2f mL, EF %.1f %%, peak P_lv %.1f mmHg, V(T) - V(0) %.3f mL\n", EDV * 1e6,
              ESV * 1e6, 100 * SV / EDV, P.maxCoeff() / 133.322, (V(V.size() - 1) - V(0)) * 1e6);

  // Phases in physiological order, filling (0) -> isovolumic contraction (1) -> ejection (2) ->
  // isovolumic relaxation (3) -> filling: every change goes to the next phase of the cycle and each
  // phase occurs once (the run that ends the beat may continue the one that started it: the mitral
  // valve closes as the atrial kick falls, just before t = 0).
  std::vector<int> order;
  std::vector<std::pair<int, int>> runs;  // first and last sample of each phase run
  for (int k = 0; k < tr.samples(); ++k) {
    const int p = static_cast<int>(ph(k));
    if (order.empty() || order.back() != p) {
      order.push_back(p);
      runs.emplace_back(k, k);
    }
    runs.back().second = k;
  }
  ASSERT_GE(order.size(), 4u);
  ASSERT_LE(order.size(), 5u);
  for (size_t j = 0; j + 1 < order.size(); ++j) EXPECT_EQ(order[j + 1], (order[j] + 1) % 4) << "phase run " << j;
  if (order.size() == 5) {
    EXPECT_EQ(order.front(), order.back());
  }

  // Isovolumic phases hold the volume: the only volume change is C_cav dP_v and the closed-valve
  // leak K_p (P_v - P_at), about 0.1 mL per phase; bound: 1 % of the stroke volume per phase run.
  for (size_t j = 0; j < runs.size(); ++j) {
    if (order[j] != 1 && order[j] != 3) continue;
    const auto [a, b] = runs[j];
    const Eigen::VectorXd seg = V.segment(a, b - a + 1);
    EXPECT_LT(seg.maxCoeff() - seg.minCoeff(), 0.01 * SV)
        << "phase " << order[j] << ": volume change " << (seg.maxCoeff() - seg.minCoeff()) * 1e6 << " mL";
  }
  for (int phase : {1, 3}) {
    int n = 0;
    for (int k = 0; k < tr.samples(); ++k) n += static_cast<int>(ph(k)) == phase;
    EXPECT_GE(n, 3) << "phase " << phase << " has too few samples";
  }

  // The beat closes: the volume at its end returns to its start within 3 % of the stroke volume.
  EXPECT_LT(std::abs(V(V.size() - 1) - V(0)), 0.03 * SV)
      << "V(0) " << V(0) * 1e6 << " mL, V(T) " << V(V.size() - 1) * 1e6 << " mL";

  // Wide physiological ranges on the coarse mesh (docs/models.md s.7 gives the healthy ones).
  const double EF = SV / EDV;
  EXPECT_GT(EF, 0.30);
  EXPECT_LT(EF, 0.80);
  EXPECT_GT(EDV, 90e-6);
  EXPECT_LT(EDV, 250e-6);
  EXPECT_GT(P.maxCoeff(), 80 * 133.322);
  EXPECT_LT(P.maxCoeff(), 160 * 133.322);
  // Regional volumes sum to the cavity volume (docs/models.md s.5).
  const int k = tr.samples() / 2;
  double sum = 0.0;
  for (int s = 1; s <= 17; ++s) sum += tr.channel((s < 10 ? "V_seg0" : "V_seg") + std::to_string(s))(k);
  EXPECT_NEAR(sum, V(k), 1e-9 * V(k));
}

TEST(LeftVentricle3D, CoarseBeatClosesWithPhasesInOrderAndIsovolumicVolumesHeld) { check_coarse_beat({}); }

// The same on linear tetrahedra (element_order 1, P1-P1 with a 10 MPa bulk modulus, one quadrature
// point; docs/models.md s.4.8 "Linear tetrahedra"): the coarse mesh's 396 tetrahedra with straight faces (a smaller
// cavity), about 1 s of CPU.
TEST(LeftVentricle3D, CoarseBeatOnLinearTetrahedraClosesWithPhasesInOrderAndIsovolumicVolumesHeld) {
  LeftVentricle3DOptions o;
  o.element_order = 1;
  o.bulk_modulus = 1e7;
  o.quadrature_degree = 1;
  check_coarse_beat(o);
}

// Broyden's updates of the chord directions (electromechanics.cpp, step) change the path of each
// Newton solve, not its answer: the beat agrees with the plain chord's to the Newton tolerance
// (1e-8 on the scaled rows; volumes and pressures within 1e-8 of their peaks, measured 6e-11 to
// 7e-11) in fewer Newton iterations (measured 290 against 384; the bench's dt 5 ms beat: 948
// against 1036).
// One beat on the coarse mesh with linear tetrahedra at step dt, first with `on` set in the options
// by `set`, then without; each channel of `channels` agrees between the two within 1e-8 of its peak.
std::array<RunResult, 2> coarse_linear_beats_with_and_without(double dt, void (*set)(LeftVentricle3DOptions&, bool),
                                                            std::initializer_list<const char*> channels) {
  LeftVentricle3DOptions o;
  o.element_order = 1;
  o.bulk_modulus = 1e7;
  o.quadrature_degree = 1;
  o.dt = dt;
  o.max_beats = 1;
  o.periodic_tolerance = 1.0;
  std::array<RunResult, 2> r;
  for (int k = 0; k < 2; ++k) {
    set(o, k == 0);
    LeftVentricle3D lv(o);
    r[k] = lv.run(lv.parameters().nominal());
    EXPECT_TRUE(r[k].status.ok()) << r[k].status.message;
    if (!r[k].status.ok()) return r;
  }
  for (const char* c : channels) {
    const Eigen::VectorXd a = r[0].trajectory.channel(c), b = r[1].trajectory.channel(c);
    EXPECT_EQ(a.size(), b.size());
    if (a.size() != b.size()) continue;
    EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-8 * b.cwiseAbs().maxCoeff()) << c;
    std::printf("%s: largest difference %.2g of the peak\n", c, (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff());
  }
  return r;
}

TEST(LeftVentricle3D, BroydenChordGivesThePlainChordBeatInFewerNewtonIterations) {
  // Broyden alone (the carried factors and the predictor: next test).
  const auto r = coarse_linear_beats_with_and_without(
      0.02, [](LeftVentricle3DOptions& o, bool on) {
        o.broyden = on;
        o.carry_factors = false;
      }, {"V_lv", "P_lv", "P_ar"});
  ASSERT_TRUE(r[0].status.ok() && r[1].status.ok());
  std::printf("Newton iterations: Broyden %d, plain chord %d\n", r[0].info.newton_iterations, r[1].info.newton_iterations);
  EXPECT_LT(r[0].info.newton_iterations, r[1].info.newton_iterations);
}

// Within run(), the factors of the last step's tangent start the next step's chord iterations and
// the first iterate is extrapolated from the last two steps (LeftVentricle3DOptions::carry_factors;
// docs/solvers.md s.1). They change the path of the Newton solves, not their answer: the
// beat agrees with the one that refactorises at every step's start to the Newton tolerance, with
// fewer factorisations and Newton iterations (coarse linear beat at dt 5 ms: 48 against 181
// factorisations, 914 against 948 iterations). advance() does not carry anything from one call to
// the next: stepped through advance(), the carrying simulator gives run()'s beat without carrying,
// bit for bit.
TEST(LeftVentricle3D, CarriedFactorsAndPredictorGiveTheSameBeatWithFewerFactorisations) {
  const auto r = coarse_linear_beats_with_and_without(
      0.005, [](LeftVentricle3DOptions& o, bool on) { o.carry_factors = on; }, {"V_lv", "P_lv", "P_ar", "V_seg05"});
  ASSERT_TRUE(r[0].status.ok() && r[1].status.ok());
  std::printf("carried: %d factorisations, %d Newton iterations; fresh at every step: %d, %d\n",
              r[0].info.factorizations, r[0].info.newton_iterations, r[1].info.factorizations,
              r[1].info.newton_iterations);
  EXPECT_LT(2 * r[0].info.factorizations, r[1].info.factorizations);
  EXPECT_LT(r[0].info.newton_iterations, r[1].info.newton_iterations);

  // advance() through the first 20 steps with carry_factors on: run()'s rows without it.
  LeftVentricle3DOptions o;
  o.element_order = 1;
  o.bulk_modulus = 1e7;
  o.quadrature_degree = 1;
  o.dt = 0.005;
  LeftVentricle3D lv(o);
  const Eigen::VectorXd theta = lv.parameters().nominal();
  model::State s = lv.initial_state(theta);
  for (int k = 1; k <= 20; ++k) {
    ASSERT_TRUE(lv.advance(s, theta, r[1].trajectory.times(k)).ok());
    EXPECT_EQ((lv.sample(s, theta).transpose() - r[1].trajectory.values.row(k)).cwiseAbs().maxCoeff(), 0.0)
        << "step " << k;
  }
}

}  // namespace
}  // namespace sigmaheart::model::fem
