#include "estimation/sensitivity/sobol_indices.h"

#include "estimation/sensitivity/test_functions.h"
#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

namespace sh = sigmaheart::estimation::sensitivity;
using sigmaheart::estimation::Backend;
using sigmaheart::testing::FunctionModel;
namespace model = sigmaheart::model;

namespace {

sh::SobolOptions options(int N, std::uint64_t seed = 2024) {
  sh::SobolOptions o;
  o.base_samples = N;
  o.seed = seed;
  o.bootstrap_samples = 400;
  o.convergence_levels = 4;
  o.ensemble.backend = Backend::kThreads;
  o.ensemble.threads = 2;
  return o;
}

// Ishigami, but runs with x1 > limit fail (a simulator that diverges in part of the space).
FunctionModel failing_ishigami(double limit) {
  sh::IshigamiModel ishigami;
  return FunctionModel({"x1", "x2", "x3"}, ishigami.outputs(),
                       [limit, ishigami](const Eigen::VectorXd& theta, Eigen::Ref<Eigen::VectorXd> z) mutable {
                         if (theta(0) > limit) return model::Status::Error(model::StatusCode::kDiverged, "diverged");
                         return ishigami.evaluate(theta, z);
                       });
}

// Two outputs from the same inputs: y1 = x1 + 2 x2, y2 = x2 x3 (vector output in one design).
FunctionModel two_outputs() {
  return FunctionModel({"x1", "x2", "x3"}, {{"y1", "1", ""}, {"y2", "1", ""}},
                       [](const Eigen::VectorXd& x, Eigen::Ref<Eigen::VectorXd> z) {
                         z(0) = x(0) + 2.0 * x(1);
                         z(1) = x(1) * x(2);
                         return model::Status::Ok();
                       });
}

}  // namespace

TEST(SobolIndices, IshigamiEstimatesContainTheExactIndicesInTheirBootstrapIntervals) {
  const auto exact = sh::ishigami_exact();
  const auto r = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), options(8192));
  ASSERT_TRUE(r.ok()) << r.report();
  EXPECT_EQ(r.runs, 8192 * 5);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r.estimate.S1(i, 0), exact.S1(i), 0.01) << r.report();
    EXPECT_NEAR(r.estimate.ST(i, 0), exact.ST(i), 0.01) << r.report();
    EXPECT_LE(r.estimate.S1_low(i, 0), exact.S1(i)) << r.report();
    EXPECT_GE(r.estimate.S1_high(i, 0), exact.S1(i)) << r.report();
    EXPECT_LE(r.estimate.ST_low(i, 0), exact.ST(i)) << r.report();
    EXPECT_GE(r.estimate.ST_high(i, 0), exact.ST(i)) << r.report();
    // SALib's S1_conf / ST_conf: the normal half-width z x bootstrap std covers the exact index
    // and is close to half the percentile interval (the bootstrap distribution is near normal).
    EXPECT_LE(std::abs(r.estimate.S1(i, 0) - exact.S1(i)), r.estimate.S1_conf(i, 0)) << r.report();
    EXPECT_LE(std::abs(r.estimate.ST(i, 0) - exact.ST(i)), r.estimate.ST_conf(i, 0)) << r.report();
    const double half_s1 = 0.5 * (r.estimate.S1_high(i, 0) - r.estimate.S1_low(i, 0));
    const double half_st = 0.5 * (r.estimate.ST_high(i, 0) - r.estimate.ST_low(i, 0));
    EXPECT_NEAR(r.estimate.S1_conf(i, 0), half_s1, 0.2 * half_s1) << "x" << i + 1;
    EXPECT_NEAR(r.estimate.ST_conf(i, 0), half_st, 0.2 * half_st) << "x" << i + 1;
    EXPECT_GT(r.estimate.S1_conf(i, 0), 0.0);
  }
  EXPECT_TRUE(r.estimate.S2.empty());  // second order is opt-in
}

