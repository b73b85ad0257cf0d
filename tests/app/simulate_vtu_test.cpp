// `sigmaheart simulate --vtu` (app/commands/simulate.cpp, docs/models.md s.4.8): the last beat of
// any model that offers fields (model::FieldOutput) as binary VTU files with a .pvd index, one per
// kept step: lv-3d with the fields people look at, and a stand-in model app/ knows nothing of; a
// lumped model asks for fields it does not have: exit 2 before any work.
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "app/errors.h"
#include "app/io/hdf5_writer.h"
#include "app/io/observation_file.h"
#include "model/fem/mesh.h"
#include "model/fem/vtk_output.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <regex>
#include <string>

namespace sigmaheart::testing {
namespace {

// The command line with the executable's models (lv-3d is registered by app/blackbox).
CliRun cli3d(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, app::blackbox::cli_models());
  return {code, out.str(), err.str()};
}

// A model app/ has never heard of, with fields: the beat of "test-beat" (BeatStandIn), and as its
// state one tetrahedron whose first vertex moves with the volume; its VTU carries the point data
// `volume_fraction` (V / V_ed). It reports each of its samples to the step observer.
class FieldStandIn final : public model::Simulator, public model::FieldOutput {
 public:
  explicit FieldStandIn(model::ParameterSpace p) : beat_(std::move(p), 21) {}
  std::string name() const override { return "test-fields"; }
  const model::ParameterSpace& parameters() const override { return beat_.parameters(); }
  std::vector<model::Channel> channels() const override { return beat_.channels(); }
  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override {
    model::RunResult r = beat_.run(theta);
    for (int k = 0; observer_ && k < r.trajectory.samples(); ++k) {
      model::State s;
      s.time = r.trajectory.times(k);
      s.x = Eigen::VectorXd::Constant(1, r.trajectory.values(k, 0) / theta(0));
      observer_(1, s.time, s);
    }
    return r;
  }
  std::unique_ptr<model::Simulator> clone() const override { return std::make_unique<FieldStandIn>(parameters()); }
  model::FieldOutput* fields() override { return this; }
  void observe_steps(StepObserver observer) override { observer_ = std::move(observer); }
  void write_fields(const model::State& state, std::ostream& os) override {
    model::fem::Mesh mesh;
    mesh.nodes = Eigen::MatrixX3d{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    mesh.nodes(0, 0) = -state.x(0);
    mesh.n_vertices = 4;
    mesh.tets = Eigen::MatrixXi{{0, 1, 2, 3}};
    model::fem::VtuDocument doc(mesh);
    doc.add_point_data("volume_fraction", Eigen::VectorXd::Constant(4, state.x(0)));
    doc.write(os);
  }

 private:
  BeatStandIn beat_;
  StepObserver observer_;
};

CliRun cli_fields(const std::vector<std::string>& args) {
  static const model::ModelRegistry registry = [] {
    model::ModelRegistry r = model::builtin_models();
    r.add(model::ModelSetup{"test-fields", "stand-in with fields", [](const model::OptionReader&) {
                              return model::ModelBuild(BeatStandIn::defaults(), [](const model::ParameterSpace& p) {
                                return std::unique_ptr<model::Simulator>(std::make_unique<FieldStandIn>(p));
                              });
                            }});
    return r;
  }();
  std::ostringstream out, err;
  const int code = app::run_cli(args, out, err, registry);
  return {code, out.str(), err.str()};
}

// One beat at 40 ms steps on the coarse mesh (22 steps), healthy eikonal activation.
std::string lv3d_config() {
  return "name: beat\nsimulator:\n  model: lv-3d\n"
         "  numerics: {mesh: coarse, dt: 40 ms, activation: healthy, min_beats: 1, max_beats: 1,"
         " periodic_tolerance: 1.0}\n";
}

TEST(SimulateVtu, WritesTheLastBeatAsAParaViewTimeSeriesThatObserveReadsBack) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "beat.yaml", lv3d_config());
  const CliRun r = cli3d({"simulate", cfg.string(), "-o", (dir / "beat.h5").string(), "--vtu", (dir / "vtu").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("ParaView steps of the last beat"), std::string::npos) << r.out;

  // The index lists every step of the beat, times from 0 to the period (0.85 s).
  const std::string pvd = read_file(dir / "vtu" / "beat.pvd");
  const std::regex entry(R"re(<DataSet timestep="([^"]+)" group="" part="0" file="(beat_\d{4}\.vtu)"/>)re");
  std::vector<std::pair<double, std::string>> steps;
  for (auto it = std::sregex_iterator(pvd.begin(), pvd.end(), entry); it != std::sregex_iterator(); ++it)
    steps.emplace_back(std::stod((*it)[1]), (*it)[2]);
  ASSERT_EQ(steps.size(), 23u);  // t = 0 and 22 steps (0.85 s / 40 ms, the last one shorter)
  EXPECT_EQ(steps.front().first, 0.0);
  EXPECT_NEAR(steps.back().first, 0.85, 1e-12);

  // Every file is a binary VTU of the coarse mesh with the documented arrays.
  for (const auto& [t, file] : steps) {
    const std::string vtu = read_file(dir / "vtu" / file);
    ASSERT_NE(vtu.find("<AppendedData encoding=\"raw\">"), std::string::npos) << file;
    EXPECT_NE(vtu.find("NumberOfCells=\"396\""), std::string::npos) << file;
    for (const char* name : {"displacement", "hydrostatic_pressure", "activation_time", "active_stress",
                             "fibre_strain", "fibre", "aha_segment", "endocardium", "base"})
      EXPECT_NE(vtu.find("Name=\"" + std::string(name) + "\""), std::string::npos) << file << " " << name;
  }
#ifdef SIGMAHEART_HAVE_VTK
  // `sigmaheart observe` reads the series back (docs/models.md s.5.1) and gives the simulator's own
  // V_lv and V_seg01..17 (the segments assigned on the undeformed mesh, the simulator's frame:
  // endocardial apex (0, 0, -45 mm), base ring at z = 13.2 mm, phi = 0 along +x). Here, not in
  // observe_command_test.cpp, so that the fast tier runs the beat once.
  const std::string observe =
      "name: beat-observed\nobserve:\n  meshes: vtu/beat.pvd\n  units: m\n"
      "  displacement: {array: displacement, points: deformed}\n  reference: undeformed\n"
      "  endocardium: {point_label: endocardium}\n"
      "  landmarks: {apex: [0, 0, -0.045], base: rim, rv_anterior: [0.025, 0, 0], tolerance: 1 mm}\n";
  write_file(dir / "observe.yaml", observe);
  const CliRun o = cli3d({"observe", (dir / "observe.yaml").string(), "-o", (dir / "obs.csv").string()});
  ASSERT_EQ(o.code, 0) << o.err << o.out;
  app::io::Hdf5Reader h5(dir / "beat.h5");
  const app::io::ObservationCurves c = app::io::read_observation_csv(dir / "obs.csv");
  ASSERT_EQ(c.trajectory.samples(), 23);
  double worst = 0;
  for (size_t j = 0; j < c.trajectory.channels.size(); ++j) {
    const std::string& name = c.trajectory.channels[j].name;
    const Eigen::VectorXd sim = h5.read_vector("/trajectories/simulated/" + name) * 1e-6;  // mL -> m^3
    const Eigen::VectorXd got = c.trajectory.values.col(static_cast<Eigen::Index>(j));
    for (Eigen::Index k = 0; k < got.size(); ++k) {
      // Relative, or against 1e-6 of V_lv for the empty segment 17.
      const double err = std::abs(got(k) - sim(k)) / std::max(std::abs(sim(k)), 1e-6 * c.trajectory.values(k, 0));
      worst = std::max(worst, err);
      EXPECT_LE(err, 1e-6) << name << " frame " << k << ": " << got(k) << " against " << sim(k);
    }
  }
  std::printf("observe on the simulator's series: largest relative difference %.2e over V_lv, V_seg01..17\n", worst);
  // Without the label the endocardium is found as the inner boundary: the same faces.
  std::string inner = observe;
  inner.erase(inner.find("  endocardium: {point_label: endocardium}\n"), 42);
  write_file(dir / "inner.yaml", inner);
  const CliRun oi = cli3d({"observe", (dir / "inner.yaml").string(), "-o", (dir / "inner.csv").string()});
  ASSERT_EQ(oi.code, 0) << oi.err;
  EXPECT_EQ(app::io::read_observation_csv(dir / "inner.csv").trajectory.values, c.trajectory.values);
#endif
}

// A beat whose Newton iterations are capped at 8 without step cuts diverges in its second step
// (t = 0.08 s, the isovolumic contraction): the beat up to the first step is still written, its
// curves and ParaView steps alike, with status "diverged" and no indices (exit 1).
TEST(SimulateVtu, ABeatThatDivergesIsWrittenUpToItsLastStep) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "beat.yaml", lv3d_config());
  const CliRun r = cli3d({"--log-level", "off", "simulate", cfg.string(), "-o", (dir / "beat.h5").string(), "--vtu",
                          (dir / "vtu").string(), "--set", "numerics.newton_max_iterations=8", "--set",
                          "numerics.max_step_cuts=0"});
  EXPECT_EQ(r.code, app::kExitRuntimeFailure);
  EXPECT_NE(r.err.find("failed (diverged): Newton did not converge at t = 0.08 s"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the beat up to t = 0.04 s of beat 1 is written to"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("wrote 2 ParaView steps of the failing beat"), std::string::npos) << r.out;
  const std::string pvd = read_file(dir / "vtu" / "beat.pvd");
  EXPECT_NE(pvd.find("timestep=\"0.04\""), std::string::npos) << pvd;
  app::io::Hdf5Reader f((dir / "beat.h5").string());
  EXPECT_EQ(f.string_attribute("/summary", "status"), "diverged");
  const Eigen::VectorXd t = f.read_vector("/trajectories/simulated/time");
  ASSERT_EQ(t.size(), 2);
  EXPECT_NEAR(t(1), 0.04, 1e-12);
  EXPECT_EQ(f.read_vector("/trajectories/simulated/V_seg17").size(), 2);
}

TEST(SimulateVtu, AnyModelThatOffersFieldsGetsItsBeatAsAParaViewSeries) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "f.yaml", "name: f\nsimulator:\n  model: test-fields\n");
  const CliRun r = cli_fields({"simulate", cfg.string(), "-o", (dir / "f.h5").string(), "--vtu", (dir / "vtu").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string pvd = read_file(dir / "vtu" / "f.pvd");
  const std::regex entry(R"re(<DataSet timestep="([^"]+)" group="" part="0" file="(f_\d{4}\.vtu)"/>)re");
  std::vector<std::pair<double, std::string>> steps;
  for (auto it = std::sregex_iterator(pvd.begin(), pvd.end(), entry); it != std::sregex_iterator(); ++it)
    steps.emplace_back(std::stod((*it)[1]), (*it)[2]);
  ASSERT_EQ(steps.size(), 21u);  // every sample of the beat, 0 to 0.8 s
  EXPECT_EQ(steps.front().first, 0.0);
  EXPECT_NEAR(steps.back().first, 0.8, 1e-12);
  for (const auto& [t, file] : steps) {
    const std::string vtu = read_file(dir / "vtu" / file);
    EXPECT_NE(vtu.find("<DataArray type=\"Float64\" Name=\"volume_fraction\""), std::string::npos) << file;
  }
  EXPECT_EQ(temporaries_in(dir / "vtu"), 0);
}

TEST(SimulateVtu, ALumpedModelHasNoFieldsAndExitsTwoBeforeRunning) {
  const auto dir = scratch_dir();
  const auto cfg = write_file(dir / "sphere.yaml", "name: s\nsimulator:\n  model: lumped-sphere\n");
  const CliRun r = cli({"simulate", cfg.string(), "-o", (dir / "s.h5").string(), "--vtu", (dir / "vtu").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("offers no spatial fields"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "s.h5"));

  // A file where the directory should go.
  const auto file = write_file(dir / "taken", "x");
  const CliRun f = cli({"simulate", cfg.string(), "--vtu", file.string()});
  EXPECT_EQ(f.code, 2);
  EXPECT_NE(f.err.find("expected a directory"), std::string::npos) << f.err;
}

// The configs of experiments/3d-twin (README.md there) stay valid: model, numerics, zones, data.
TEST(ThreeDTwin, TheExperimentsConfigsValidate) {
  for (const char* name : {"calibrate-3d.yaml", "personalize-3d.yaml", "personalize-lumped-from-3d.yaml"}) {
    const std::string path = std::string(SIGMAHEART_SOURCE_DIR) + "/experiments/3d-twin/" + name;
    const CliRun r = cli3d({"validate", path});
    EXPECT_EQ(r.code, 0) << name << ": " << r.err;
  }
}

}  // namespace
}  // namespace sigmaheart::testing
