#include "estimation/therapy/therapy.h"
#include "model/lumped/regional.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::estimation::therapy {
namespace {

namespace act = model::activation;

model::lumped::RegionalVentricle regional(model::lumped::ActivationPattern pattern) {
  model::lumped::RegionalOptions o;
  o.activation = pattern;
  o.numerics.dt = 2e-3;  // the map's runs at 2 ms steps (their indices move by < 1 %)
  return model::lumped::RegionalVentricle(o);
}

TherapyOptions sites(std::vector<int> segments) {
  TherapyOptions o;
  for (int s : segments) o.lv_sites.push_back({s, act::Surface::kEpicardium, std::nullopt});
  o.ensemble.threads = 1;
  o.ensemble.backend = Backend::kSerial;
  return o;
}

TEST(Therapy, BiventricularPacingOfASynchronousHeartGivesANonPositiveAhr) {
  // Every segment at t = 0: any paced sequence is less synchronous, so dP/dt max cannot rise.
  const auto model = regional(model::lumped::ActivationPattern::kSynchronous);
  const TherapySummary s = run_therapy_study(model, model.parameters().nominal(), {}, std::nullopt, sites({5, 11}));
  ASSERT_TRUE(s.ok()) << s.message;
  ASSERT_EQ(s.map.size(), 2u);
  for (const auto& t : s.map) {
    EXPECT_LE(t.change_moments.mean(TherapySummary::kAhr), 0.0) << t.therapy.label;
    EXPECT_GT(t.raw_moments.mean(6), 0.03) << "a paced beat is activated over tens of ms";  // TAT
  }
  EXPECT_NEAR(s.baseline.raw_moments.mean(6), 0.0, 1e-12);  // synchronous: no activation time
  EXPECT_EQ(s.points.count(), 1);
}

TEST(Therapy, BiventricularPacingAtTheLateWallRaisesDpdtInLbbb) {
  const auto model = regional(model::lumped::ActivationPattern::kLbbb);
  const TherapySummary s = run_therapy_study(model, model.parameters().nominal(), {}, std::nullopt, sites({5}));
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_GT(s.map[0].change_moments.mean(TherapySummary::kAhr), 0.0);
  EXPECT_LT(s.map[0].raw_moments.mean(6), s.baseline.raw_moments.mean(6));  // shorter TAT
  EXPECT_EQ(s.best, 0);
  EXPECT_NEAR(s.p_best(0), 1.0, 1e-12);
}

TEST(Therapy, AFailingSiteIsReportedAndTheOtherSitesStillRun) {
  // No intrinsic conduction and the apical ring in scar: paced from the base the apex (17) is
  // never activated, so that site fails; the lead at the apex itself activates it.
  const auto model = regional(model::lumped::ActivationPattern::kLbbb);
  TherapyOptions o = sites({5, 17});
  o.intrinsic_conduction = false;
  o.scar = {13, 14, 15, 16};
  const TherapySummary s = run_therapy_study(model, model.parameters().nominal(), {}, std::nullopt, o);
  EXPECT_EQ(s.termination, Termination::kSomeFailed);
  ASSERT_EQ(s.map.size(), 2u);
  EXPECT_FALSE(s.map[0].ok());
  EXPECT_NE(s.map[0].failure.find("never activated"), std::string::npos) << s.map[0].failure;
  EXPECT_TRUE(s.map[1].ok()) << s.map[1].failure;
  EXPECT_EQ(s.best, 1);
  EXPECT_TRUE(std::isnan(s.p_best(0)));
}

// A posterior over one or two zones' contractilities (septal 2, 3, 8, 9, 14, then lateral 5, 6, 11,
// 12, 16), log-normal with a 14 % standard deviation, on the LBBB heart.
struct ZonePosterior {
  std::vector<std::vector<int>> estimated;
  Posterior posterior;
};
ZonePosterior zone_posterior(const model::ParameterSpace& space, size_t count = 2) {
  ZonePosterior z;
  std::vector<std::vector<int>> zones = {{2, 3, 8, 9, 14}, {5, 6, 11, 12, 16}};
  zones.resize(count);
  for (size_t j = 0; j < zones.size(); ++j) {
    std::vector<int> members;
    for (int seg : zones[j]) members.push_back(space.index_or_throw((seg < 10 ? "sigma0_0" : "sigma0_") + std::to_string(seg)));
    z.estimated.push_back(members);
    z.posterior.names.push_back(j == 0 ? "sigma0_septal" : "sigma0_lateral");
    z.posterior.units.push_back("Pa");
    z.posterior.transforms.push_back({TransformKind::kLog, space[members.front()].nominal});
  }
  const auto p = static_cast<Eigen::Index>(count);
  z.posterior.eta_mean = Eigen::VectorXd::Zero(p);
  z.posterior.eta_covariance = 0.02 * Eigen::MatrixXd::Identity(p, p);
  return z;
}

// Warm starts across the points (docs/estimation.md s.12) give the cold map: every run, warm or
// cold, stops when its last Newton correction is below periodic_tolerance = 1e-6 of each state
// entry's peak, so the two beats of a point differ by about that relative amount and dP/dt max by
// about 1e-6 of itself; the AHR, 100 (dPdt / dPdt_baseline - 1) with both terms so perturbed,
// then moves by about 100 x 2 x 1e-6 = 2e-4 percentage points. We allow 10 times that, 2e-3 points
// per point and site (the slow Windkessel mode can carry a correction's error a few times further),
// and 1e-5 relative on dP/dt max itself; the best site does not change. Measured: 1.1e-6 points and
// 6.1e-9 (the last corrections are far below the tolerance). Beats: 310 warm against 139 cold, as
// 3 points per therapy do not repay the seeds' 72-beat Jacobians (the 18 of the benchmark do).
TEST(Therapy, WarmStartsAcrossThePointsGiveTheColdLeadSiteMap) {
  const auto model = regional(model::lumped::ActivationPattern::kLbbb);
  const ZonePosterior z = zone_posterior(model.parameters());
  TherapyOptions o = sites({5, 13});
  o.propagation.sigma.rule = SigmaRule::kSimplex;  // 3 points, none at the mean: one seed run each
  o.warm_starts = TherapyOptions::WarmStarts::kNever;
  const TherapySummary cold = run_therapy_study(model, model.parameters().nominal(), z.estimated, z.posterior, o);
  o.warm_starts = TherapyOptions::WarmStarts::kAlways;  // auto: 3 points do not repay a seed
  const TherapySummary warm = run_therapy_study(model, model.parameters().nominal(), z.estimated, z.posterior, o);
  ASSERT_TRUE(cold.ok()) << cold.message;
  ASSERT_TRUE(warm.ok()) << warm.message;
  ASSERT_EQ(warm.points.count(), 3);
  EXPECT_EQ(cold.seed_runs, 0);
  EXPECT_EQ(warm.seed_runs, 3);  // the baseline and 2 sites
  EXPECT_EQ(cold.simulations, 9);
  EXPECT_EQ(warm.simulations, 12 + warm.cold_retries);
  EXPECT_EQ(warm.cold_retries, 0);
  ASSERT_EQ(warm.map.size(), cold.map.size());
  for (size_t k = 0; k < cold.map.size(); ++k) {
    const Eigen::VectorXd a = cold.map[k].change.col(TherapySummary::kAhr), b = warm.map[k].change.col(TherapySummary::kAhr);
    EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 2e-3) << cold.map[k].therapy.label;
    const Eigen::VectorXd da = cold.map[k].raw.col(0), db = warm.map[k].raw.col(0);
    EXPECT_LT(((da - db).array() / da.array()).abs().maxCoeff(), 1e-5) << cold.map[k].therapy.label;
  }
  const Eigen::VectorXd ba = cold.baseline.raw.col(0), bb = warm.baseline.raw.col(0);
  EXPECT_LT(((ba - bb).array() / ba.array()).abs().maxCoeff(), 1e-5);
  // P(best) is not compared: from 3 points the sites' AHR covariance is singular, and its seeded
  // draws moved P(best) by 0.009 for AHR changes of 1e-6 points.
  EXPECT_EQ(warm.best, cold.best);
  // The warm points take a few chord beats instead of a cold solve; the seeds pay for the
  // Jacobian (one beat per unknown, 72).
  EXPECT_LT(warm.beats - 3 * 72, cold.beats);
}

