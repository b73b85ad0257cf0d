#include "estimation/specificity/specificity.h"

#include "estimation/sensitivity/design.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace sp = sigmaheart::estimation::specificity;
namespace model = sigmaheart::model;

namespace {

// Standard normal draws by Box-Muller from a seeded stream (independent of the standard
// library's distribution algorithms).
double normal(std::mt19937_64& rng) {
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) / 9007199254740992.0;
  const double u2 = (static_cast<double>(rng() >> 11) + 0.5) / 9007199254740992.0;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

// A cohort of 12 volunteers and 12 patients; four parameters with the same distribution in both
// groups except "sigma0" (index 2), whose mean is 3 standard deviations lower in patients.
struct Cohort {
  std::vector<sp::CohortCase> cases;
  std::vector<sp::CaseCalibration> truth;
};

Cohort make_cohort() {
  auto rng = sigmaheart::estimation::sensitivity::make_stream(42, 0);
  Cohort c;
  const Eigen::Vector4d centre(1.0, 10.0, 100.0, 0.5), spread(0.2, 2.0, 10.0, 0.1);
  for (int i = 0; i < 24; ++i) {
    const bool patient = i >= 12;
    sp::CohortCase k;
    k.id = (patient ? "hf" : "vol") + std::to_string(i % 12);
    k.group = patient ? "heart-failure" : "volunteer";
    k.source = k.id + ".csv";
    sp::CaseCalibration cal;
    cal.mean.resize(4);
    for (int j = 0; j < 4; ++j) cal.mean(j) = centre(j) + spread(j) * normal(rng);
    if (patient) cal.mean(2) -= 3.0 * spread(2);
    cal.sd = 0.1 * spread;
    c.cases.push_back(k);
    c.truth.push_back(cal);
  }
  return c;
}

sp::SpecificityOptions options() {
  sp::SpecificityOptions o;
  o.parameters = {"tau", "R_p", "sigma0", "k_s"};
  return o;
}

}  // namespace

TEST(Specificity, TheOnlyParameterThatDiffersBetweenGroupsIsRankedFirst) {
  const Cohort cohort = make_cohort();
  int calls = 0;
  const auto r = sp::run_specificity(
      cohort.cases,
      [&](const sp::CohortCase& k) {
        ++calls;
        for (size_t i = 0; i < cohort.cases.size(); ++i) {
          if (cohort.cases[i].id == k.id) return cohort.truth[i];
        }
        throw std::runtime_error("unknown case");
      },
      options());
  EXPECT_EQ(calls, 24);
  EXPECT_EQ(r.group_a, "volunteer");
  EXPECT_EQ(r.group_b, "heart-failure");
  ASSERT_EQ(r.ranking.size(), 4u);
  EXPECT_EQ(r.ranking.front(), 2) << r.report();
  const auto& s = r.parameters[2];
  EXPECT_EQ(s.name, "sigma0");
  // Every difference is of heart-failure (B) against volunteers (A): sigma0 is lower in B.
  EXPECT_LT(s.mann_whitney.auc, 0.1) << r.report();
  EXPECT_EQ(s.direction, "lower");
  EXPECT_LT(s.welch.p_value, 1e-4) << r.report();
  EXPECT_LT(s.effect.hedges_g, -1.5);
  EXPECT_LT(s.welch.mean_difference, 0.0);
  EXPECT_TRUE(s.different) << r.report();
  EXPECT_LT(s.p_adjusted, 1e-3);
  // The others do not separate at the 1 % level, and none is reported as different after Holm.
  for (int j : {0, 1, 3}) {
    const auto& q = r.parameters[static_cast<size_t>(j)];
    EXPECT_GT(q.welch.p_value, 0.01) << j;
    EXPECT_FALSE(q.different) << j << r.report();
    EXPECT_GE(q.p_adjusted, q.posterior_welch.p_value) << j;
  }
  ASSERT_TRUE(r.classifier.valid);
  EXPECT_GE(r.classifier.accuracy, 0.8) << r.report();
  EXPECT_EQ(r.classifier.total, 24);
  EXPECT_NEAR(s.posterior_sd_a, 1.0, 1e-12);
}