// Second order on Ishigami (a = 7, b = 0.1): the only interaction is x1 x3, S13 = V13 / V =
// (8 b^2 pi^8 / 225) / V = 0.2437 (Ishigami & Homma 1990; Sobol' & Levitan 1999), S12 = S23 = 0.
TEST(SobolIndices, IshigamiSecondOrderIndicesMatchTheExactInteraction) {
  const auto exact = sh::ishigami_exact();
  EXPECT_NEAR(exact.S2(0, 2), 0.2437, 5e-5);
  auto o = options(8192);
  o.second_order = true;
  const auto r = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), o);
  ASSERT_TRUE(r.ok()) << r.report();
  EXPECT_EQ(r.runs, 8192 * 8);  // N (2p + 2)
  EXPECT_EQ(r.layout.block[static_cast<size_t>(7 * 8192)], "BA_3 (x3)");
  ASSERT_EQ(r.estimate.S2.size(), 1u);
  ASSERT_EQ(r.estimate.S2_conf.size(), 1u);
  const Eigen::MatrixXd& S2 = r.estimate.S2[0];
  const Eigen::MatrixXd& conf = r.estimate.S2_conf[0];
  ASSERT_EQ(S2.rows(), 3);
  ASSERT_EQ(S2.cols(), 3);
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k <= i; ++k) {
      EXPECT_TRUE(std::isnan(S2(i, k))) << i << "," << k;  // on and below the diagonal
      EXPECT_TRUE(std::isnan(conf(i, k))) << i << "," << k;
    }
  }
  std::ostringstream table;
  table << "S2\n" << S2 << "\nS2_conf\n" << conf << "\n" << r.report();
  RecordProperty("S2_13", std::to_string(S2(0, 2)) + " +- " + std::to_string(conf(0, 2)));
  RecordProperty("S2_12", std::to_string(S2(0, 1)) + " +- " + std::to_string(conf(0, 1)));
  RecordProperty("S2_23", std::to_string(S2(1, 2)) + " +- " + std::to_string(conf(1, 2)));
  EXPECT_NEAR(S2(0, 2), exact.S2(0, 2), 0.03) << table.str();
  EXPECT_NEAR(S2(0, 1), 0.0, 0.03) << table.str();
  EXPECT_NEAR(S2(1, 2), 0.0, 0.03) << table.str();
  for (auto [i, k] : std::vector<std::pair<int, int>>{{0, 1}, {0, 2}, {1, 2}}) {
    EXPECT_GT(conf(i, k), 0.0);
    EXPECT_LT(conf(i, k), 0.05) << table.str();
    EXPECT_LE(std::abs(S2(i, k) - exact.S2(i, k)), conf(i, k)) << i << "," << k << "\n" << table.str();
  }
  // The first- and total-order indices from the same design still match the exact ones.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r.estimate.S1(i, 0), exact.S1(i), 0.01) << r.report();
    EXPECT_NEAR(r.estimate.ST(i, 0), exact.ST(i), 0.01) << r.report();
  }
}

// 100 parameters: a Saltelli design of dimension 200, beyond the 53 dimensions of the old table.
// G-function with ten important inputs spread over the whole index range (so the AB columns come
// from Sobol' dimensions up to 200) and 90 unimportant ones (a = 99); exact indices from
// g_function_exact (Sobol' 2001).
TEST(SobolIndices, OneHundredParameterGFunctionMatchesTheExactIndices) {
  const int p = 100;
  Eigen::VectorXd a = Eigen::VectorXd::Constant(p, 99.0);
  const int important[] = {0, 9, 21, 33, 47, 58, 66, 78, 90, 99};
  const double coefficient[] = {0.0, 1.0, 4.5, 9.0, 0.5, 2.0, 3.0, 6.0, 1.5, 0.0};
  for (int t = 0; t < 10; ++t) a(important[t]) = coefficient[t];
  const auto exact = sh::g_function_exact(a);
  auto o = options(2048, 11);
  o.bootstrap_samples = 50;
  o.convergence_levels = 1;
  const auto r = sh::run_sobol(sh::GFunctionModel(a), sh::g_function_prior(p), o);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.runs, 2048 * 102);
  double worst_s1 = 0.0, worst_st = 0.0;
  int covered_s1 = 0, covered_st = 0;  // exact within S1_conf / ST_conf (95 % nominal)
  for (int i = 0; i < p; ++i) {
    const double e1 = std::abs(r.estimate.S1(i, 0) - exact.S1(i));
    const double et = std::abs(r.estimate.ST(i, 0) - exact.ST(i));
    worst_s1 = std::max(worst_s1, e1);
    worst_st = std::max(worst_st, et);
    covered_s1 += e1 <= r.estimate.S1_conf(i, 0) ? 1 : 0;
    covered_st += et <= r.estimate.ST_conf(i, 0) ? 1 : 0;
  }
  RecordProperty("worst_S1_error", std::to_string(worst_s1));
  RecordProperty("worst_ST_error", std::to_string(worst_st));
  RecordProperty("covered", std::to_string(covered_s1) + " S1, " + std::to_string(covered_st) + " ST");
  // Observed at this seed: 0.012 (S1) and 0.030 (ST, an a = 0 input with ST = 0.33).
  EXPECT_LT(worst_s1, 0.02) << "largest |S1 - exact| over 100 parameters";
  EXPECT_LT(worst_st, 0.04) << "largest |ST - exact| over 100 parameters";
  EXPECT_GE(covered_s1, 85);
  EXPECT_GE(covered_st, 85);
  // The two most important inputs (a = 0) lead the ranking, and an a = 99 input has ST < 0.005.
  const auto order = r.ranking(0);
  EXPECT_TRUE((order[0] == 0 && order[1] == 99) || (order[0] == 99 && order[1] == 0));
  EXPECT_LT(r.estimate.ST(50, 0), 0.005);
  EXPECT_GT(exact.S1(0), 0.1);
}

