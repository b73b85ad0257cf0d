#include "estimation/fit_report.h"

#include "model/units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::estimation {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMl = 1e-6;                       // m^3 per mL
constexpr double kMmHg = model::units::kMmHg;      // Pa per mmHg

std::string frame_name(const std::string& channel, int k) {
  std::string s = channel + "@f";
  if (k < 10) s += '0';
  return s + std::to_string(k);
}

// Curves at frames as an ObservationSet (channel-major, names "<channel>@fNN"), noise std per
// channel.
observers::ObservationSet curves(const Eigen::VectorXd& t, const std::vector<std::string>& channels,
                                 const std::vector<std::string>& units,
                                 const std::vector<Eigen::VectorXd>& values,
                                 const std::vector<double>& noise_std) {
  observers::ObservationSet obs;
  const auto n = t.size();
  const auto c = static_cast<Eigen::Index>(channels.size());
  obs.y.resize(n * c);
  Eigen::VectorXd sd(n * c);
  for (Eigen::Index ch = 0; ch < c; ++ch) {
    for (Eigen::Index k = 0; k < n; ++k) {
      obs.names.push_back(frame_name(channels[static_cast<size_t>(ch)], static_cast<int>(k)));
      obs.units.push_back(units[static_cast<size_t>(ch)]);
      obs.y(ch * n + k) = values[static_cast<size_t>(ch)](k);
      sd(ch * n + k) = noise_std[static_cast<size_t>(ch)];
    }
  }
  obs.R = sd.array().square().matrix().asDiagonal();
  obs.frame_times = t;
  return obs;
}

Eigen::VectorXd frames(int n, double period) {
  return Eigen::VectorXd::LinSpaced(n, 0.0, period * (n - 1) / n);
}

// V(t) = 120 - 35 (1 - cos(2 pi t / T)) mL and P(t) = 5 + 57.5 (1 - cos(2 pi t / T)) mmHg at 30
// frames: EDV 120 mL at t = 0, ESV 50 mL at t = T/2 (frame 15), EF 70/120, P_max 120 mmHg,
// EDP 5 mmHg.
TEST(FitReport, ClinicalIndicesOfAnAnalyticBeatAreExact) {
  const Eigen::VectorXd t = frames(30, 1.0);
  const Eigen::ArrayXd c = 1 - (2 * kPi * t.array()).cos();
  const Eigen::VectorXd v = (120 - 35 * c) * kMl;
  const Eigen::VectorXd p = (5 + 57.5 * c) * kMmHg;
  const ClinicalIndices ci = clinical_indices(v, p);
  EXPECT_NEAR(ci.edv, 120 * kMl, 1e-12 * kMl);
  EXPECT_NEAR(ci.esv, 50 * kMl, 1e-12 * kMl);
  EXPECT_NEAR(ci.sv, 70 * kMl, 1e-12 * kMl);
  EXPECT_NEAR(ci.ef, 70.0 / 120.0, 1e-14);
  EXPECT_NEAR(ci.p_max, 120 * kMmHg, 1e-9);
  EXPECT_NEAR(ci.edp, 5 * kMmHg, 1e-9);

  // A noisy frame in isovolumic contraction with a volume 1 mL above the end-diastolic one and a
  // pressure of 65 mmHg: end-diastole stays the filling frame (EDP 5 mmHg), not the volume maximum.
  Eigen::VectorXd v_noisy = v, p_noisy = p;
  v_noisy(1) = 121 * kMl;
  p_noisy(1) = 65 * kMmHg;
  EXPECT_NEAR(clinical_indices(v_noisy, p_noisy).edp, 5 * kMmHg, 1e-9);

  // The same frame on the isovolumic rise but still below mid-pressure (50 mmHg, 45 above the
  // frame before, the steepest rise of this beat being 45): also not end-diastole.
  p_noisy(1) = 50 * kMmHg;
  EXPECT_NEAR(clinical_indices(v_noisy, p_noisy).edp, 5 * kMmHg, 1e-9);

  // Fitted curves 10 % larger in volume: errors fitted - observed.
  const auto obs = curves(t, {"V_lv", "P_lv"}, {"m^3", "Pa"}, {v, p}, {2 * kMl, 3 * kMmHg});
  Eigen::VectorXd z = obs.y;
  z.head(30) *= 1.1;
  const FitReport r = make_fit_report(obs, z);
  ASSERT_EQ(r.indices.size(), 6u);
  EXPECT_EQ(r.indices[0].name, "EDV");
  EXPECT_NEAR(r.indices[0].error, 12 * kMl, 1e-12 * kMl);
  EXPECT_EQ(r.indices[3].name, "EF");
  EXPECT_NEAR(r.indices[3].error, 0.0, 1e-14);  // a scaled volume keeps EF
  EXPECT_EQ(r.indices[5].name, "EDP");
  EXPECT_NEAR(r.indices[5].fitted, 5 * kMmHg, 1e-9);
}