TEST(Specificity, FailedCalibrationsAreDroppedAndListed) {
  const Cohort cohort = make_cohort();
  const auto r = sp::run_specificity(
      cohort.cases,
      [&](const sp::CohortCase& k) {
        if (k.id == "vol3") throw std::runtime_error("observation file unreadable");
        if (k.id == "hf5") {
          sp::CaseCalibration bad;
          bad.status = model::Status::Error(model::StatusCode::kDiverged, "all sigma points failed");
          return bad;
        }
        for (size_t i = 0; i < cohort.cases.size(); ++i) {
          if (cohort.cases[i].id == k.id) return cohort.truth[i];
        }
        throw std::runtime_error("unknown case");
      },
      options());
  EXPECT_EQ(r.cases.size(), 22u);
  ASSERT_EQ(r.failed_cases.size(), 2u);
  EXPECT_EQ(r.failed_cases[0], "vol3");
  EXPECT_EQ(r.failed_cases[1], "hf5");
  const std::string report = r.report();
  EXPECT_NE(report.find("observation file unreadable"), std::string::npos) << report;
  EXPECT_NE(report.find("all sigma points failed"), std::string::npos) << report;
  EXPECT_EQ(r.ranking.front(), 2);
}

TEST(Specificity, LdaSeparatesTwoCleanClustersPerfectly) {
  // Two well-separated clusters in 2D: leave-one-out accuracy 1.
  Eigen::MatrixXd X(8, 2);
  X << 0, 0, 0.1, 0.2, -0.1, 0.1, 0.2, -0.1,  //
      5, 5, 5.1, 4.9, 4.8, 5.2, 5.2, 5.0;
  const std::vector<int> label = {0, 0, 0, 0, 1, 1, 1, 1};
  const auto c = sp::loo_lda(X, label, 0.2);
  ASSERT_TRUE(c.valid);
  EXPECT_EQ(c.correct, 8);
  EXPECT_DOUBLE_EQ(c.accuracy, 1.0);
}

TEST(Specificity, TooSmallGroupsAreRejectedWithAMessage) {
  std::vector<sp::CaseEstimate> cases = {{"a", "g1", Eigen::Vector2d(1, 2), Eigen::Vector2d(0.1, 0.1)},
                                         {"b", "g2", Eigen::Vector2d(1, 2), Eigen::Vector2d(0.1, 0.1)},
                                         {"c", "g2", Eigen::Vector2d(1, 3), Eigen::Vector2d(0.1, 0.1)}};
  sp::SpecificityOptions o;
  o.parameters = {"p", "q"};
  EXPECT_THROW(sp::compare_groups(cases, o), std::invalid_argument);
  o.parameters = {};
  EXPECT_FALSE(o.validate().empty());
}

TEST(Specificity, CasesCalibratedInParallelGiveTheSameResult) {
  const Cohort cohort = make_cohort();
  auto lookup = [&](const sp::CohortCase& k) {
    for (size_t i = 0; i < cohort.cases.size(); ++i) {
      if (cohort.cases[i].id == k.id) return cohort.truth[i];
    }
    throw std::runtime_error("unknown case");
  };
  sp::SpecificityOptions serial = options(), parallel = options();
  parallel.case_threads = 2;
  int reported = 0;
  parallel.progress = [&](int done, int total, const std::string&) {
    EXPECT_EQ(total, 24);
    reported = std::max(reported, done);
  };
  const auto a = sp::run_specificity(cohort.cases, lookup, serial);
  const auto b = sp::run_specificity(cohort.cases, lookup, parallel);
  EXPECT_EQ(reported, 24);
  ASSERT_EQ(a.cases.size(), b.cases.size());
  for (size_t i = 0; i < a.cases.size(); ++i) EXPECT_EQ(a.cases[i].id, b.cases[i].id);  // cohort order
  EXPECT_EQ(a.ranking, b.ranking);
  EXPECT_EQ(a.parameters[2].welch.p_value, b.parameters[2].welch.p_value);
  EXPECT_EQ(a.classifier.correct, b.classifier.correct);
}

