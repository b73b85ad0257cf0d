// The 3D electromechanical LV against the simulator contract (tests/model/simulator_contract.h) on
// the coarse mesh, and beats repeated to periodicity. Slow tier: each contract case runs up to four
// beats (about 20 s of CPU each).
#include "model/fem/electromechanics.h"
#include "model/fem/register.h"
#include "tests/model/map_options.h"
#include "tests/support/expect_between.h"

#include "tests/model/simulator_contract.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {
namespace {

using sigmaheart::model::testing::MapOptions;
using sigmaheart::testing::expect_between;

// Clinical indices of a periodic beat from the channels (V_lv, P_lv, P_ar the first three).
struct BeatIndices {
  double edv = 0, esv = 0, ef = 0;  // [mL], [mL], [%]
  double edp = 0;                   // P_lv at t = 0 (the earliest depolarisation, end-diastole) [mmHg]
  double aortic_max = 0, aortic_min = 0;  // [mmHg]
  double dpdt_max = 0;              // largest difference quotient of P_lv on the output grid [mmHg/s]
};

BeatIndices beat_indices(const RunResult& r) {
  const Eigen::VectorXd V = r.trajectory.values.col(0) * 1e6;             // mL
  const Eigen::VectorXd P = r.trajectory.values.col(1) / 133.322368;      // mmHg
  const Eigen::VectorXd Par = r.trajectory.values.col(2) / 133.322368;    // mmHg
  BeatIndices b;
  b.edv = V.maxCoeff();
  b.esv = V.minCoeff();
  b.ef = 100.0 * (b.edv - b.esv) / b.edv;
  b.edp = P(0);
  b.aortic_max = Par.maxCoeff();
  b.aortic_min = Par.minCoeff();
  for (Eigen::Index i = 1; i < P.size(); ++i)
    b.dpdt_max = std::max(b.dpdt_max, (P(i) - P(i - 1)) / (r.trajectory.times(i) - r.trajectory.times(i - 1)));
  return b;
}

// The healthy adult ranges of docs/models.md s.7 (dP/dt: the textbook 1200-2000 mmHg/s), no margin.
void expect_adult_ranges(const BeatIndices& b) {
  expect_between(b.edv, 83.0, 218.0, "EDV [mL]");
  expect_between(b.esv, 18.0, 82.0, "ESV [mL]");
  expect_between(b.ef, 59.0, 85.0, "EF [%]");
  expect_between(b.aortic_max, 90.0, 130.0, "aortic systolic [mmHg]");
  expect_between(b.aortic_min, 60.0, 85.0, "aortic diastolic [mmHg]");
  EXPECT_LT(b.edp, 16.0);  // t = 0 is end-diastole with healthy activation: EDP below 16 mmHg
  expect_between(b.dpdt_max, 1200.0, 2000.0, "dP/dt max [mmHg/s]");
}

// The lv-3d preset `name` built as a config naming it would build it (its numerics under `numerics`,
// its values over the defaults), and its nominal parameters.
struct PresetModel {
  std::unique_ptr<Simulator> sim;
  Eigen::VectorXd theta;
};

PresetModel preset_model(const std::string& name, const MapOptions& numerics) {
  ModelRegistry registry;
  register_fem_models(registry);
  const ModelSetup* setup = registry.find("lv-3d");
  const Preset* preset = setup ? setup->find_preset(name) : nullptr;
  if (!preset) throw std::logic_error("no lv-3d preset " + name);
  const ModelBuild build = setup->configure(*with_defaults(numerics, preset->numerics));
  ParameterSpace space = build.parameters();
  for (const auto& [parameter, value] : preset->values) space.set_nominal(parameter, value);
  return {build.make(space), space.nominal()};
}

// The `healthy` preset (model/fem/register.cpp): the periodic beat on the coarse mesh with the
// healthy eikonal activation at 20 ms steps lies in the adult ranges of docs/models.md s.7.
TEST(Lv3dPreset, TheHealthyPresetBeatsInTheAdultRanges) {
  const PresetModel m =
      preset_model("healthy", MapOptions({{"mesh", "coarse"}, {"dt", "0.02"}, {"activation", "healthy"}, {"max_beats", "8"}}));
  const RunResult r = m.sim->run(m.theta);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const BeatIndices b = beat_indices(r);
  // Measured: EDV 147.8 mL, ESV 52.8 mL, EF 64.3 %, dP/dt max 1298 mmHg/s (the channel's
  // differences on the 20 ms grid), EDP 6.9 mmHg, aortic 127.1/71.9 mmHg. Bounds: the cited
  // ranges of docs/models.md s.7 (dP/dt: the textbook 1200-2000 mmHg/s).
  expect_adult_ranges(b);
}

// The same preset on the fine mesh with linear tetrahedra (11 340 tetrahedra, the size of the
// issue's cost target; docs/models.md s.4.8 "Linear tetrahedra") at the default 5 ms steps: the
// periodic beat is in the same adult ranges, no bound changed. At 20 ms steps the difference
// quotient of P_lv over 20 ms gave a dP/dt max of 1145 mmHg/s, below the range: a 20 ms secant
// flattens the isovolumic upstroke. Measured 2026-11-27 (3 beats, about 4 minutes of one core):
// EDV 149.2 mL, ESV 53.8 mL, EF 64.0 %, EDP 7.2 mmHg, dP/dt max 1332 mmHg/s, aortic 127.4/71.7 mmHg.
TEST(Lv3dPreset, TheHealthyPresetBeatsInTheAdultRangesOnTheFineLinearMesh) {
  const PresetModel m = preset_model(
      "healthy", MapOptions({{"mesh", "fine"}, {"dt", "0.005"}, {"activation", "healthy"}, {"element_order", "1"},
                             {"bulk_modulus", "1e7"}, {"quadrature_degree", "1"}, {"linear_solver", "umfpack"},
                             {"max_beats", "8"}}));
  const RunResult r = m.sim->run(m.theta);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const BeatIndices b = beat_indices(r);
  std::printf("healthy, fine linear mesh, dt 5 ms: EDV %.1f mL, ESV %.1f mL, EF %.1f %%, EDP %.1f mmHg, aortic "
              "%.1f/%.1f mmHg, dP/dt max %.0f mmHg/s, %d beats\n",
              b.edv, b.esv, b.ef, b.edp, b.aortic_max, b.aortic_min, b.dpdt_max, r.info.beats);
  expect_adult_ranges(b);
}

// The `lbbb-heart-failure` preset (model/fem/register.cpp) with `numerics` over its own: its
// numerics (LBBB activation, dilated geometry) come with it through with_defaults; the periodic beat
// lies in the failing column of docs/models.md s.7 (EDV and ESV above the healthy ranges, HFrEF EF
// 20-40 %, EDP above 16 mmHg, systolic pressure >= 90 mmHg, dP/dt max below 1000 mmHg/s) and the LV
// activation lasts as long as a LBBB QRS (s.4.6: >= 130 ms, Strauss et al. 2011). No margin.
void expect_lbbb_failing_beat(const MapOptions& numerics, const char* label) {
  const PresetModel m = preset_model("lbbb-heart-failure", numerics);
  auto* lv = dynamic_cast<LeftVentricle3D*>(m.sim.get());
  ASSERT_NE(lv, nullptr);
  EXPECT_EQ(lv->options().activation, ActivationSource::kLbbb);
  EXPECT_DOUBLE_EQ(lv->options().geometry.r_short_endo, 0.028);
  const RunResult r = m.sim->run(m.theta);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const BeatIndices b = beat_indices(r);
  const std::vector<double>& td = lv->activation_times();
  const double qrs_ms = 1e3 * (*std::max_element(td.begin(), td.end()) - *std::min_element(td.begin(), td.end()));
  std::printf("lbbb-heart-failure, %s: EDV %.1f mL, ESV %.1f mL, EF %.1f %%, EDP %.1f mmHg, aortic %.1f/%.1f mmHg, "
              "dP/dt max %.0f mmHg/s, LV activation %.1f ms, %d beats\n",
              label, b.edv, b.esv, b.ef, b.edp, b.aortic_max, b.aortic_min, b.dpdt_max, qrs_ms, r.info.beats);
  EXPECT_GT(b.edv, 218.0);
  EXPECT_GT(b.esv, 82.0);
  expect_between(b.ef, 20.0, 40.0, "EF [%]");
  EXPECT_GT(b.edp, 16.0);
  EXPECT_GE(b.aortic_max, 90.0);
  EXPECT_LT(b.dpdt_max, 1000.0);
  EXPECT_GE(qrs_ms, 130.0);
}

// On the coarse mesh at 20 ms steps. Measured: EDV 266.3 mL, ESV 199.5 mL, EF 25.1 %, EDP 18.0 mmHg,
// aortic 98.9/58.3 mmHg, dP/dt max 622 mmHg/s (differences on the 20 ms grid), LV activation
// 137.3 ms, periodic after 3 beats.
TEST(Lv3dPreset, TheLbbbHeartFailurePresetBeatsInTheFailingRanges) {
  expect_lbbb_failing_beat(MapOptions({{"mesh", "coarse"}, {"dt", "0.02"}, {"max_beats", "8"}}), "coarse mesh, dt 20 ms");
}

// On the fine linear mesh at the default 5 ms steps (as the healthy one above). Measured
// (2026-11-27, 264 s): EDV 264.4 mL, ESV 195.7 mL, EF 26.0 %, EDP 18.4 mmHg (P_lv at t = 0;
// `simulate`'s summary gives 17.9 at the onset of the end-diastolic plateau), aortic 101.0/59.4 mmHg,
// dP/dt max 683 mmHg/s, LV activation 141.9 ms, periodic after 3 beats (3290 Newton iterations, no
// step cut).
TEST(Lv3dPreset, TheLbbbHeartFailurePresetBeatsInTheFailingRangesOnTheFineLinearMesh) {
  expect_lbbb_failing_beat(MapOptions({{"mesh", "fine"}, {"dt", "0.005"}, {"element_order", "1"}, {"bulk_modulus", "1e7"},
                                       {"quadrature_degree", "1"}, {"linear_solver", "umfpack"}, {"max_beats", "8"}}),
                           "fine linear mesh, dt 5 ms");
}

LeftVentricle3DOptions coarse_one_beat() {
  LeftVentricle3DOptions o;
  o.dt = 0.01;
  o.max_beats = 1;
  o.periodic_tolerance = 1.0;
  return o;
}

struct FirstBeat {
  double edv, esv, ef;  // [m^3], [m^3], [-]
};

// The first beat of coarse_one_beat() on `mesh` with elements of `order`; linear ones with the
// pressure stabilisation `alpha` (MechanicsOptions::pressure_stabilization).
FirstBeat first_beat_indices(const std::string& mesh, int order, double alpha = 0.0) {
  LeftVentricle3DOptions o = with_mesh_preset(coarse_one_beat(), mesh);
  o.element_order = order;
  o.bulk_modulus = order == 1 ? 1e7 : 0.0;
  o.quadrature_degree = order == 1 ? 1 : 2;
  o.pressure_stabilization = alpha;
  o.linear_solver = linear_solver_available(LinearSolver::kUmfPack) ? LinearSolver::kUmfPack : LinearSolver::kSparseLU;
  LeftVentricle3D lv(o);
  const RunResult r = lv.run(lv.parameters().nominal());
  EXPECT_TRUE(r.status.ok()) << mesh << " P" << order << ": " << r.status.message;
  const Eigen::VectorXd V = r.trajectory.channel("V_lv"), P = r.trajectory.channel("P_lv");
  const FirstBeat x{V.maxCoeff(), V.minCoeff(), 1.0 - V.minCoeff() / V.maxCoeff()};
  std::printf("%-6s P%d alpha %.2g (%5d tets): EDV %.2f mL, ESV %.2f mL, EF %.2f %%, peak P %.2f mmHg\n", mesh.c_str(),
              order, alpha, lv.mesh().n_tets(), x.edv * 1e6, x.esv * 1e6, 100 * x.ef, P.maxCoeff() / 133.322);
  return x;
}

// Errors of the linear beats on the coarse, medium and fine meshes against the medium P2-P1 beat:
// |EDV/EDV_ref - 1|, |ESV/ESV_ref - 1|, |EF - EF_ref|, with the observed orders printed.
std::vector<Eigen::Vector3d> linear_beat_errors(double alpha) {
  const FirstBeat ref = first_beat_indices("medium", 2);
  std::vector<Eigen::Vector3d> err;
  for (const char* mesh : {"coarse", "medium", "fine"}) {
    const FirstBeat x = first_beat_indices(mesh, 1, alpha);
    err.emplace_back(std::abs(x.edv / ref.edv - 1), std::abs(x.esv / ref.esv - 1), std::abs(x.ef - ref.ef));
  }
  const char* names[] = {"EDV", "ESV", "EF"};
  for (int i = 0; i < 3; ++i)
    std::printf("alpha %.2g %s: errors %.4f %.4f %.4f, observed orders %.2f %.2f\n", alpha, names[i], err[0][i],
                err[1][i], err[2][i], std::log(err[0][i] / err[1][i]) / std::log(24.0 / 12.0),
                std::log(err[1][i] / err[2][i]) / std::log(36.0 / 24.0));
  return err;
}

// The observed orders of `err` (linear_beat_errors): at least 1 from coarse to medium for the
// volumes, at least 1.5 from medium to fine for all three; and the fine errors below `fine_bound`.
void expect_second_order(const std::vector<Eigen::Vector3d>& err, const Eigen::Vector3d& fine_bound) {
  const char* names[] = {"EDV", "ESV", "EF"};
  for (int i = 0; i < 3; ++i) {
    const double order_cm = std::log(err[0][i] / err[1][i]) / std::log(24.0 / 12.0);
    const double order_mf = std::log(err[1][i] / err[2][i]) / std::log(36.0 / 24.0);
    if (i < 2) {
      EXPECT_GE(order_cm, 1.0) << names[i];
    }
    EXPECT_GE(order_mf, 1.5) << names[i];
    EXPECT_LT(err[2][i], fine_bound[i]) << names[i];
  }
}

// Linear tetrahedra (element_order 1, P1-P1 with a 10 MPa bulk modulus, one quadrature point;
// docs/models.md s.4.8, "Linear tetrahedra") converge to the Taylor-Hood beat: the first beat from
// the inflation at dt 10 ms on the coarse, medium and fine meshes (396, 3312, 11 340 tetrahedra;
// element size h ~ 1/12, 1/24, 1/36 around) against P2-P1 on the medium mesh (which moves EDV by
// 0.2 % from the coarse mesh: its own error is an order below the P1 ones). EDV, ESV and EF are
// functionals of the displacement, which converge as h^2 for linear elements (Brenner & Scott 2008,
// The Mathematical Theory of Finite Element Methods, s.5.7). From medium to fine the observed
// order must be at least 1.5 for all three; from coarse to medium at least 1 for the volumes only:
// EF = 1 - ESV/EDV takes the difference of two same-sign relative errors, which cancel on the
// coarse mesh (EF error 1.1 points there, 1.8 on the medium mesh). Measured 2026-11-26: fine P1
// EDV -1.5 %, ESV -2.6 %, EF +0.6 points from the medium P2-P1 beat; orders coarse-medium /
// medium-fine EDV 1.86 / 1.91, ESV 1.15 / 2.16, EF - / 2.53. About 4 min of CPU.
TEST(LeftVentricle3DSlow, LinearTetrahedraConvergeToTheTaylorHoodBeat) {
  expect_second_order(linear_beat_errors(0.0), Eigen::Vector3d::Constant(1.0));
}

// With the pressure stabilisation of the linear tetrahedra (pressure_stabilization 0.1, the value
// whose iterative solves stop growing with the mesh: docs/models.md s.4.4) the beat converges to the
// same Taylor-Hood beat. Measured 2026-11-27: fine P1 EDV -1.24 %, ESV -1.95 %, EF +0.44 points from
// the P2-P1 beat (unstabilised: -1.5 %, -2.6 %, +0.6: the stabilisation relieves some of P1-P1's
// locking); orders coarse-medium / medium-fine EDV 1.90 / 1.99, ESV 1.11 / 2.24, EF - / 2.67. The
// test asserts the orders as above and that the fine errors stay below the unstabilised ones of
// the test above (2026-11-26 numbers: 0.0152, 0.0256, 0.0064). About 4 min of CPU.
TEST(LeftVentricle3DSlow, StabilisedLinearTetrahedraConvergeToTheTaylorHoodBeat) {
  expect_second_order(linear_beat_errors(0.1), Eigen::Vector3d(0.0152, 0.0256, 0.0064));
}

// Beats repeat until the beat-start state changes by less than 1e-3 (relative) from one beat to
// the next; the count and the EF of the periodic beat are reported.
TEST(LeftVentricle3DSlow, BeatsRepeatToPeriodicity) {
  LeftVentricle3DOptions o = coarse_one_beat();
  o.max_beats = 12;
  o.periodic_tolerance = 1e-3;
  LeftVentricle3D lv(o);
  const RunResult r = lv.run(lv.parameters().nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_LE(r.info.periodicity_change, 1e-3);
  EXPECT_GE(r.info.beats, 2);
  const Eigen::VectorXd V = r.trajectory.channel("V_lv");
  EXPECT_LT(std::abs(V(V.size() - 1) - V(0)), 1e-3 * V(0));
  std::printf("periodic after %d beats (change %.2e): EDV %.1f mL, ESV %.1f mL\n", r.info.beats,
              r.info.periodicity_change, V.maxCoeff() * 1e6, V.minCoeff() * 1e6);
}

}  // namespace
}  // namespace sigmaheart::model::fem

namespace sigmaheart::testing {
namespace {

INSTANTIATE_TEST_SUITE_P(Lv3d, SimulatorContract,
                         ::testing::Values(ContractCase{"lv_3d_coarse",
                                                        [] {
                                                          return std::make_unique<model::fem::LeftVentricle3D>(
                                                              model::fem::coarse_one_beat());
                                                        },
                                                        0.1, 0.3, 0.05}),
                         contract_case_name);

}  // namespace
}  // namespace sigmaheart::testing