// A beat of 50 frames (T = 1 s, dt = 20 ms) with known phases: isovolumic contraction [0, 60) ms,
// ejection [60, 360) ms (linear, 70 mL), isovolumic relaxation [360, 460) ms, filling
// [460, 1000) ms (linear). Pressure rises in contraction, falls in relaxation.
struct SyntheticBeat {
  Eigen::VectorXd t = frames(50, 1.0);
  Eigen::VectorXd v, p;
  std::vector<CyclePhase> truth;
  SyntheticBeat() : v(50), p(50) {
    for (int k = 0; k < 50; ++k) {
      const double s = t(k);
      if (s < 0.06) {
        v(k) = 120;
        p(k) = 10 + 70 * s / 0.06;
        truth.push_back(CyclePhase::kIsovolumicContraction);
      } else if (s < 0.36) {
        v(k) = 120 - 70 * (s - 0.06) / 0.3;
        p(k) = 80 + 40 * std::sin(kPi * (s - 0.06) / 0.3);
        truth.push_back(CyclePhase::kEjection);
      } else if (s < 0.46) {
        v(k) = 50;
        p(k) = 80 - 72 * (s - 0.36) / 0.1;
        truth.push_back(CyclePhase::kIsovolumicRelaxation);
      } else {
        v(k) = 50 + 70 * (s - 0.46) / 0.54;
        p(k) = 5 + 5 * (s - 0.46) / 0.54;
        truth.push_back(CyclePhase::kFilling);
      }
    }
    v *= kMl;
    p *= kMmHg;
  }
};

TEST(FitReport, ClassifiesThePhasesOfASyntheticBeat) {
  const SyntheticBeat beat;
  for (bool with_pressure : {true, false}) {
    std::vector<CyclePhase> phases;
    const model::Status s = classify_phases(beat.t, beat.v, with_pressure ? beat.p : Eigen::VectorXd(),
                                            PhaseOptions{}, phases);
    ASSERT_TRUE(s.ok()) << s.message;
    ASSERT_EQ(phases.size(), 50u);
    for (int k = 0; k < 50; ++k) {
      const auto before = beat.truth[static_cast<size_t>((k + 49) % 50)];
      const auto after = beat.truth[static_cast<size_t>((k + 1) % 50)];
      const auto truth = beat.truth[static_cast<size_t>(k)];
      if (before == truth && after == truth) {
        EXPECT_EQ(phases[static_cast<size_t>(k)], truth) << "frame " << k << " pressure " << with_pressure;
      } else {  // a frame at a boundary goes to one of its neighbours' phases
        const auto got = phases[static_cast<size_t>(k)];
        EXPECT_TRUE(got == before || got == truth || got == after) << "frame " << k;
      }
    }
  }
  std::vector<CyclePhase> phases;
  EXPECT_FALSE(classify_phases(beat.t, Eigen::VectorXd::Constant(50, 1e-4), Eigen::VectorXd(), {}, phases).ok());
}

// Residuals by hand: V_lv alternating +-1 noise std (RMS 1), P_lv 10 std on the 5 isovolumic
// relaxation frames and 0 elsewhere (RMS 10 sqrt(5/50) = 3.162); all of P's squared residual in
// isovolumic relaxation.
TEST(FitReport, RmsPerChannelAndTheDiscrepancyPhaseByHand) {
  const SyntheticBeat beat;
  const double sv = 2 * kMl, sp = 2 * kMmHg;
  const auto obs = curves(beat.t, {"V_lv", "P_lv"}, {"m^3", "Pa"}, {beat.v, beat.p}, {sv, sp});
  Eigen::VectorXd z = obs.y;
  int ivr = 0;
  for (int k = 0; k < 50; ++k) {
    z(k) -= (k % 2 ? -1.0 : 1.0) * sv;
    if (beat.truth[static_cast<size_t>(k)] == CyclePhase::kIsovolumicRelaxation) {
      z(50 + k) -= 10 * sp;
      ++ivr;
    }
  }
  ASSERT_EQ(ivr, 5);
  const FitReport r = make_fit_report(obs, z);
  ASSERT_EQ(r.channels.size(), 2u);
  EXPECT_EQ(r.channels[0].channel, "V_lv");
  EXPECT_EQ(r.channels[0].count, 50);
  EXPECT_NEAR(r.channels[0].rms_normalised, 1.0, 1e-12);
  EXPECT_NEAR(r.channels[0].rms_residual, sv, 1e-12 * sv);
  EXPECT_NEAR(r.channels[1].rms_normalised, 10 * std::sqrt(5.0 / 50.0), 1e-12);
  EXPECT_NEAR(r.channels[1].max_abs_normalised, 10.0, 1e-9);
  ASSERT_EQ(r.discrepancies.size(), 1u);
  const ChannelDiscrepancy& d = r.discrepancies[0];
  EXPECT_EQ(d.channel, "P_lv");
  EXPECT_EQ(d.dominant, CyclePhase::kIsovolumicRelaxation);
  // The IVR frames whose neighbours are IVR too are classified exactly; a boundary frame may move.
  const PhaseResidual& top = d.phases[static_cast<size_t>(CyclePhase::kIsovolumicRelaxation)];
  EXPECT_GE(top.frames, 3);
  EXPECT_LE(top.frames, 7);
  EXPECT_GE(top.share, 0.6);
  double shares = 0;
  for (const auto& ph : d.phases) shares += ph.share;
  EXPECT_NEAR(shares, 1.0, 1e-12);
  EXPECT_NE(r.summary.find("V_lv fits to 1.0 noise std"), std::string::npos) << r.summary;
  EXPECT_NE(r.summary.find("P_lv misfit 3.2 noise std concentrated in isovolumic relaxation"),
            std::string::npos) << r.summary;
  EXPECT_NE(r.summary.find("model discrepancy"), std::string::npos);
}