TEST(SobolIndices, SecondOrderResultsDoNotDependOnTheThreadCount) {
  auto serial = options(256);
  serial.second_order = true;
  serial.ensemble.backend = Backend::kSerial;
  auto threaded = serial;
  threaded.ensemble.backend = Backend::kThreads;
  threaded.ensemble.threads = 2;
  const auto a = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), serial);
  const auto b = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), threaded);
  ASSERT_EQ(a.estimate.S2.size(), 1u);
  ASSERT_EQ(b.estimate.S2.size(), 1u);
  const auto same = [](const Eigen::MatrixXd& x, const Eigen::MatrixXd& y) {
    return ((x.array() == y.array()) || (x.array().isNaN() && y.array().isNaN())).all();
  };
  EXPECT_TRUE(same(a.estimate.S2[0], b.estimate.S2[0]));
  EXPECT_TRUE(same(a.estimate.S2_conf[0], b.estimate.S2_conf[0]));
  EXPECT_TRUE(same(a.estimate.S1_conf, b.estimate.S1_conf));
}

TEST(SobolIndices, SecondOrderNeedsTwoParameters) {
  auto o = options(64);
  o.second_order = true;
  EXPECT_FALSE(o.validate(1).empty());
  EXPECT_TRUE(o.validate(2).empty());
}

TEST(SobolIndices, IntervalWidthsShrinkAsTheDesignGrows) {
  const auto r = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), options(8192));
  ASSERT_EQ(r.convergence.size(), 4u);
  EXPECT_EQ(r.convergence[0].n, 8192);
  EXPECT_EQ(r.convergence[3].n, 1024);
  for (int i = 0; i < 3; ++i) {
    for (size_t l = 0; l + 1 < r.convergence.size(); ++l) {
      const auto& big = r.convergence[l];
      const auto& small = r.convergence[l + 1];
      EXPECT_LT(big.ST_high(i, 0) - big.ST_low(i, 0), small.ST_high(i, 0) - small.ST_low(i, 0))
          << "x" << i + 1 << " n " << big.n;
    }
    // Eight times the rows: the width falls by about sqrt(8) ~ 2.8; at least by 2.
    const double w_big = r.convergence[0].S1_high(i, 0) - r.convergence[0].S1_low(i, 0);
    const double w_small = r.convergence[3].S1_high(i, 0) - r.convergence[3].S1_low(i, 0);
    EXPECT_LT(2.0 * w_big, w_small) << "x" << i + 1;
  }
}

