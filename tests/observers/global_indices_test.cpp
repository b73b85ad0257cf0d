#include "observers/global_indices.h"

#include "analytic_beat.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

namespace sigmaheart::observers {
namespace {

using testing::CosineBeat;
using testing::kPi;
using testing::sample_beat;

std::map<std::string, double> indices_of(const model::Trajectory& tr,
                                         GlobalIndicesOptions options = {}) {
  const GlobalIndices gi(std::move(options), tr.channels);
  Eigen::VectorXd z(gi.size());
  const auto status = gi.observe(tr, z);
  EXPECT_TRUE(status.ok()) << status.message;
  std::map<std::string, double> out;
  const auto outs = gi.outputs();
  for (size_t i = 0; i < outs.size(); ++i) out[outs[i].name] = z(static_cast<Eigen::Index>(i));
  return out;
}

// Measured frames: the last one is one frame before the next beat.
GlobalIndicesOptions open_frames() {
  GlobalIndicesOptions o;
  o.beat = measured_frames();
  return o;
}

TEST(GlobalIndices, ListsEveryIndexWithItsSiUnitWhenVolumeAndPressuresArePresent) {
  const CosineBeat beat;
  const auto tr = sample_beat(beat.channels(), beat.period, 100, true);
  const GlobalIndices gi({}, tr.channels);
  const std::vector<std::string> expected = {
      "EDV",   "ESV",      "EF",       "SV",  "dVdt_min", "dVdt_max", "t_ES",
      "ejection_duration", "P_max", "dPdt_max", "dPdt_min", "EDP", "P_ar_sys", "P_ar_dia"};
  const auto outs = gi.outputs();
  ASSERT_EQ(outs.size(), expected.size());
  for (size_t i = 0; i < outs.size(); ++i) EXPECT_EQ(outs[i].name, expected[i]);
  EXPECT_EQ(outs[2].unit, "1");
  EXPECT_EQ(outs[4].unit, "m^3/s");
  EXPECT_EQ(outs[9].unit, "Pa/s");
}

TEST(GlobalIndices, OffersOnlyVolumeIndicesWithoutPressureChannels) {
  const std::vector<model::Channel> channels = {{"V_lv", "m^3", ""}};
  const GlobalIndices gi({}, channels);
  EXPECT_EQ(gi.size(), 8);
}

TEST(GlobalIndices, RejectsUnknownIndexWithDidYouMean) {
  GlobalIndicesOptions o;
  o.indices = {"EDV", "ESF"};
  try {
    GlobalIndices gi(o, {{"V_lv", "m^3", ""}});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'ESV'"), std::string::npos) << e.what();
  }
  o.indices = {"P_max"};
  EXPECT_THROW(GlobalIndices(o, {{"V_lv", "m^3", ""}}), std::invalid_argument);
}

TEST(GlobalIndices, ReproducesAnalyticIndicesOfACosineBeatOnAFineGrid) {
  CosineBeat b;
  b.t_ed = 0.1234;  // between samples: the parabola refinement is exercised
  const auto idx = indices_of(sample_beat(b.channels(), b.period, 800, true));  // 1 ms, closed
  const double w = b.w();
  // Sample extrema at 1 ms: off by at most A (w h / 2)^2 / 2 = 0.0003 mL.
  EXPECT_NEAR(idx.at("EDV"), b.v0 + b.amplitude, 1e-9);
  EXPECT_NEAR(idx.at("ESV"), b.v0 - b.amplitude, 1e-9);
  EXPECT_NEAR(idx.at("SV"), 2 * b.amplitude, 2e-9);
  EXPECT_NEAR(idx.at("EF"), 2 * b.amplitude / (b.v0 + b.amplitude), 1e-5);
  // Centred differences underestimate a sine's slope by sinc(w h) - 1 = -1.6e-5 at h = 1 ms.
  EXPECT_NEAR(idx.at("dVdt_min"), -b.amplitude * w, 5e-5 * b.amplitude * w);
  EXPECT_NEAR(idx.at("dVdt_max"), b.amplitude * w, 5e-5 * b.amplitude * w);
  EXPECT_NEAR(idx.at("t_ES"), b.period / 2, 1e-5);
  // V falls from EDV - 5 % SV to ESV + 5 % SV over (pi - 2 acos(0.9)) / w.
  EXPECT_NEAR(idx.at("ejection_duration"), b.ejection(), 1e-5);
  EXPECT_NEAR(idx.at("P_max"), b.p0 + b.pa, 0.1);
  EXPECT_NEAR(idx.at("dPdt_max"), b.pa * w, 5e-5 * b.pa * w);
  EXPECT_NEAR(idx.at("dPdt_min"), -b.pa * w, 5e-5 * b.pa * w);
  EXPECT_NEAR(idx.at("EDP"), b.pressure(b.ed_onset()), 0.5);
  EXPECT_NEAR(idx.at("P_ar_sys"), b.ar0 + b.ara, 0.1);
  EXPECT_NEAR(idx.at("P_ar_dia"), b.ar0 - b.ara, 0.1);
}

TEST(GlobalIndices, ReproducesAnalyticIndicesFromThirtyFramesWithinTheSamplingError) {
  const CosineBeat b;
  GlobalIndicesOptions o = open_frames();
  o.beat.refine_extrema = true;  // a cosine has smooth extrema: the parabola vertex pays off
  const auto idx = indices_of(sample_beat(b.channels(), b.period, 30, false), o);
  const double w = b.w();
  const double frame = b.period / 30;
  // The peak lies between frames; the parabola through three frames misses it by about
  // A (w h)^4 / 24 (< 0.01 mL here), the frame maximum by up to 0.2 mL.
  EXPECT_NEAR(idx.at("EDV"), b.v0 + b.amplitude, 0.01e-6);
  EXPECT_NEAR(idx.at("ESV"), b.v0 - b.amplitude, 0.01e-6);
  EXPECT_NEAR(idx.at("EF"), 2 * b.amplitude / (b.v0 + b.amplitude), 2e-4);
  // Centred differences at 30 frames: sinc(2 pi / 30) = 0.9927, i.e. 0.73 % low.
  EXPECT_NEAR(idx.at("dVdt_min"), -b.amplitude * w, 0.01 * b.amplitude * w);
  EXPECT_NEAR(idx.at("dPdt_max"), b.pa * w, 0.01 * b.pa * w);
  EXPECT_NEAR(idx.at("t_ES"), b.period / 2, 0.05 * frame);
  EXPECT_NEAR(idx.at("ejection_duration"), b.ejection(), 0.1 * frame);
  // ED is located by linear interpolation between frames (~1.5 ms off); P rises 50 Pa/ms there.
  EXPECT_NEAR(idx.at("EDP"), b.pressure(b.ed_onset()), 0.02 * b.pa);
  EXPECT_NEAR(idx.at("P_max"), b.p0 + b.pa, 0.002 * b.pa);
}

TEST(GlobalIndices, ThirtyFramesAndAFineGridOfTheSameSkewedCurveAgree) {
  const double period = 0.9;
  const auto channels = testing::skewed_beat(period);
  const auto fine = indices_of(sample_beat(channels, period, 900, true));
  const auto coarse = indices_of(sample_beat(channels, period, 30, false, 0.013), open_frames());
  const double frame = period / 30;
  const double sv = fine.at("SV");
  // Stated tolerances for cine MRI at 30 frames per beat: volumes within 1 % of SV (a frame
  // maximum misses a smooth peak by up to 1 - cos(pi / 30) = 0.5 % of the amplitude), EF within
  // 0.005, flows and pressure rates within 5 % (centred differences span two frames and damp
  // the third harmonic by sinc(6 pi / 30) = 0.94), times within a quarter frame, pressures 0.5 %.
  for (const char* v : {"EDV", "ESV", "SV"}) EXPECT_NEAR(coarse.at(v), fine.at(v), 0.01 * sv) << v;
  EXPECT_NEAR(coarse.at("EF"), fine.at("EF"), 0.005);
  for (const char* r : {"dVdt_min", "dVdt_max", "dPdt_max", "dPdt_min"}) {
    EXPECT_NEAR(coarse.at(r), fine.at(r), 0.05 * std::abs(fine.at(r))) << r;
  }
  for (const char* t : {"t_ES", "ejection_duration"}) {
    EXPECT_NEAR(coarse.at(t), fine.at(t), 0.25 * frame) << t;
  }
  for (const char* p : {"P_max", "EDP"}) {
    EXPECT_NEAR(coarse.at(p), fine.at(p), 0.005 * fine.at("P_max")) << p;
  }
}

// A beat with isovolumic plateaus: V(t) falls as a half cosine from 140 to 60 mL over 0.3 s,
// stays at 60 mL for 0.1 s, rises back over 0.3 s and stays at 140 mL for 0.1 s.
double plateau_volume(double t) {
  const double T = 0.8;
  double s = std::fmod(t, T);
  if (s < 0) s += T;
  if (s < 0.3) return 1e-6 * (100.0 + 40.0 * std::cos(kPi * s / 0.3));
  if (s < 0.4) return 60e-6;
  if (s < 0.7) return 1e-6 * (100.0 - 40.0 * std::cos(kPi * (s - 0.4) / 0.3));
  return 140e-6;
}

TEST(GlobalIndices, KeepsSampleExtremaExactOnPlateausWhereAParabolaWouldOvershoot) {
  const std::vector<testing::AnalyticChannel> ch = {{"V_lv", "m^3", plateau_volume}};
  const auto frames = sample_beat(ch, 0.8, 30, false, 0.011);
  auto with_refinement = open_frames();
  with_refinement.beat.refine_extrema = true;
  const auto plain = indices_of(frames, open_frames());
  const auto refined = indices_of(frames, with_refinement);
  EXPECT_NEAR(plain.at("EDV"), 140e-6, 1e-12);
  EXPECT_NEAR(plain.at("ESV"), 60e-6, 1e-12);
  EXPECT_LT(refined.at("ESV"), 60e-6 - 0.05e-6);  // the vertex extrapolates beyond the plateau
  // ED is the onset of the 140 mL plateau (0.7 s), ES the end of ejection (0.3 s): V reaches
  // the 5 % levels 0.0215 s before both, so t_ES = 0.4 s up to the frame interpolation.
  EXPECT_NEAR(plain.at("t_ES"), 0.4, 0.1 * 0.8 / 30);
  // Ejection from V = 136 mL (0.0431 s) to V = 64 mL (0.2569 s) after the start of the fall.
  const double theta = std::acos(0.9);
  EXPECT_NEAR(plain.at("ejection_duration"), 0.3 * (kPi - 2 * theta) / kPi, 0.1 * 0.8 / 30);
}

TEST(GlobalIndices, GivesTheSameIndicesWhateverTheUnitsOfTheChannels) {
  const CosineBeat b;
  auto si = sample_beat(b.channels(), b.period, 30, false);
  auto clinical = si;
  clinical.values.col(0) *= 1e6;
  clinical.channels[0].unit = "mL";
  clinical.values.col(1) /= 133.322;
  clinical.channels[1].unit = "mmHg";
  const auto a = indices_of(si, open_frames());
  const auto c = indices_of(clinical, open_frames());
  for (const auto& [name, value] : a) EXPECT_NEAR(c.at(name), value, 1e-9 * std::abs(value)) << name;
}

TEST(GlobalIndices, ReportsAFlatVolumeAsNoEjectionFound) {
  CosineBeat b;
  b.amplitude = 0.0;
  const auto tr = sample_beat(b.channels(), b.period, 30, false);
  const GlobalIndices gi({}, tr.channels);
  Eigen::VectorXd z(gi.size());
  const auto status = gi.observe(tr, z);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message.find("no ejection"), std::string::npos) << status.message;
}

TEST(GlobalIndices, ReportsAMissingChannelAsAStatusNotAnException) {
  const CosineBeat b;
  const auto tr = sample_beat(b.channels(), b.period, 30, false);
  const GlobalIndices gi({}, tr.channels);
  model::Trajectory volume_only = tr;
  volume_only.channels = {{"V_lv", "m^3", ""}};
  volume_only.values = tr.values.leftCols(1);
  Eigen::VectorXd z(gi.size());
  const auto status = gi.observe(volume_only, z);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message.find("P_lv"), std::string::npos) << status.message;
}