// The same numbers on any thread count; the star rule's centre is the seed (no extra run); a site
// whose seed fails hands on no warm start, its points run cold and fail alone.
TEST(Therapy, WarmStartsAreTheSameOnTwoThreadsAndAFailedSeedFailsOnlyItsSite) {
  const auto model = regional(model::lumped::ActivationPattern::kLbbb);
  const ZonePosterior z = zone_posterior(model.parameters(), 1);
  TherapyOptions o = sites({5, 17});
  o.intrinsic_conduction = false;
  o.scar = {13, 14, 15, 16};  // paced from segment 5 the apex is never activated (above)
  o.warm_starts = TherapyOptions::WarmStarts::kAlways;
  const TherapySummary one = run_therapy_study(model, model.parameters().nominal(), z.estimated, z.posterior, o);
  o.ensemble.backend = Backend::kThreads;
  o.ensemble.threads = 2;
  const TherapySummary two = run_therapy_study(model, model.parameters().nominal(), z.estimated, z.posterior, o);
  ASSERT_EQ(one.points.count(), 3);  // star: the centre and +-sqrt(p + 1) along the axis
  EXPECT_EQ(one.seed_runs, 0);
  EXPECT_EQ(one.termination, Termination::kSomeFailed);
  EXPECT_FALSE(one.map[0].ok());
  EXPECT_NE(one.map[0].failure.find("never activated"), std::string::npos) << one.map[0].failure;
  ASSERT_TRUE(one.map[1].ok()) << one.map[1].failure;
  EXPECT_EQ(one.failures, 3);
  EXPECT_EQ(one.map[1].raw, two.map[1].raw);
  EXPECT_EQ(one.baseline.raw, two.baseline.raw);
  EXPECT_EQ(one.beats, two.beats);
}

