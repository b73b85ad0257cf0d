#include "estimation/sensitivity/design.h"

#include "estimation/sensitivity/oat.h"
#include "estimation/sensitivity/sobol_indices.h"
#include "estimation/sensitivity/test_functions.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace sh = sigmaheart::estimation::sensitivity;
using sigmaheart::estimation::TransformKind;

namespace {
sigmaheart::estimation::PriorParameter range(double lower, double upper, double nominal) {
  return sigmaheart::estimation::PriorParameter::uniform("k", "1", lower, upper, nominal);
}
}  // namespace

TEST(Design, PhysicalRangesMapTheUnitIntervalLinearly) {
  const auto r = range(2.0, 6.0, 3.0);
  EXPECT_TRUE(r.validate().empty());
  EXPECT_DOUBLE_EQ(r.from_unit(0.0), 2.0);
  EXPECT_DOUBLE_EQ(r.from_unit(0.25), 3.0);
  EXPECT_DOUBLE_EQ(r.from_unit(1.0), 6.0);
  EXPECT_DOUBLE_EQ(r.to_unit(5.0), 0.75);
}

TEST(Design, EtaRangesRoundTripThroughTheirTransform) {
  auto r = range(0.2, 0.9, 0.5);
  r.space = sh::SamplingSpace::kEta;
  r.transform.kind = TransformKind::kLogit;
  r.transform.lower = 0.0;
  r.transform.upper = 1.0;
  ASSERT_TRUE(r.validate().empty()) << r.validate();
  EXPECT_NEAR(r.from_unit(0.0), 0.2, 1e-14);
  EXPECT_NEAR(r.from_unit(1.0), 0.9, 1e-14);
  for (double u : {0.1, 0.5, 0.8}) EXPECT_NEAR(r.to_unit(r.from_unit(u)), u, 1e-13);
  // Midpoint in eta is the logistic of the mean logit: not the physical midpoint.
  const double mid = 1.0 / (1.0 + std::exp(-0.5 * (std::log(0.2 / 0.8) + std::log(0.9 / 0.1))));
  EXPECT_NEAR(r.from_unit(0.5), mid, 1e-14);
}

TEST(Design, RangesThatTheTransformCannotMapAreRejected) {
  auto r = range(0.0, 1.0, 0.5);
  r.space = sh::SamplingSpace::kEta;
  r.transform.kind = TransformKind::kLogit;  // bounds (0, 1): eta(0) = -inf
  EXPECT_FALSE(r.validate().empty());
  auto l = range(-1.0, 1.0, 0.0);
  l.space = sh::SamplingSpace::kEta;
  l.transform.kind = TransformKind::kLog;  // log of a negative bound
  EXPECT_NE(l.validate().find("outside the transform"), std::string::npos) << l.validate();
  EXPECT_NE(range(1.0, 0.0, 0.5).validate().find("lower < upper"), std::string::npos);
  EXPECT_NE(range(0.0, 1.0, 2.0).validate().find("nominal"), std::string::npos);
}

TEST(Design, RangesMustMatchTheModelInputsByCountAndName) {
  const sh::IshigamiModel model;
  auto r = sh::ishigami_prior();
  EXPECT_TRUE(sh::validate_prior(r, model).empty());
  r.parameters[1].name = "x9";
  EXPECT_NE(sh::validate_prior(r, model).find("'x9'"), std::string::npos);
  r.parameters.pop_back();
  EXPECT_FALSE(sh::validate_prior(r, model).empty());
}

TEST(Design, AGaussianPriorIsNotAStudyRange) {
  const sh::IshigamiModel model;
  auto r = sh::ishigami_prior();
  r.parameters[0].kind = sigmaheart::estimation::PriorKind::kGaussian;
  EXPECT_NE(sh::validate_prior(r, model).find("uniform"), std::string::npos);
}

TEST(Design, RankingPutsTheLargestMagnitudeFirstAndNaNLast) {
  Eigen::MatrixXd score(4, 1);
  score << 0.5, std::nan(""), -2.0, 0.5;
  EXPECT_EQ(sh::rank_by(score, 0), (std::vector<int>{2, 0, 3, 1}));
}