TEST(Specificity, LeaveOneOutWorksWithTwoCasesInAGroup) {
  // 5 volunteers around 0, 2 patients around 5 on the first feature: every held-out case is
  // classified from a training set that keeps one case of its group.
  Eigen::MatrixXd X(7, 2);
  X << 0.1, 1.0, -0.2, 0.8, 0.0, 1.1, 0.3, 0.9, -0.1, 1.2, 5.0, 1.0, 5.3, 0.9;
  const auto c = sp::loo_lda(X, {0, 0, 0, 0, 0, 1, 1}, 0.2);
  ASSERT_TRUE(c.valid) << c.message;
  EXPECT_EQ(c.correct, 7);
  EXPECT_FALSE(sp::loo_lda(X.topRows(6), {0, 0, 0, 0, 0, 1}, 0.2).valid);
}

TEST(Specificity, TooFewCalibratedCasesIsAStatusWithPerCaseResultsKept) {
  // Every patient fails: no statistics, but the volunteers' estimates stay in the summary.
  const Cohort cohort = make_cohort();
  sp::SpecificityOptions named_groups = options();
  named_groups.group_a = "volunteer";
  named_groups.group_b = "heart-failure";
  const auto r = sp::run_specificity(
      cohort.cases,
      [&](const sp::CohortCase& k) {
        const auto i = static_cast<size_t>(&k - cohort.cases.data());
        if (k.group == "heart-failure") {
          sp::CaseCalibration bad;
          bad.termination = "aborted-failures";
          bad.status = sigmaheart::model::Status::Error(sigmaheart::model::StatusCode::kDiverged, "diverged");
          return bad;
        }
        return cohort.truth[i];
      },
      named_groups);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.status, sp::SpecificityStatus::kNoStatistics);
  EXPECT_NE(r.message.find("at least 2"), std::string::npos) << r.message;
  ASSERT_EQ(r.calibrations.size(), 24u);
  const Eigen::MatrixXd mean = r.means();
  EXPECT_DOUBLE_EQ(mean(0, 2), cohort.truth[0].mean(2));
  EXPECT_TRUE(std::isnan(mean(12, 2)));
  EXPECT_EQ(r.case_status(0), "ok");
  EXPECT_EQ(r.case_status(12), "aborted-failures: diverged");
  EXPECT_FALSE(r.any_truth());
}

TEST(Specificity, RelativeErrorOfAFitIsTheMeanRelativeMisfitInPercent) {
  sp::CaseCalibration c;
  c.observed = Eigen::Vector2d(100.0, 0.5);
  c.fitted = Eigen::Vector2d(101.0, 0.49);
  EXPECT_NEAR(c.relative_error_percent(), 100.0 * (0.01 + 0.02) / 2.0, 1e-12);
  EXPECT_NEAR(c.relative_error_percent(Eigen::Vector2d(1e6, 100.0)), 1.5, 1e-12);
  c.fitted.resize(0);
  EXPECT_TRUE(std::isnan(c.relative_error_percent()));
}

TEST(Specificity, KnownValuesAreReportedPerCaseWithNaNWhereUnknown) {
  Cohort cohort = make_cohort();
  cohort.cases[1].truth = Eigen::Vector4d(1.0, std::nan(""), 90.0, 0.4);
  const auto r = sp::run_specificity(
      cohort.cases,
      [&](const sp::CohortCase& k) { return cohort.truth[static_cast<size_t>(&k - cohort.cases.data())]; },
      options());
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.any_truth());
  const Eigen::MatrixXd t = r.truths();
  EXPECT_DOUBLE_EQ(t(1, 2), 90.0);
  EXPECT_TRUE(std::isnan(t(1, 1)));
  EXPECT_TRUE(std::isnan(t(0, 0)));
}

namespace {
// The cohort's calibrations, with the cases of `failing` returning a failed status.
sp::CalibrateFn failing_some(const Cohort& cohort, const std::vector<std::string>& failing) {
  return [&cohort, failing](const sp::CohortCase& k) {
    const auto i = static_cast<size_t>(&k - cohort.cases.data());
    if (std::find(failing.begin(), failing.end(), k.id) != failing.end()) {
      sp::CaseCalibration bad;
      bad.termination = "aborted-failures";
      bad.status = model::Status::Error(model::StatusCode::kDiverged, "diverged");
      return bad;
    }
    return cohort.truth[i];
  };
}
}  // namespace

