#include "estimation/ut_calibration.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>
#include <vector>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;
using sigmaheart::testing::indexed;

observers::ObservationSet observations(const Eigen::VectorXd& y, const Eigen::MatrixXd& R) {
  observers::ObservationSet obs;
  for (int i = 0; i < y.size(); ++i) {
    obs.names.push_back(indexed("o", i));
    obs.units.push_back("1");
  }
  obs.y = y;
  obs.R = R;
  return obs;
}

Prior identity_parameters(const Eigen::VectorXd& mean, const Eigen::VectorXd& std) {
  Prior out;
  for (int j = 0; j < mean.size(); ++j) {
    out.parameters.push_back(
        PriorParameter::gaussian(indexed("t", j), "1", mean(j), std(j), SpreadKind::kEta, {}));
  }
  return out;
}

UtOptions serial_options(SigmaOptions sigma = {}) {
  UtOptions o;
  o.sigma = sigma;
  o.ensemble.backend = Backend::kSerial;
  return o;
}

// z = H theta + c with observations of very different scales (a volume in m^3, a pressure in Pa).
struct LinearProblem {
  Eigen::MatrixXd H{4, 3};
  Eigen::VectorXd c{4};
  Eigen::VectorXd m0{3}, s0{3}, y{4};
  Eigen::MatrixXd R{4, 4};
  LinearProblem() {
    H << 2e-6, -1e-6, 0.5e-6,  //
        1e3, 2e3, -1e3,        //
        0.3, 0.1, 0.9,         //
        -4e2, 1e2, 3e2;
    c << 1.2e-4, 1.5e4, 0.7, 2e3;
    m0 << 1.0, -0.5, 2.0;
    s0 << 0.3, 0.8, 0.5;
    y << 1.26e-4, 1.48e4, 2.4, 2.35e3;
    const Eigen::Vector4d sd(2e-6, 150.0, 0.05, 40.0);
    Eigen::Matrix4d C = Eigen::Matrix4d::Identity();
    C(1, 3) = C(3, 1) = 0.3;  // correlated pressure errors
    R = sd.asDiagonal() * C * sd.asDiagonal();
  }
  FunctionModel model() const {
    return FunctionModel(3, 4, [H = H, c = c](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
      z = H * t + c;
      return model::Status::Ok();
    });
  }
  // Information form, an algebra route independent of the gain form.
  void exact(Eigen::VectorXd& mean, Eigen::MatrixXd& P) const {
    const Eigen::MatrixXd P0inv = s0.array().square().inverse().matrix().asDiagonal();
    const Eigen::MatrixXd Rinv = R.inverse();
    P = (P0inv + H.transpose() * Rinv * H).inverse();
    mean = P * (P0inv * m0 + H.transpose() * Rinv * (y - c));
  }
};

TEST(UtCalibration, OneUpdateEqualsTheBayesianPosteriorOnALinearGaussianModelForEveryRule) {
  const LinearProblem lp;
  Eigen::VectorXd mean;
  Eigen::MatrixXd P;
  lp.exact(mean, P);
  const FunctionModel fm = lp.model();
  for (const SigmaOptions& sigma :
       {SigmaOptions{SigmaRule::kSimplex}, SigmaOptions{SigmaRule::kCanonical},
        SigmaOptions{SigmaRule::kStar, 0.5}, SigmaOptions{SigmaRule::kScaled, 0.0, 0.5, 2.0}}) {
    UtCalibration cal(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R),
                      serial_options(sigma));
    const UtSummary s = cal.run();
    ASSERT_EQ(s.termination, UtTermination::kCompleted) << s.message;
    EXPECT_LT((s.eta_mean - mean).cwiseAbs().maxCoeff(), 1e-10) << to_string(sigma.rule);
    EXPECT_LT((s.eta_covariance - P).cwiseAbs().maxCoeff(), 1e-10 * P.cwiseAbs().maxCoeff())
        << to_string(sigma.rule);
    // The reported SI gain is the textbook one.
    const Eigen::MatrixXd P0 = lp.s0.array().square().matrix().asDiagonal();
    const Eigen::MatrixXd K = P0 * lp.H.transpose() * (lp.H * P0 * lp.H.transpose() + lp.R).inverse();
    EXPECT_LT((s.iterations[0].gain - K).norm(), 1e-9 * K.norm());
  }
}