TEST(SobolIndices, GFunctionEstimatesMatchTheExactIndices) {
  const Eigen::VectorXd a = sh::g_function_default_a();
  const auto exact = sh::g_function_exact(a);
  const auto r = sh::run_sobol(sh::GFunctionModel(a), sh::g_function_prior(8), options(8192, 7));
  ASSERT_TRUE(r.ok()) << r.report();
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(r.estimate.S1(i, 0), exact.S1(i), 0.01) << "x" << i + 1 << "\n" << r.report();
    EXPECT_NEAR(r.estimate.ST(i, 0), exact.ST(i), 0.01) << "x" << i + 1 << "\n" << r.report();
    EXPECT_LE(r.estimate.ST_low(i, 0), exact.ST(i)) << "x" << i + 1 << "\n" << r.report();
    EXPECT_GE(r.estimate.ST_high(i, 0), exact.ST(i)) << "x" << i + 1 << "\n" << r.report();
    EXPECT_LE(r.estimate.S1_low(i, 0), exact.S1(i)) << "x" << i + 1 << "\n" << r.report();
    EXPECT_GE(r.estimate.S1_high(i, 0), exact.S1(i)) << "x" << i + 1 << "\n" << r.report();
  }
  // The unimportant inputs have tiny total indices.
  for (int i = 4; i < 8; ++i) EXPECT_LT(r.estimate.ST(i, 0), 0.002);
}

TEST(SobolIndices, VectorOutputsAreAnalysedFromOneDesign) {
  // y1 = x1 + 2 x2 on [0,1]^3: S1 = ST = (1/5, 4/5, 0). y2 = x2 x3: S1 = (0, 3/7, 3/7),
  // ST = (0, 4/7, 4/7) (V = 7/144, V2 = V3 = 1/48, V23 = 1/144).
  const auto r = sh::run_sobol(two_outputs(), sh::g_function_prior(3), options(4096));
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r.estimate.S1.rows(), 3);
  ASSERT_EQ(r.estimate.S1.cols(), 2);
  EXPECT_EQ(r.runs, 4096 * 5);
  const Eigen::Vector3d S1_y1(0.2, 0.8, 0.0), S1_y2(0.0, 3.0 / 7.0, 3.0 / 7.0);
  const Eigen::Vector3d ST_y2(0.0, 4.0 / 7.0, 4.0 / 7.0);
  EXPECT_LT((r.estimate.S1.col(0) - S1_y1).cwiseAbs().maxCoeff(), 0.01) << r.report();
  EXPECT_LT((r.estimate.ST.col(0) - S1_y1).cwiseAbs().maxCoeff(), 0.01) << r.report();
  EXPECT_LT((r.estimate.S1.col(1) - S1_y2).cwiseAbs().maxCoeff(), 0.02) << r.report();
  EXPECT_LT((r.estimate.ST.col(1) - ST_y2).cwiseAbs().maxCoeff(), 0.02) << r.report();
}

TEST(SobolIndices, AFailedRunStopsTheStudyWithTheFailedRowsListedAndNoIndices) {
  // x1 > 3.1 fails: a few percent of the A, B and AB_i rows.
  const auto r = sh::run_sobol(failing_ishigami(3.1), sh::ishigami_prior(), options(256));
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.imputed);
  ASSERT_FALSE(r.failed_runs.empty());
  int expected = 0;
  for (int run = 0; run < r.runs; ++run) expected += r.thetas(run, 0) > 3.1 ? 1 : 0;
  EXPECT_EQ(static_cast<int>(r.failed_runs.size()), expected);
  for (const auto& f : r.failed_runs) {
    EXPECT_GT(f.theta(0), 3.1);
    EXPECT_EQ(f.status.code, model::StatusCode::kDiverged);
    EXPECT_EQ(f.run, [&] {
      const int block = f.block == "A" ? 0 : f.block == "B" ? 1 : 2 + (f.block[3] - '1');
      return block * r.N + f.design_row;
    }());
  }
  EXPECT_EQ(r.estimate.S1.size(), 0);  // no silent numbers
  const std::string report = r.report();
  EXPECT_NE(report.find("INVALID"), std::string::npos) << report;
  EXPECT_NE(report.find(std::to_string(expected) + " of " + std::to_string(r.runs) + " runs failed"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("diverged"), std::string::npos) << report;
}

TEST(SobolIndices, ImputationIsOptInAndFlagged) {
  auto o = options(1024);
  o.failure_policy = sh::SobolFailurePolicy::kImputeMean;
  const auto r = sh::run_sobol(failing_ishigami(3.1), sh::ishigami_prior(), o);
  EXPECT_TRUE(r.ok());
  EXPECT_TRUE(r.imputed);
  EXPECT_FALSE(r.failed_runs.empty());
  EXPECT_NE(r.report().find("impute-mean"), std::string::npos);
  // Failed outputs stay NaN in Z (imputation is applied only to the estimator's copy).
  EXPECT_TRUE(std::isnan(r.Z(r.failed_runs.front().run, 0)));
  EXPECT_TRUE(r.estimate.S1.allFinite());
}