TEST(Design, StudyStatusNamesAreStable) {
  EXPECT_STREQ(sh::to_string(sh::StudyStatus::kOk), "ok");
  EXPECT_STREQ(sh::to_string(sh::StudyStatus::kFailedRuns), "failed-runs");
  EXPECT_STREQ(sh::to_string(sh::StudyStatus::kFailedNominal), "failed-nominal");
}

TEST(Design, StreamsDependOnSeedAndIndexOnly) {
  EXPECT_EQ(sh::stream_seed(1, 2), sh::stream_seed(1, 2));
  EXPECT_NE(sh::stream_seed(1, 2), sh::stream_seed(2, 1));
  EXPECT_NE(sh::stream_seed(1, 2), sh::stream_seed(1, 3));
  auto a = sh::make_stream(5, 9);
  auto b = sh::make_stream(5, 9);
  EXPECT_EQ(a(), b());
  // uniform_index covers its range evenly: 60000 draws in 6 bins, each within 3 % of 10000.
  std::vector<int> bins(6, 0);
  for (int i = 0; i < 60000; ++i) ++bins[static_cast<size_t>(sh::uniform_index(a, 6))];
  for (int c : bins) EXPECT_NEAR(c, 10000, 300);
}

TEST(Design, PercentileIntervalInterpolatesOrderStatistics) {
  std::vector<double> v;
  for (int i = 0; i <= 100; ++i) v.push_back(static_cast<double>(100 - i));
  v.push_back(std::nan(""));
  const auto [lo, hi] = sh::percentile_interval(v, 0.9);
  EXPECT_DOUBLE_EQ(lo, 5.0);
  EXPECT_DOUBLE_EQ(hi, 95.0);
}

TEST(Design, EnumNamesRoundTripAndAcceptAliases) {
  for (auto m : {sh::OatMode::kRange, sh::OatMode::kRelative}) EXPECT_EQ(sh::parse_oat_mode(sh::to_string(m)), m);
  EXPECT_EQ(sh::parse_sobol_failure_policy("impute_mean"), sh::SobolFailurePolicy::kImputeMean);
  EXPECT_STREQ(sh::to_string(sh::SobolFailurePolicy::kImputeMean), "impute-mean");
  EXPECT_EQ(sh::parse_scrambling("off"), sh::Scrambling::kNone);
  EXPECT_STREQ(sh::to_string(sh::Scrambling::kLinearMatrixAndShift), "lms");
  EXPECT_FALSE(sh::parse_oat_mode("sideways").has_value());
}

// Reference values of the standard normal quantile (Abramowitz & Stegun 1964, Table 26.5).
TEST(SensitivityDesign, NormalQuantileMatchesTabulatedValues) {
  EXPECT_NEAR(sh::normal_quantile(0.975), 1.959963984540054, 1e-12);
  EXPECT_NEAR(sh::normal_quantile(0.995), 2.575829303548901, 1e-12);
  EXPECT_NEAR(sh::normal_quantile(0.95), 1.644853626951472, 1e-12);
  EXPECT_NEAR(sh::normal_quantile(0.025), -1.959963984540054, 1e-12);
  EXPECT_NEAR(sh::normal_quantile(0.5), 0.0, 1e-15);
  EXPECT_NEAR(sh::normal_quantile(1e-10), -6.361340902404056, 1e-9);
  EXPECT_THROW(sh::normal_quantile(0.0), std::invalid_argument);
  EXPECT_THROW(sh::normal_quantile(1.0), std::invalid_argument);
}

TEST(SensitivityDesign, FiniteStdSkipsNonFiniteValuesAndUsesTheSampleDivisor) {
  // {1, 2, 3, 4}: mean 2.5, sum of squares 5, sample variance 5/3.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NEAR(sh::finite_std({1.0, nan, 2.0, 3.0, 4.0}), std::sqrt(5.0 / 3.0), 1e-15);
  EXPECT_TRUE(std::isnan(sh::finite_std({1.0, nan})));
}