TEST(UtCalibration, FitAfterIsBetterThanFitBeforeAndReportsPerObservation) {
  const LinearProblem lp;
  const FunctionModel fm = lp.model();
  UtCalibration cal(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R),
                    serial_options());
  const UtSummary s = cal.run();
  ASSERT_TRUE(s.fit_before && s.fit_after);
  EXPECT_NEAR(s.fit_before->z(1), (lp.H * lp.m0 + lp.c)(1), 1e-8);
  EXPECT_NEAR(s.fit_before->residual(1), lp.y(1) - s.fit_before->z(1), 1e-9);
  EXPECT_LT(s.fit_after->misfit(), 0.2 * s.fit_before->misfit());
  // 4 sigma points + centre, then the fit at the result.
  EXPECT_EQ(s.simulations, 6);
  EXPECT_NE(s.brief_report().find("one-shot, simplex, 3 params, 4 obs"), std::string::npos);
  EXPECT_NE(s.full_report().find("  o1: y 14800"), std::string::npos) << s.full_report();
}

TEST(UtCalibration, SummaryCarriesTheFitMetricsThePriorStdAndTheErrorsAgainstATruth) {
  const LinearProblem lp;
  const FunctionModel fm = lp.model();
  UtOptions opt = serial_options();
  opt.truth = lp.m0 * 1.1;
  const UtSummary s = UtCalibration(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt).run();
  ASSERT_TRUE(s.ok()) << s.message;
  const int m = static_cast<int>(lp.y.size());
  // RMS normalised residual = sqrt(2 misfit / m); relative errors from y and z by hand.
  EXPECT_NEAR(s.metrics_before.rms_normalised_residual, std::sqrt(2 * s.fit_before->misfit() / m), 1e-12);
  EXPECT_NEAR(s.metrics_after.rms_normalised_residual, std::sqrt(2 * s.fit_after->misfit() / m), 1e-12);
  EXPECT_LT(s.metrics_after.rms_normalised_residual, s.metrics_before.rms_normalised_residual);
  EXPECT_NEAR(s.metrics_after.relative_error_percent(1),
              100 * std::abs(lp.y(1) - s.fit_after->z(1)) / std::abs(lp.y(1)), 1e-10);
  // Identity transforms: the prior std in theta is the std in eta.
  EXPECT_LT((s.theta_prior_std - lp.s0).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((s.theta_prior - lp.m0).cwiseAbs().maxCoeff(), 1e-15);
  ASSERT_TRUE(s.truth_error_percent);
  for (int j = 0; j < lp.m0.size(); ++j) {
    EXPECT_NEAR((*s.truth_error_percent)(j),
                100 * std::abs(s.theta_of_eta_mean(j) - 1.1 * lp.m0(j)) / std::abs(1.1 * lp.m0(j)), 1e-10);
  }
}

TEST(UtCalibration, ReportsTransformOfEtaMeanAndSigmaPointThetaMeanSeparately) {
  // z = log(theta / ref): linear in eta for a log transform, so the posterior in eta is Gaussian
  // with known moments; E[theta] = ref exp(mu + s^2 / 2) differs from ref exp(mu).
  const double ref = 2.0e4, s0 = 0.3, r = 0.2, y = 0.4;
  FunctionModel fm(1, 1, [&](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z(0) = std::log(t(0) / ref);
    return model::Status::Ok();
  });
  Prior prior;
  // relative spread = std in eta for a log transform
  prior.parameters.push_back(PriorParameter::gaussian("t0", "1", ref, s0, SpreadKind::kRelative,
                                                      Transform{TransformKind::kLog, ref}));
  UtCalibration cal(fm, prior, observations(Eigen::VectorXd::Constant(1, y),
                                            Eigen::MatrixXd::Constant(1, 1, r * r)),
                    serial_options({SigmaRule::kStar, 2.0}));
  const UtSummary s = cal.run();
  ASSERT_TRUE(s.ok()) << s.message;
  const double var = 1.0 / (1.0 / (s0 * s0) + 1.0 / (r * r));
  const double mu = var * y / (r * r);
  EXPECT_NEAR(s.eta_prior_std(0), s0, 1e-15);
  EXPECT_NEAR(s.eta_mean(0), mu, 1e-12);
  EXPECT_NEAR(s.eta_std(0), std::sqrt(var), 1e-12);
  EXPECT_NEAR(s.theta_of_eta_mean(0), ref * std::exp(mu), 1e-8);
  // Star points m +- sqrt(3 var), weights 1/6, 2/3: E[theta] to fourth order in the std.
  const double ut_mean = ref * std::exp(mu) * (2.0 / 3.0 + std::cosh(std::sqrt(3 * var)) / 3.0);
  EXPECT_NEAR(s.theta_sigma_mean(0), ut_mean, 1e-10 * ref);
  EXPECT_NEAR(s.theta_sigma_mean(0), ref * std::exp(mu + var / 2), 1e-6 * ref);
  EXPECT_NEAR(s.theta_std(0), ref * std::exp(mu) * std::sqrt(var), 1e-8);
}

TEST(UtCalibration, IteratedCalibrationRecoversTheTruthOfAnExponentialModelFromNoiseFreeData) {
  const Eigen::Vector2d truth(0.8, -0.4);
  auto h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z(0) = std::exp(t(0));
    z(1) = std::exp(t(1));
    z(2) = std::exp(t(0) + 2.0 * t(1));
    return model::Status::Ok();
  };
  FunctionModel fm(2, 3, h);
  Eigen::VectorXd y(3);
  h(truth, y);
  const Eigen::Matrix3d R = (0.02 * y).array().square().matrix().asDiagonal();
  UtOptions opt = serial_options();
  opt.mode = UtMode::kIterateKeepSpread;
  opt.max_iterations = 60;
  opt.tolerance = 1e-10;
  UtCalibration cal(fm, identity_parameters(Eigen::Vector2d(0.2, 0.3), Eigen::Vector2d(0.5, 0.5)),
                    observations(y, R), opt);
  const UtSummary s = cal.run();
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  EXPECT_EQ(s.innovation, UtInnovation::kCenter);
  EXPECT_LT((s.eta_mean - truth).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT(s.fit_after->misfit(), 1e-12);
  // One-shot from the same prior is far from the truth: the iterations did the work.
  UtCalibration once(fm, identity_parameters(Eigen::Vector2d(0.2, 0.3), Eigen::Vector2d(0.5, 0.5)),
                     observations(y, R), serial_options());
  EXPECT_GT((once.run().eta_mean - truth).cwiseAbs().maxCoeff(), 1e-2);
}

TEST(UtCalibration, ASmallSampleScaleKeepsTheLinearPosteriorExact) {
  const LinearProblem lp;
  Eigen::VectorXd mean;
  Eigen::MatrixXd P;
  lp.exact(mean, P);
  UtOptions opt = serial_options({SigmaRule::kStar, 0.5});
  opt.sample_scale = 0.05;
  const UtSummary s =
      UtCalibration(lp.model(), identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt)
          .run();
  EXPECT_NEAR(s.iterations[0].spread_factor, 0.05, 0.0);
  EXPECT_LT((s.eta_mean - mean).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((s.eta_covariance - P).cwiseAbs().maxCoeff(), 1e-9 * P.cwiseAbs().maxCoeff());
}

TEST(UtCalibration, IteratingWithASmallSampleScaleConvergesInFewerIterations) {
  const Eigen::Vector2d truth(0.8, -0.4);
  FunctionModel fm(2, 2, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z = t.array().exp().matrix();
    return model::Status::Ok();
  });
  const Eigen::Vector2d y = truth.array().exp().matrix();
  const Eigen::Matrix2d R = (0.01 * y).array().square().matrix().asDiagonal();
  UtOptions opt = serial_options();
  opt.mode = UtMode::kIterateKeepSpread;
  opt.max_iterations = 100;
  opt.tolerance = 1e-9;
  auto run = [&](double scale) {
    opt.sample_scale = scale;
    return UtCalibration(fm, identity_parameters(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.6, 0.6)),
                         observations(y, R), opt)
        .run();
  };
  const UtSummary wide = run(1.0);
  const UtSummary local = run(0.01);
  ASSERT_EQ(wide.termination, UtTermination::kConverged);
  ASSERT_EQ(local.termination, UtTermination::kConverged);
  EXPECT_LT((wide.eta_mean - truth).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((local.eta_mean - truth).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LE(local.iterations.size() + 4, wide.iterations.size())  // 7 vs 12
      << local.iterations.size() << " vs " << wide.iterations.size();
}

TEST(UtCalibration, ShrinkAndRetryRecoversFromFailedMembersAndKeepsTheLinearPosterior) {
  // The linear map fails for t0 > 1.5: the prior spread 0.3 x sqrt(3) puts one simplex point
  // there, half the spread does not. The shrunk ensemble is rescaled, so the posterior is exact.
  const LinearProblem lp;
  FunctionModel fm(3, 4, [&](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(0) > 1.3) return model::Status::Error(model::StatusCode::kDiverged, "Newton failed");
    z = lp.H * t + lp.c;
    return model::Status::Ok();
  });
  Eigen::VectorXd mean;
  Eigen::MatrixXd P;
  lp.exact(mean, P);
  UtCalibration cal(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R),
                    serial_options());
  const UtSummary s = cal.run();
  ASSERT_EQ(s.termination, UtTermination::kCompleted) << s.message;
  ASSERT_EQ(s.actions.size(), 1u);
  EXPECT_EQ(s.actions[0].kind, UtAction::Kind::kShrinkAndRetry);
  EXPECT_NEAR(s.actions[0].spread_factor, 0.5, 0.0);
  EXPECT_NEAR(s.iterations[0].spread_factor, 0.5, 0.0);
  EXPECT_EQ(s.iterations[0].attempts, 2);
  ASSERT_FALSE(s.failed.empty());
  EXPECT_GT(s.failed[0].theta(0), 1.3);
  EXPECT_EQ(s.failures, static_cast<int>(s.failed.size()));
  EXPECT_LT((s.eta_mean - mean).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((s.eta_covariance - P).cwiseAbs().maxCoeff(), 1e-10 * P.cwiseAbs().maxCoeff());
}

TEST(UtCalibration, AbortPolicyStopsWithTheFailingMembersParametersAndMessages) {
  const LinearProblem lp;
  FunctionModel fm(3, 4, [&](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(0) > 1.3) throw std::runtime_error("solver exploded");
    z = lp.H * t + lp.c;
    return model::Status::Ok();
  });
  UtOptions opt = serial_options();
  opt.failure_policy = UtFailurePolicy::kAbort;
  UtCalibration cal(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt);
  const UtSummary s = cal.run();
  EXPECT_EQ(s.termination, UtTermination::kAbortedFailures);
  EXPECT_FALSE(s.ok());
  ASSERT_EQ(s.actions.size(), 1u);
  EXPECT_EQ(s.actions[0].kind, UtAction::Kind::kAbort);
  EXPECT_NE(s.message.find("solver exploded"), std::string::npos);
  EXPECT_NE(s.message.find("t0 = "), std::string::npos);
  EXPECT_TRUE(s.iterations.empty());
  EXPECT_NEAR((s.eta_mean - lp.m0).norm(), 0.0, 0.0);  // the prior is kept
}

