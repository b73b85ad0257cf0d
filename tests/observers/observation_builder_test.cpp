#include "observers/observation_builder.h"

#include "analytic_beat.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::observers {
namespace {

using testing::CosineBeat;
using testing::sample_beat;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no exception)";
}

TEST(ObservationBuilder, ParsesAbsoluteAndRelativeNoise) {
  const Noise a = parse_noise(" 5 mL ");
  EXPECT_EQ(a.kind, Noise::Kind::kAbsolute);
  EXPECT_DOUBLE_EQ(a.value, 5.0);
  EXPECT_EQ(a.unit, "mL");
  const Noise r = parse_noise("10 %");
  EXPECT_EQ(r.kind, Noise::Kind::kRelative);
  EXPECT_DOUBLE_EQ(r.value, 10.0);
  EXPECT_EQ(parse_noise("0.03").unit, "");
  EXPECT_NE(message_of([] { parse_noise("5 furlong"); }).find("known units: m^3"), std::string::npos);
  EXPECT_NE(message_of([] { parse_noise("-2 mL"); }).find("positive"), std::string::npos);
  EXPECT_NE(message_of([] { parse_noise("mL"); }).find("expected a number"), std::string::npos);
}

TEST(ObservationBuilder, ConvertsTypedInIndicesAndTheirNoiseToSi) {
  const auto set = observations_from_entries({
      {"EDV", 150.0, "mL", Noise::absolute(5.0, "mL")},
      {"EF", 55.0, "%", Noise::absolute(0.03, "")},
      {"P_max", 16.0, "kPa", Noise::relative(10.0)},
      {"t_ES", 350.0, "ms", Noise::absolute(20.0, "ms")},
  });
  ASSERT_EQ(set.size(), 4);
  EXPECT_NEAR(set.y(0), 150e-6, 1e-18);
  EXPECT_NEAR(set.R(0, 0), 25e-12, 1e-24);
  EXPECT_NEAR(set.y(1), 0.55, 1e-15);
  EXPECT_NEAR(set.R(1, 1), 9e-4, 1e-15);
  EXPECT_NEAR(set.y(2), 16e3, 1e-9);
  EXPECT_NEAR(set.R(2, 2), 1600.0 * 1600.0, 1e-6);
  EXPECT_NEAR(set.y(3), 0.35, 1e-15);
  EXPECT_EQ(set.units[0], "m^3");
  EXPECT_EQ(set.display_units[2], "kPa");
  EXPECT_TRUE(set.validate().empty());
}

TEST(ObservationBuilder, RefusesTypedInIndicesWithWrongNamesUnitsOrNoise) {
  const Noise n = Noise::absolute(5.0, "mL");
  EXPECT_NE(message_of([&] { observations_from_entries({{"EVD", 150, "mL", n}}); })
                .find("did you mean 'EDV'"), std::string::npos);
  EXPECT_NE(message_of([&] { observations_from_entries({{"EDV", 150, "mmHg", n}}); })
                .find("measures Pa"), std::string::npos);
  EXPECT_NE(message_of([&] { observations_from_entries({{"EDV", 150, "mLs", n}}); })
                .find("known units"), std::string::npos);
  EXPECT_NE(message_of([&] {
              observations_from_entries({{"EDV", 150, "mL", Noise::absolute(2, "mmHg")}});
            }).find("noise"), std::string::npos);
  EXPECT_NE(message_of([&] {
              observations_from_entries({{"EDV", 150, "mL", n}, {"EDV", 140, "mL", n}});
            }).find("twice"), std::string::npos);
  EXPECT_NE(message_of([&] {
              observations_from_entries({{"dVdt_max", 0.0, "mL/s", Noise::relative(5)}});
            }).find("absolute noise"), std::string::npos);
}

TEST(ObservationBuilder, ComputesMeasuredIndicesWithTheObserversOwnCode) {
  const CosineBeat b;
  const auto measured = sample_beat(b.channels(), b.period, 30, false);
  NoiseModel noise;
  noise.fallback = Noise::relative(5.0);
  noise.by_name["EDV"] = Noise::absolute(4.0, "mL");
  const auto set = observations_from_indices(measured, {}, noise, {"mL", "mmHg", "mmHg"});
  GlobalIndicesOptions frames;
  frames.beat = measured_frames();  // what observations_from_indices reads measured curves with
  const GlobalIndices gi(frames, measured.channels);
  Eigen::VectorXd z(gi.size());
  ASSERT_TRUE(gi.observe(measured, z).ok());
  ASSERT_EQ(set.size(), gi.size());
  EXPECT_EQ(set.y, z);
  EXPECT_NEAR(set.R(0, 0), 16e-12, 1e-24);
  EXPECT_NEAR(std::sqrt(set.R(1, 1)), 0.05 * z(1), 1e-15);
  EXPECT_EQ(set.display_units[0], "mL");
  EXPECT_EQ(set.display_units[2], "%");
  EXPECT_EQ(set.display_units[4], "mL/s");
  EXPECT_EQ(set.display_units[6], "ms");
  EXPECT_EQ(set.display_units[9], "mmHg/s");
  EXPECT_EQ(set.frame_times.size(), 30);
}