// Automatic warm starts: where the seeds' Jacobians (72 beats on the 17-patch model, 8 on the
// sphere) cost less than the ~10 beats each warm point saves.
TEST(Therapy, WarmStartsAreUsedWhereTheySaveBeats) {
  EXPECT_TRUE(warm_starts_pay(18, 72, true));    // the benchmark's simplex map: 18 points per therapy
  EXPECT_FALSE(warm_starts_pay(4, 72, false));   // star on 2 parameters: the centre and 4
  EXPECT_FALSE(warm_starts_pay(3, 72, true));    // simplex on 2 parameters
  EXPECT_TRUE(warm_starts_pay(2, 8, false));     // the sphere, star on 1 parameter
}

TEST(Therapy, TimingPlacesTheStimuliOnTheIntrinsicClock) {
  TherapyOptions o = sites({6});
  o.timing = {0.18, 0.10, 0.02};  // PR 180 ms, AV 100 ms, LV 20 ms before RV
  const Therapy biv{"biv", false, Mode::kBiventricular, 0, o.timing};
  const act::PacingPlan plan = pacing_plan(biv, o);
  ASSERT_EQ(plan.stimuli.size(), 2u);
  EXPECT_NEAR(plan.stimuli[1].time, -0.08, 1e-12);  // LV at AV - PR
  EXPECT_NEAR(plan.stimuli[0].time, -0.06, 1e-12);  // RV 20 ms later
  EXPECT_EQ(plan.stimuli[1].site.segment, 6);
  o.timing.av_delay = 0.5;
  EXPECT_NE(o.validate().find("av_delay"), std::string::npos);
}

}  // namespace
}  // namespace sigmaheart::estimation::therapy