TEST(UtCalibration, ShrinkRetriesAreBoundedThenTheRunAborts) {
  FunctionModel fm(2, 1, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(1) < 0.0) return model::Status::Error(model::StatusCode::kNonFinite, "NaN in P_lv");
    z(0) = t(0) + t(1);
    return model::Status::Ok();
  });
  // The prior mean sits on the failure boundary: every spread has a failing member.
  UtOptions opt = serial_options();
  opt.max_retries = 2;
  opt.ensemble.backend = Backend::kThreads;
  opt.ensemble.threads = 2;
  UtCalibration cal(fm, identity_parameters(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.1, 0.1)),
                    observations(Eigen::VectorXd::Constant(1, 1.2), Eigen::MatrixXd::Identity(1, 1)),
                    opt);
  const UtSummary s = cal.run();
  EXPECT_EQ(s.termination, UtTermination::kAbortedFailures);
  ASSERT_EQ(s.actions.size(), 3u);
  EXPECT_NEAR(s.actions[1].spread_factor, 0.25, 0.0);
  EXPECT_EQ(s.actions[2].kind, UtAction::Kind::kAbort);
  EXPECT_NE(s.message.find("NaN in P_lv"), std::string::npos);
  // 3 attempts of 3 simplex points, the centre once, the fit at the (prior) result reused.
  EXPECT_EQ(s.simulations, 3 * 3 + 1);
}