TEST(FitReport, NamesUninformedParametersAndCorrelatedPairs) {
  const Eigen::Vector3d prior_std(1.0, 2.0, 0.5);
  const Eigen::Vector3d post_std(0.3, 1.9, 0.1);
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  C(0, 2) = C(2, 0) = -0.95;
  C(0, 1) = C(1, 0) = 0.5;
  const Eigen::Matrix3d P = post_std.asDiagonal() * C * post_std.asDiagonal();
  const Identifiability id = identifiability({"a", "b", "c"}, P, prior_std);
  EXPECT_LT((id.correlation - C).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_NEAR(id.std_ratio(1), 0.95, 1e-14);
  EXPECT_EQ(id.uninformed, std::vector<std::string>{"b"});
  ASSERT_EQ(id.correlated.size(), 1u);
  EXPECT_EQ(id.correlated[0].a, "a");
  EXPECT_EQ(id.correlated[0].b, "c");
  EXPECT_NEAR(id.correlated[0].rho, -0.95, 1e-14);
  EXPECT_THROW(identifiability({"a"}, P, prior_std), std::invalid_argument);

  // In the report: typed-in indices (no curves) and the posterior.
  observers::ObservationSet obs;
  obs.names = {"EDV", "EF"};
  obs.units = {"m^3", "1"};
  obs.y = Eigen::Vector2d(1.2e-4, 0.6);
  obs.R = Eigen::Vector2d(4e-12, 1e-4).asDiagonal();
  const FitReport r = make_fit_report(obs, Eigen::Vector2d(1.22e-4, 0.59),
                                      PosteriorSpread{{"a", "b", "c"}, P, prior_std});
  EXPECT_NEAR(r.channels[0].rms_normalised, 1.0, 1e-9);
  EXPECT_TRUE(r.indices.empty());
  EXPECT_FALSE(r.notes.empty());
  EXPECT_NE(r.summary.find("not informed by the data (posterior std > 90 % of prior): b"),
            std::string::npos) << r.summary;
  EXPECT_NE(r.summary.find("a and c strongly correlated (rho -0.95)"), std::string::npos) << r.summary;
}

TEST(FitReport, ParsesFrameNames) {
  EXPECT_EQ(parse_observation_name("V_lv@f07").channel, "V_lv");
  EXPECT_EQ(parse_observation_name("V_lv@f07").frame, 7);
  EXPECT_EQ(parse_observation_name("V_seg12@f130").frame, 130);
  EXPECT_EQ(parse_observation_name("EDV").frame, -1);
  EXPECT_EQ(parse_observation_name("x@fast").channel, "x@fast");
}

TEST(FitReport, RefusesMismatchedSizes) {
  const SyntheticBeat beat;
  const auto obs = curves(beat.t, {"V_lv"}, {"m^3"}, {beat.v}, {2 * kMl});
  EXPECT_THROW(make_fit_report(obs, Eigen::VectorXd::Zero(3)), std::invalid_argument);
  auto short_times = obs;
  short_times.frame_times = short_times.frame_times.head(10);
  EXPECT_THROW(make_fit_report(short_times, obs.y), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
Eigen::VectorXd cosine_volume(const Eigen::VectorXd& t, double period) {
  return (120 - 35 * (1 - (2 * kPi * t.array() / period).cos())).matrix() * kMl;
}

// Three beats of T = 0.8 s sampled every 27 ms (not a divisor of T). The vertex of the parabola
// through the sampled correlation peak is biased by the peak's non-parabolic shape: under 1 % of
// the spacing at ~30 samples per period (0.24 ms here), so 1 ms (4 % of dt) could fail only if the
// wrong peak or lag were found.
TEST(Period, FromTheAutocorrelationOfSeveralBeats) {
  const double T = 0.8, dt = 0.027;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(89, 0.0, 88 * dt);
  const PeriodEstimate pe = estimate_period(t, cosine_volume(t, T));
  ASSERT_TRUE(pe.status.ok()) << pe.status.message;
  EXPECT_EQ(pe.method, PeriodEstimate::Method::kAutocorrelation);
  EXPECT_NEAR(pe.period, T, 1e-3);
  EXPECT_NEAR(pe.beats, 89 * dt / T, 0.01);
  EXPECT_GT(pe.correlation, 0.99);
  EXPECT_NE(pe.describe().find("from the autocorrelation"), std::string::npos) << pe.describe();
}

TEST(Period, FromTheTimeSpanOfOneOpenBeat) {
  const Eigen::VectorXd t = frames(30, 0.9);
  const PeriodEstimate pe = estimate_period(t, cosine_volume(t, 0.9));
  ASSERT_TRUE(pe.status.ok());
  EXPECT_EQ(pe.method, PeriodEstimate::Method::kTimeSpan);
  EXPECT_NEAR(pe.period, 0.9, 1e-12);
  EXPECT_FALSE(estimate_period(Eigen::Vector3d(0, 0.1, 0.1), Eigen::Vector3d(1, 2, 3)).status.ok());
}

model::Trajectory beat_trajectory(const Eigen::VectorXd& t, const Eigen::VectorXd& v) {
  model::Trajectory tr;
  tr.times = t;
  tr.channels = {{"V_lv", "m^3", ""}, {"frame", "1", ""}};
  tr.values.resize(t.size(), 2);
  tr.values.col(0) = v;
  tr.values.col(1) = Eigen::VectorXd::LinSpaced(t.size(), 0, static_cast<double>(t.size() - 1));
  return tr;
}

// One open beat of 30 frames whose largest volume is at frame 7: after alignment frame 7 is at
// t = 0, frame 6 last, times increasing in [0, T).
TEST(Alignment, PutsTheLargestVolumeAtTimeZero) {
  const double T = 0.9;
  const Eigen::VectorXd t = frames(30, T);
  const Eigen::VectorXd v = cosine_volume((t.array() - t(7)).matrix(), T);
  const AlignedBeat a = align_on_end_diastole(beat_trajectory(t, v));
  ASSERT_TRUE(a.status.ok()) << a.status.message;
  EXPECT_NEAR(a.period, T, 1e-12);
  EXPECT_NEAR(a.landmark_time, t(7), 1e-15);
  ASSERT_EQ(a.trajectory.samples(), 30);
  EXPECT_EQ(a.trajectory.values(0, 1), 7.0);
  EXPECT_EQ(a.trajectory.values(29, 1), 6.0);
  EXPECT_NEAR(a.trajectory.times(0), 0.0, 1e-15);
  EXPECT_NEAR(a.trajectory.times(29), T - T / 30, 1e-12);

  // A shift of one frame: t = 0 one frame after end-diastole.
  AlignmentOptions shifted;
  shifted.shift = T / 30;
  EXPECT_EQ(align_on_end_diastole(beat_trajectory(t, v), shifted).trajectory.values(0, 1), 8.0);
  // The trigger keeps the recorded times.
  AlignmentOptions trigger;
  trigger.landmark = AlignmentOptions::Landmark::kTrigger;
  EXPECT_EQ(align_on_end_diastole(beat_trajectory(t, v), trigger).trajectory.values(0, 1), 0.0);
  AlignmentOptions missing;
  missing.channel = "V_xx";
  EXPECT_NE(align_on_end_diastole(beat_trajectory(t, v), missing).status.message.find("V_xx"),
            std::string::npos);
}

// Two and a half beats: the period comes from the autocorrelation and the first complete beat
// after the first end-diastole is kept.
TEST(Alignment, KeepsTheFirstCompleteBeatOfALongerRecord) {
  const double T = 0.8;
  const int per_beat = 32;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(80, 0.0, 79 * T / per_beat);
  const Eigen::VectorXd v = cosine_volume((t.array() - 5 * T / per_beat).matrix(), T);
  const AlignedBeat a = align_on_end_diastole(beat_trajectory(t, v));
  ASSERT_TRUE(a.status.ok()) << a.status.message;
  EXPECT_NEAR(a.period, T, 1e-3);
  EXPECT_NEAR(a.landmark_time, t(5), 1e-15);
  EXPECT_EQ(a.trajectory.samples(), per_beat);
  EXPECT_EQ(a.trajectory.values(0, 1), 5.0);
  EXPECT_EQ(a.trajectory.values(per_beat - 1, 1), 5.0 + per_beat - 1);
}

}  // namespace
}  // namespace sigmaheart::estimation