TEST(SobolIndices, ResultsDoNotDependOnTheThreadCount) {
  auto serial = options(512);
  serial.ensemble.backend = Backend::kSerial;
  auto threaded = options(512);
  threaded.ensemble.threads = 2;
  const auto a = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), serial);
  const auto b = sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), threaded);
  EXPECT_EQ((a.Z - b.Z).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.estimate.S1 - b.estimate.S1).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.estimate.ST_low - b.estimate.ST_low).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.estimate.ST_high - b.estimate.ST_high).cwiseAbs().maxCoeff(), 0.0);
}

TEST(SobolIndices, EtaSpaceSamplingOfALogTransformIsLogUniform) {
  // A log transform sampled in eta on [1, 100]: log10(theta) of the design is uniform on [0, 2],
  // so half the A rows lie below 10.
  auto prior = sh::g_function_prior(3);
  prior.parameters[0].lower = 1.0;
  prior.parameters[0].upper = 100.0;
  prior.parameters[0].theta_nominal = 10.0;
  prior.parameters[0].space = sh::SamplingSpace::kEta;
  prior.parameters[0].transform.kind = sigmaheart::estimation::TransformKind::kLog;
  prior.parameters[0].transform.reference = 10.0;
  const Eigen::MatrixXd U = sh::saltelli_design(3, 1024, sh::Scrambling::kLinearMatrixAndShift, 1);
  const Eigen::MatrixXd T = prior.unit_to_theta(U);
  int below = 0;
  for (int j = 0; j < 1024; ++j) below += T(j, 0) < 10.0 ? 1 : 0;
  EXPECT_EQ(below, 512);
  EXPECT_GE(T.col(0).minCoeff(), 1.0);
  EXPECT_LE(T.col(0).maxCoeff(), 100.0);
}

TEST(SobolIndices, InvalidOptionsAreRejectedBeforeAnyRun) {
  auto o = options(1000);  // not a power of two
  EXPECT_THROW(sh::run_sobol(sh::IshigamiModel(), sh::ishigami_prior(), o), std::invalid_argument);
  auto prior = sh::ishigami_prior();
  prior.parameters.pop_back();
  EXPECT_THROW(sh::run_sobol(sh::IshigamiModel(), prior, options(64)), std::invalid_argument);
}

// Sobol' indices are invariant to adding a constant to the output; the centred first-order
// estimator (sobol_indices.h) keeps that in finite samples too, so an output with a large mean
// (P_max ~124 mmHg with a 14 mmHg spread) gets the same S1 and interval width as its centred twin.
namespace {
FunctionModel shifted_ishigami() {
  return FunctionModel({"x1", "x2", "x3"}, {{"y", "1", "Ishigami"}, {"y_shifted", "1", "y + 1000"}},
                       [ishigami = sh::IshigamiModel()](const Eigen::VectorXd& theta,
                                                        Eigen::Ref<Eigen::VectorXd> z) mutable {
                         Eigen::VectorXd y(1);
                         const model::Status s = ishigami.evaluate(theta, y);
                         z(0) = y(0);
                         z(1) = y(0) + 1000.0;
                         return s;
                       });
}
}  // namespace

TEST(SobolIndices, FirstOrderIndicesDoNotDependOnAnOutputOffset) {
  const auto r = sh::run_sobol(shifted_ishigami(), sh::ishigami_prior(), options(1024));
  ASSERT_TRUE(r.ok()) << r.report();
  const auto exact = sh::ishigami_exact();
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r.estimate.S1(i, 1), r.estimate.S1(i, 0), 1e-9);
    EXPECT_NEAR(r.estimate.S1_high(i, 1) - r.estimate.S1_low(i, 1),
                r.estimate.S1_high(i, 0) - r.estimate.S1_low(i, 0), 1e-9);
    EXPECT_NEAR(r.estimate.S1(i, 1), exact.S1(i), 0.05);
    EXPECT_LT(r.estimate.S1_high(i, 1) - r.estimate.S1_low(i, 1), 0.2);  // uncentred it grows with the offset
  }
}