TEST(ObservationBuilder, MeasuredFramesAndTheSamplerOnAFineSimulationAgree) {
  CosineBeat b;
  b.t_ed = 0.51;  // ED between frames 19 and 20 of the measured curve
  const auto measured = sample_beat(b.channels(), b.period, 30, false);
  MeasuredCurveOptions opt;
  opt.channels = {"V_lv", "P_lv"};
  NoiseModel noise;
  noise.by_name["V_lv"] = Noise::absolute(3.0, "mL");
  noise.by_name["P_lv"] = Noise::absolute(1.0, "mmHg");
  const auto obs = observations_from_curves(measured, opt, noise);
  const auto& set = obs.observations;
  ASSERT_EQ(set.size(), 60);
  EXPECT_EQ(set.names[0], "V_lv@f00");
  EXPECT_EQ(set.names[59], "P_lv@f29");
  const double frame = b.period / 30;
  // Frame 0 is the measured frame nearest to end-diastole (onset of the ED plateau).
  const double t_ed = b.ed_onset();
  const int k0 = static_cast<int>(std::lround(t_ed / frame)) % 30;
  EXPECT_DOUBLE_EQ(set.y(0), measured.values(k0, 0));
  EXPECT_NEAR(set.frame_times(0), k0 * frame - t_ed, 0.1 * frame);
  EXPECT_LE(std::abs(set.frame_times(0)), 0.5 * frame + 1e-12);
  EXPECT_NEAR(set.frame_times(1) - set.frame_times(0), frame, 1e-12);
  EXPECT_NEAR(set.R(0, 0), 9e-12, 1e-24);
  EXPECT_NEAR(set.R(30, 30), 133.322 * 133.322, 1e-6);

  // The same curve simulated on a fine grid with another phase (simulations start anywhere).
  CosineBeat sim = b;
  sim.t_ed = 0.2;
  sim.t_p = b.t_p - b.t_ed + sim.t_ed;
  const auto fine = sample_beat(sim.channels(), sim.period, 800, true);
  const CurveSampler sampler(obs.sampler, fine.channels);
  Eigen::VectorXd z(sampler.size());
  ASSERT_TRUE(sampler.observe(fine, z).ok());
  // Residual: the measured ED is located by linear interpolation between frames; a timing error
  // dt shifts every frame by up to A w dt = 0.1 mL for dt = 0.36 ms.
  EXPECT_LT((z.head(30) - set.y.head(30)).cwiseAbs().maxCoeff(), 0.1e-6);   // 0.1 mL
  EXPECT_LT((z.tail(30) - set.y.tail(30)).cwiseAbs().maxCoeff(), 0.002 * b.pa);
}

TEST(ObservationBuilder, ConvertsAFullCovarianceFromClinicalUnits) {
  auto set = observations_from_entries({{"EDV", 150.0, "mL", Noise::absolute(5.0, "mL")},
                                        {"P_max", 120.0, "mmHg", Noise::absolute(5.0, "mmHg")}});
  Eigen::Matrix2d R;
  R << 25.0, 2.0, 2.0, 16.0;  // mL^2, mL mmHg, mmHg^2
  set_covariance(set, R, {"mL", "mmHg"});
  EXPECT_NEAR(set.R(0, 0), 25e-12, 1e-24);
  EXPECT_NEAR(set.R(0, 1), 2.0 * 1e-6 * 133.322, 1e-15);
  EXPECT_NEAR(set.R(1, 1), 16.0 * 133.322 * 133.322, 1e-6);
  R(0, 1) = 30.0;  // not symmetric
  EXPECT_THROW(set_covariance(set, R, {"mL", "mmHg"}), std::invalid_argument);
  EXPECT_THROW(set_covariance(set, Eigen::Matrix2d::Identity(), {"mL", "mL"}), std::invalid_argument);
}

TEST(ObservationBuilder, ConcatenatesSetsBlockDiagonally) {
  const auto a = observations_from_entries({{"EDV", 150.0, "mL", Noise::absolute(5.0, "mL")}});
  const auto b = observations_from_entries({{"ESV", 60.0, "mL", Noise::absolute(4.0, "mL")},
                                            {"EF", 0.6, "1", Noise::absolute(0.02, "1")}});
  const auto all = concatenate({a, b});
  ASSERT_EQ(all.size(), 3);
  EXPECT_EQ(all.names[2], "EF");
  EXPECT_DOUBLE_EQ(all.R(1, 1), b.R(0, 0));
  EXPECT_DOUBLE_EQ(all.R(0, 1), 0.0);
  EXPECT_THROW(concatenate({a, a}), std::invalid_argument);
}

TEST(ObservationBuilder, ChecksThatAnObserverAndASetListTheSameEntries) {
  const CosineBeat b;
  const auto measured = sample_beat(b.channels(), b.period, 30, false);
  NoiseModel noise;
  noise.fallback = Noise::relative(5.0);
  GlobalIndicesOptions o;
  o.indices = {"EDV", "ESV", "P_max"};
  const auto set = observations_from_indices(measured, o, noise);
  const GlobalIndices same(o, measured.channels);
  EXPECT_EQ(check_consistent(same, set), "");
  o.indices = {"ESV", "EDV", "P_max"};
  const GlobalIndices swapped(o, measured.channels);
  EXPECT_NE(check_consistent(swapped, set).find("'ESV' where 'EDV'"), std::string::npos);
  EXPECT_EQ(check_consistent(swapped, set.select({"ESV", "EDV", "P_max"})), "");
}

}  // namespace
}  // namespace sigmaheart::observers