TEST(GlobalIndices, MeasuresTimeOfEndSystoleFromEndDiastoleAcrossTheWrap) {
  CosineBeat b;
  b.t_ed = 0.7;  // ES at 0.3 s, before ED in the record
  const auto idx = indices_of(sample_beat(b.channels(), b.period, 800, true));
  EXPECT_NEAR(idx.at("t_ES"), 0.4, 1e-5);
}

TEST(GlobalIndices, SpreadsTheBeatToBeatMismatchOfAClosedBeatInsteadOfMakingAFlowSpike) {
  CosineBeat b;
  b.t_ed = 0.6004;  // the beat starts at peak ejection, where a jump at the wrap would add up
  auto channels = b.channels();
  // A beat that settled only to 0.3 % of its range: V drifts by delta over the beat.
  const double delta = 0.003 * 2 * b.amplitude, period = b.period;
  const auto v = channels[0].x;
  channels[0].x = [=](double t) { return v(t) + delta * t / period; };
  auto tr = sample_beat(channels, b.period, 800, true);
  tr.values(800, 0) = v(period) + delta;  // sample_beat copied the first row; restore the drift
  const auto exact = indices_of(sample_beat(b.channels(), b.period, 800, true));
  const auto closed = indices_of(tr);
  // Without the spreading, the wrap would carry a jump delta over one 1 ms step: a spurious
  // |dV/dt| of delta / 2 ms = 38 % of the peak flow.
  EXPECT_NEAR(closed.at("dVdt_max"), exact.at("dVdt_max"), 1e-3 * exact.at("dVdt_max"));
  EXPECT_NEAR(closed.at("dVdt_min"), exact.at("dVdt_min"), 1e-3 * std::abs(exact.at("dVdt_min")));
  EXPECT_NEAR(closed.at("EDV"), exact.at("EDV"), delta);
  EXPECT_NEAR(closed.at("t_ES"), exact.at("t_ES"), 2e-3);
}

}  // namespace
}  // namespace sigmaheart::observers
