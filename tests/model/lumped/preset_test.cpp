// The presets of the lumped sphere (model/lumped/register.cpp, docs/models.md s.7) against
// published ranges: the healthy beat must look like a normal adult ventricle, the heart-failure
// beat like a dilated HFrEF ventricle with raised filling pressure. Every index is computed here
// from the channels of the periodic beat (V_lv, P_lv, P_ar, P_at, q_at, phase), not taken from
// the simulator's own summaries.
#include "model/lumped/sphere.h"

#include "model/registry.h"
#include "model/units.h"
#include "tests/support/expect_between.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <string>

namespace sigmaheart::model::lumped {
namespace {

using sigmaheart::testing::expect_between;
using units::kMilliLitre;
using units::kMmHg;

const Preset& sphere_preset(const std::string& name) {
  const ModelSetup* setup = builtin_models().find("lumped-sphere");
  if (setup == nullptr) throw std::logic_error("lumped-sphere is not registered");
  const Preset* preset = setup->find_preset(name);
  if (preset == nullptr) throw std::logic_error("no preset " + name);
  return *preset;
}

ParameterSpace preset_parameters(const std::string& name) {
  ParameterSpace space = LumpedSphere::default_parameters();
  for (const auto& [parameter, value] : sphere_preset(name).values) space.set_nominal(parameter, value);
  return space;
}

// Indices of one beat, in clinical units.
struct Beat {
  double edv = 0, esv = 0, ef = 0;  // [mL], [mL], [%]
  double sbp = 0, dbp = 0;          // aortic (proximal arterial) max and min [mmHg]
  double edp = 0;                   // LV pressure at end-diastole (the largest volume) [mmHg]
  double ivrt = 0;                  // isovolumic relaxation time [ms]
  double e_wave = 0, a_wave = 0;    // peak mitral inflow, early and atrial [mL/s]
};

// IVRT is the time from aortic valve closure to mitral valve opening: the length of the phase-3
// run (phase 2 ejection -> 3 isovolumic relaxation -> 0 filling), known to one output step.
// E and A are the peaks of mitral inflow before and during the atrial kick; the kick starts where
// the prescribed atrial pressure first rises above its baseline. Echocardiography measures E and
// A as velocities through the mitral orifice; with one orifice area for both waves the ratio of
// the peak flows is the same E/A.
Beat measure(const Trajectory& tr) {
  const Eigen::VectorXd V = tr.channel("V_lv") / kMilliLitre;
  const Eigen::VectorXd P = tr.channel("P_lv") / kMmHg;
  const Eigen::VectorXd P_ar = tr.channel("P_ar") / kMmHg;
  const Eigen::VectorXd P_at = tr.channel("P_at");
  const Eigen::VectorXd q_at = tr.channel("q_at") / kMilliLitre;
  const Eigen::VectorXd phase = tr.channel("phase");
  Beat b;
  Eigen::Index i_ed = 0;
  b.edv = V.maxCoeff(&i_ed);
  b.esv = V.minCoeff();
  b.ef = 100.0 * (b.edv - b.esv) / b.edv;
  b.sbp = P_ar.maxCoeff();
  b.dbp = P_ar.minCoeff();
  b.edp = P(i_ed);

  double closure = -1.0, opening = -1.0;
  for (Eigen::Index k = 1; k < tr.samples(); ++k) {
    if (phase(k) == 3.0 && phase(k - 1) == 2.0) closure = tr.times(k);
    if (phase(k) == 0.0 && phase(k - 1) == 3.0) opening = tr.times(k);
  }
  EXPECT_GT(closure, 0.0) << "no aortic valve closure in the beat";
  EXPECT_GT(opening, closure) << "no mitral opening after the aortic closure";
  b.ivrt = 1e3 * (opening - closure);

  const double baseline = P_at.minCoeff();
  Eigen::Index kick = tr.samples();
  for (Eigen::Index k = 0; k < tr.samples(); ++k) {
    if (tr.times(k) > opening && P_at(k) > baseline * (1.0 + 1e-9)) {
      kick = k;
      break;
    }
  }
  EXPECT_LT(kick, tr.samples()) << "no atrial kick after the mitral opening";
  b.e_wave = q_at.head(kick).maxCoeff();
  b.a_wave = q_at.tail(tr.samples() - kick).maxCoeff();
  return b;
}

Beat run_preset(const std::string& name) {
  const ParameterSpace space = preset_parameters(name);
  LumpedSphere sim({}, space);
  const RunResult r = sim.run(space.nominal());
  EXPECT_TRUE(r.status.ok()) << name << ": " << r.status.message;
  return measure(r.trajectory);
}

// Normal adult ranges (mean +- 2 SD of the cited healthy cohorts):
// - EDV, ESV: steady-state free-precession CMR, Hudsmith et al. 2005 (J Cardiovasc Magn Reson
//   7:775), women 135 +- 26 / 42 +- 12 mL, men 160 +- 29 / 50 +- 16 mL: EDV 83-218 mL, ESV 18-82 mL.
// - EF: CMR, Framingham offspring, Chuang et al. 2014 (J Magn Reson Imaging 39:895), women
//   73 +- 6 %, men 71 +- 6 %: 59-85 %.
// - IVRT, E/A: Nagueh et al. 2009 (J Am Soc Echocardiogr 22:107, Table 3; kept in the 2016 update,
//   J Am Soc Echocardiogr 29:277), ages 21-40: IVRT 67 +- 8 ms, E/A 1.53 +- 0.40; ages 41-60:
//   74 +- 7 ms, 1.28 +- 0.25: IVRT 51-88 ms, E/A 0.73-2.33. An IVRT above and an E/A below these is
//   the impaired-relaxation pattern (grade I, E/A <= 0.8 in Nagueh et al. 2016).
// - Arterial pressure: "optimal" or "normal" office pressure, below 130/85 mmHg (Williams et al.
//   2018, ESC/ESH guidelines, Eur Heart J 39:3021, Table 3), above the usual hypotension limits
//   90/60 mmHg.
// - End-diastolic pressure: below the 16 mmHg that marks raised LV filling pressure (Paulus et al.
//   2007, Eur Heart J 28:2539).
TEST(LumpedSpherePresets, HealthyBeatLiesInTheNormalAdultRanges) {
  const Beat b = run_preset("healthy");
  expect_between(b.edv, 83.0, 218.0, "EDV [mL]");
  expect_between(b.esv, 18.0, 82.0, "ESV [mL]");
  expect_between(b.ef, 59.0, 85.0, "EF [%]");
  expect_between(b.ivrt, 51.0, 88.0, "IVRT [ms]");
  expect_between(b.e_wave / b.a_wave, 0.73, 2.33, "E/A");
  expect_between(b.sbp, 90.0, 130.0, "systolic aortic pressure [mmHg]");
  expect_between(b.dbp, 60.0, 85.0, "diastolic aortic pressure [mmHg]");
  expect_between(b.edp, 3.0, 16.0, "EDP [mmHg]");
}

// HFrEF, dilated, with raised filling pressure:
// - EF below 40 % (Ponikowski et al. 2016, ESC heart-failure guidelines, Eur Heart J 37:2129),
//   and not below 20 % for the moderate failure the preset stands for ("EF ~30 %").
// - Dilated: EDV and ESV above the healthy upper limits (218 and 82 mL, Hudsmith et al. 2005).
// - Raised filling pressure: EDP above 16 mmHg (Paulus et al. 2007) and a restrictive mitral
//   inflow, E/A >= 2 (grade III, Nagueh et al. 2016).
// - Not in shock: systolic pressure at least 90 mmHg (Ponikowski et al. 2016, cardiogenic shock).
TEST(LumpedSpherePresets, HeartFailureBeatIsADilatedHFrEFWithRaisedFillingPressure) {
  const Beat b = run_preset("heart-failure");
  expect_between(b.ef, 20.0, 40.0, "EF [%]");
  EXPECT_GT(b.edv, 218.0) << "EDV [mL]";
  EXPECT_GT(b.esv, 82.0) << "ESV [mL]";
  EXPECT_GT(b.edp, 16.0) << "EDP [mmHg]";
  EXPECT_GE(b.e_wave / b.a_wave, 2.0) << "E/A";
  EXPECT_GE(b.sbp, 90.0) << "systolic aortic pressure [mmHg]";
}

// The defaults of LumpedSphere::default_parameters() relax slowly (k_RS 20 1/s): their beat has
// the impaired-relaxation pattern the healthy preset corrects (measured IVRT 141 ms, E/A 0.60).
// Guards the measurement itself: the IVRT and E/A above can tell the two patterns apart.
TEST(LumpedSpherePresets, SlowRelaxationShowsTheImpairedRelaxationPattern) {
  ParameterSpace space = preset_parameters("healthy");
  space.set_nominal("k_RS", 20.0);
  space.set_nominal("P_at_kick", 533.3);
  LumpedSphere sim({}, space);
  const RunResult r = sim.run(space.nominal());
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const Beat b = measure(r.trajectory);
  EXPECT_GT(b.ivrt, 100.0);
  EXPECT_LT(b.e_wave / b.a_wave, 0.8);
}

// configs/healthy.yaml and configs/heart-failure.yaml write every value of their preset out: the
// files and the registered presets must not drift apart.
TEST(LumpedSpherePresets, ConfigFilesHoldThePresetValues) {
  for (const auto& [name, file] : {std::pair<std::string, std::string>{"healthy", "healthy.yaml"},
                                   {"heart-failure", "heart-failure.yaml"}}) {
    const YAML::Node config =
        YAML::LoadFile(std::string(SIGMAHEART_SOURCE_DIR) + "/configs/" + file);
    const YAML::Node values = config["simulator"]["parameters"];
    const ParameterSpace space = preset_parameters(name);
    ASSERT_EQ(static_cast<int>(values.size()), space.size()) << file;
    for (int i = 0; i < space.size(); ++i) {
      ASSERT_TRUE(values[space[i].name]) << file << " has no " << space[i].name;
      EXPECT_DOUBLE_EQ(values[space[i].name].as<double>(), space[i].nominal)
          << file << ": " << space[i].name;
    }
  }
}

}  // namespace
}  // namespace sigmaheart::model::lumped