TEST(UtCalibration, OneAndTwoThreadsGiveIdenticalEstimates) {
  const LinearProblem lp;
  FunctionModel fm(3, 4, [&](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z = lp.H * t.array().sinh().matrix() + lp.c;
    return model::Status::Ok();
  });
  UtOptions opt = serial_options({SigmaRule::kCanonical});
  opt.mode = UtMode::kIterateInflate;
  opt.inflation = 1.5;
  opt.max_iterations = 4;
  opt.ensemble.backend = Backend::kThreads;
  opt.ensemble.threads = 1;
  const UtSummary a =
      UtCalibration(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt).run();
  opt.ensemble.threads = 2;
  int progress_calls = 0;
  opt.progress = [&](const UtProgress& pr) {
    ++progress_calls;
    EXPECT_LE(pr.done, pr.total);
  };
  const UtSummary b =
      UtCalibration(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt).run();
  EXPECT_EQ(a.iterations.size(), 4u);
  EXPECT_EQ(a.termination, UtTermination::kMaxIterations);
  EXPECT_NEAR((a.eta_mean - b.eta_mean).norm(), 0.0, 0.0);
  EXPECT_NEAR((a.eta_covariance - b.eta_covariance).norm(), 0.0, 0.0);
  EXPECT_EQ(progress_calls, 4 * (6 + 1) + 1);
}

TEST(UtCalibration, ValidateNamesTheInconsistency) {
  const LinearProblem lp;
  const FunctionModel fm = lp.model();
  auto pars = identity_parameters(lp.m0, lp.s0);
  pars.parameters[1].name = "wrong";
  EXPECT_NE(UtCalibration(fm, pars, observations(lp.y, lp.R), serial_options()).validate().find(
                "'wrong'"),
            std::string::npos);
  // A relative spread at a zero prior mean gives no std in eta: the prior refuses to build it,
  // and a prior with a zero std (built by hand) does not validate.
  try {
    (void)PriorParameter::gaussian("t0", "1", 0.0, lp.s0(0), SpreadKind::kRelative, {});
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("non-zero prior mean"), std::string::npos);
  }
  pars = identity_parameters(lp.m0, lp.s0);
  pars.parameters[0].std_eta = 0.0;
  EXPECT_NE(UtCalibration(fm, pars, observations(lp.y, lp.R), serial_options()).validate().find(
                "positive finite std"),
            std::string::npos);
  UtOptions opt = serial_options();
  opt.shrink_factor = 1.5;
  EXPECT_THROW(
      UtCalibration(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt).run(),
      std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::estimation