TEST(Specificity, TooFewSubjectsLeftAfterFailuresMeansNoStatistics) {
  // The written policy: failed cases are left out; with min_cases_per_group 4, 3 calibrated patients
  // are too few (status no-statistics, per-case results kept) and 4 are enough.
  const Cohort cohort = make_cohort();
  sp::SpecificityOptions o = options();
  o.min_cases_per_group = 4;
  const std::vector<std::string> nine = {"hf0", "hf1", "hf2", "hf3", "hf4", "hf5", "hf6", "hf7", "hf8"};
  const auto r = sp::run_specificity(cohort.cases, failing_some(cohort, nine), o);
  EXPECT_EQ(r.status, sp::SpecificityStatus::kNoStatistics);
  EXPECT_NE(r.message.find("3 calibrated cases"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("at least 4"), std::string::npos) << r.message;
  EXPECT_EQ(r.failed_cases.size(), 9u);
  EXPECT_EQ(r.case_status(12), "aborted-failures: diverged");
  const auto eight = std::vector<std::string>(nine.begin(), nine.end() - 1);
  const auto ok = sp::run_specificity(cohort.cases, failing_some(cohort, eight), o);
  ASSERT_TRUE(ok.ok()) << ok.message;
  EXPECT_EQ(ok.parameters[2].b.n, 4);
  EXPECT_EQ(ok.parameters[2].a.n, 12);
  o.min_cases_per_group = 1;
  EXPECT_FALSE(o.validate().empty());
}

TEST(Specificity, LargePosteriorSpreadKeepsAParameterFromBeingFlagged) {
  // The same cohort, once with posterior sds of 0.1 and once of 3 between-subject sds: sigma0 is
  // 3 sds lower in the patients, significant on the means either way, but with that posterior
  // spread the primary test (posterior variance carried in) no longer calls it different.
  Cohort cohort = make_cohort();
  std::vector<sp::CaseEstimate> precise, vague;
  const Eigen::Vector4d spread(0.2, 2.0, 10.0, 0.1);
  for (size_t i = 0; i < cohort.cases.size(); ++i) {
    const auto& c = cohort.cases[i];
    precise.push_back({c.id, c.group, cohort.truth[i].mean, 0.1 * spread});
    vague.push_back({c.id, c.group, cohort.truth[i].mean, 3.0 * spread});
  }
  const auto a = sp::compare_groups(precise, options());
  const auto b = sp::compare_groups(vague, options());
  EXPECT_TRUE(a.parameters[2].different);
  EXPECT_EQ(a.parameters[2].welch.p_value, b.parameters[2].welch.p_value);
  EXPECT_LT(b.parameters[2].welch.p_value, 1e-4);
  EXPECT_FALSE(b.parameters[2].different) << b.report();
  EXPECT_GT(b.parameters[2].p_adjusted, 0.05);
}

TEST(Specificity, BenjaminiHochbergIsNeverStricterThanHolm) {
  const Cohort cohort = make_cohort();
  std::vector<sp::CaseEstimate> cases;
  for (size_t i = 0; i < cohort.cases.size(); ++i) {
    cases.push_back({cohort.cases[i].id, cohort.cases[i].group, cohort.truth[i].mean, cohort.truth[i].sd});
  }
  sp::SpecificityOptions holm = options(), bh = options();
  bh.adjust = sp::PAdjust::kBenjaminiHochberg;
  const auto h = sp::compare_groups(cases, holm);
  const auto b = sp::compare_groups(cases, bh);
  for (size_t j = 0; j < 4; ++j) {
    EXPECT_LE(b.parameters[j].p_adjusted, h.parameters[j].p_adjusted + 1e-15) << j;
    EXPECT_GE(b.parameters[j].p_adjusted, b.parameters[j].posterior_welch.p_value) << j;
  }
  EXPECT_NE(b.report().find("benjamini-hochberg"), std::string::npos);
}
