#include "estimation/ut_calibration.h"

#include "tests/support/function_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <stdexcept>
#include <vector>

namespace sigmaheart::estimation {
namespace {

using sigmaheart::testing::FunctionModel;
using sigmaheart::testing::indexed;
using sigmaheart::testing::Map;

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


// ---- mode map: damped Gauss-Newton on statistically linearised models to the MAP point ----

UtOptions map_options(SigmaOptions sigma = {}) {
  UtOptions o = serial_options(sigma);
  o.mode = UtMode::kMap;
  o.max_iterations = 100;
  o.tolerance = 1e-10;
  o.objective_tolerance = 0.0;  // these checks want the MAP to 1e-10, not to the noise: step only
  return o;
}

// The MAP point and its Gauss-Newton Laplace covariance (P0^-1 + J^T R^-1 J)^-1 of identity-
// transform problems, found independently of the UT: Newton on the exact objective
// 0.5 |y - h|^2_R^-1 + 0.5 |t - m0|^2_P0^-1 with the analytic Jacobian J and a Hessian from
// central differences of the exact gradient (only the rate depends on it), from `start`.
struct Exact {
  Eigen::VectorXd map;
  Eigen::MatrixXd laplace;
};
using Jacobian = std::function<Eigen::MatrixXd(const Eigen::VectorXd&)>;
Exact newton_map(const Map& h, const Jacobian& J, int m, const Eigen::VectorXd& m0,
                 const Eigen::VectorXd& s0, const Eigen::VectorXd& y, const Eigen::MatrixXd& R,
                 Eigen::VectorXd start) {
  const Eigen::MatrixXd Rinv = R.inverse();
  const Eigen::MatrixXd P0inv = s0.array().square().inverse().matrix().asDiagonal();
  auto gradient = [&](const Eigen::VectorXd& t) {
    Eigen::VectorXd z(m);
    h(t, z);
    return Eigen::VectorXd(-J(t).transpose() * Rinv * (y - z) + P0inv * (t - m0));
  };
  Eigen::VectorXd t = std::move(start);
  for (int k = 0; k < 100 && gradient(t).norm() > 1e-14; ++k) {
    const auto p = t.size();
    Eigen::MatrixXd Hs(p, p);
    for (Eigen::Index j = 0; j < p; ++j) {
      const double e = 1e-6;
      Eigen::VectorXd a = t, b = t;
      a(j) += e;
      b(j) -= e;
      Hs.col(j) = (gradient(a) - gradient(b)) / (2 * e);
    }
    t -= (0.5 * (Hs + Hs.transpose())).ldlt().solve(gradient(t));
  }
  EXPECT_LT(gradient(t).norm(), 1e-12);
  return {t, (P0inv + J(t).transpose() * Rinv * J(t)).inverse()};
}

TEST(UtCalibration, MapModeGivesTheExactLinearGaussianPosteriorInOneStep) {
  const LinearProblem lp;
  Eigen::VectorXd mean;
  Eigen::MatrixXd P;
  lp.exact(mean, P);
  for (const SigmaRule rule : {SigmaRule::kSimplex, SigmaRule::kCanonical}) {
    const UtSummary s = UtCalibration(lp.model(), identity_parameters(lp.m0, lp.s0),
                                      observations(lp.y, lp.R), map_options({rule}))
                            .run();
    ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
    ASSERT_EQ(s.iterations.size(), 2u);  // the step, then a zero step
    EXPECT_LT((s.iterations[0].eta_mean - mean).cwiseAbs().maxCoeff(), 1e-10) << to_string(rule);
    EXPECT_LT((s.iterations[0].P - P).cwiseAbs().maxCoeff(), 1e-10 * P.cwiseAbs().maxCoeff());
    EXPECT_LT((s.eta_mean - mean).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((s.eta_covariance - P).cwiseAbs().maxCoeff(), 1e-10 * P.cwiseAbs().maxCoeff());
    EXPECT_EQ(s.iterations[0].lambda, 0.0);  // an undamped Gauss-Newton step
    EXPECT_EQ(s.rejected_steps, 0);
    EXPECT_TRUE(s.ok());
  }
}

struct NonlinearCase {
  const char* name;
  int p, m;
  Map h;
  Jacobian J;
  Eigen::VectorXd m0, s0, y, r;
};

std::vector<NonlinearCase> nonlinear_cases() {
  std::vector<NonlinearCase> out;
  {  // exponentials: y is not h of any point, so the MAP differs from the ML point
    NonlinearCase c{"exponential", 2, 4,
                    [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
                      z << std::exp(t(0)), std::exp(t(1)), std::exp(t(0) + 2.0 * t(1)), t(0) * t(1);
                      return model::Status::Ok();
                    },
                    [](const Eigen::VectorXd& t) {
                      Eigen::MatrixXd J(4, 2);
                      const double e = std::exp(t(0) + 2.0 * t(1));
                      J << std::exp(t(0)), 0.0, 0.0, std::exp(t(1)), e, 2.0 * e, t(1), t(0);
                      return J;
                    },
                    Eigen::Vector2d(0.2, 0.3), Eigen::Vector2d(0.5, 0.5),
                    Eigen::Vector4d(2.3, 0.62, 1.1, -0.35), Eigen::Vector4d(0.1, 0.05, 0.1, 0.05)};
    out.push_back(c);
  }
  {  // a rational saturating response of three parameters
    NonlinearCase c{"rational", 3, 5,
                    [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
                      for (int i = 0; i < 5; ++i) {
                        const double x = 0.5 * (i + 1);
                        z(i) = t(0) * x / (t(1) * t(1) + x) + t(2) * x * x;
                      }
                      return model::Status::Ok();
                    },
                    [](const Eigen::VectorXd& t) {
                      Eigen::MatrixXd J(5, 3);
                      for (int i = 0; i < 5; ++i) {
                        const double x = 0.5 * (i + 1), d = t(1) * t(1) + x;
                        J.row(i) << x / d, -2.0 * t(0) * t(1) * x / (d * d), x * x;
                      }
                      return J;
                    },
                    Eigen::Vector3d(1.0, 1.0, 0.0), Eigen::Vector3d(0.5, 0.4, 0.1),
                    (Eigen::VectorXd(5) << 0.55, 0.95, 1.35, 1.6, 1.95).finished(),
                    Eigen::VectorXd::Constant(5, 0.05)};
    out.push_back(c);
  }
  return out;
}

// One exact nonlinear case calibrated in mode map with `opt` (canonical points at sample_scale
// 1e-4 unless opt says otherwise): the run, and its distance to the MAP point and (relative) to the
// Laplace covariance of newton_map.
struct AgainstExact {
  UtSummary s;
  double mean_error = 0.0, cov_error = 0.0;
};
AgainstExact run_against_exact(const NonlinearCase& c, const UtOptions& opt) {
  const Eigen::MatrixXd R = c.r.array().square().matrix().asDiagonal();
  const Exact exact = newton_map(c.h, c.J, c.m, c.m0, c.s0, c.y, R, c.m0);
  AgainstExact out;
  out.s = UtCalibration(FunctionModel(c.p, c.m, c.h), identity_parameters(c.m0, c.s0), observations(c.y, R), opt).run();
  out.mean_error = (out.s.eta_mean - exact.map).cwiseAbs().maxCoeff();
  out.cov_error = (out.s.eta_covariance - exact.laplace).cwiseAbs().maxCoeff() / exact.laplace.cwiseAbs().maxCoeff();
  return out;
}
UtOptions exact_map_options() {
  UtOptions opt = map_options({SigmaRule::kCanonical});
  opt.sample_scale = 1e-4;
  return opt;
}
// Accepted centres never raise the objective.
void expect_objective_never_rises(const UtSummary& s, const char* name) {
  for (size_t k = 1; k < s.iterations.size(); ++k) {
    EXPECT_LE(s.iterations[k].objective, s.iterations[k - 1].objective) << name << " " << k;
  }
}

TEST(UtCalibration, MapModeLandsOnTheMapPointAndItsLaplaceCovariance) {
  // sample_scale 1e-4 with the symmetric canonical rule: the statistical slope is the Jacobian
  // to O(1e-8) (central differences), so the fixed point is the MAP and P+ the Laplace form.
  for (const NonlinearCase& c : nonlinear_cases()) {
    const auto [s, mean_error, cov_error] = run_against_exact(c, exact_map_options());
    ASSERT_EQ(s.termination, UtTermination::kConverged) << c.name << ": " << s.message;
    EXPECT_LT(mean_error, 1e-4) << c.name;
    EXPECT_LT(cov_error, 1e-4) << c.name;
    RecordProperty(std::string(c.name) + "_map_error", std::to_string(mean_error));
    RecordProperty(std::string(c.name) + "_covariance_relative_error", std::to_string(cov_error));
    std::printf("%s: |eta - MAP| = %.3g, |P - Laplace| / |Laplace| = %.3g, %zu iterations, %d runs\n",
                c.name, mean_error, cov_error, s.iterations.size(), s.simulations);
    expect_objective_never_rises(s, c.name);
    EXPECT_LE(s.objective, s.objective_prior);
  }
}

TEST(UtCalibration, SecantIterationsLandOnTheSameMapPointAndLaplaceCovarianceWithFewerRuns) {
  // Broyden's update of the slope between sampled linearisations (secant_iterations): the stop is
  // decided on sigma points, so the estimate and P+ are the MAP and its Laplace covariance as
  // without it; the runs fall because most iterations cost their one candidate run.
  for (const NonlinearCase& c : nonlinear_cases()) {
    UtOptions opt = exact_map_options();
    const UtSummary sampled = run_against_exact(c, opt).s;
    opt.secant_iterations = 4;
    const auto [s, mean_error, cov_error] = run_against_exact(c, opt);
    ASSERT_EQ(s.termination, UtTermination::kConverged) << c.name << ": " << s.message;
    const auto secant = std::count_if(s.iterations.begin(), s.iterations.end(),
                                      [](const UtIteration& it) { return it.secant; });
    std::printf("%s, secant: |eta - MAP| = %.3g, |P - Laplace| / |Laplace| = %.3g, %zu iterations (%td secant), "
                "%d runs; sampled only: %zu iterations, %d runs\n",
                c.name, mean_error, cov_error, s.iterations.size(), secant, s.simulations,
                sampled.iterations.size(), sampled.simulations);
    EXPECT_LT(mean_error, 1e-4) << c.name;
    EXPECT_LT(cov_error, 1e-4) << c.name;
    EXPECT_GT(secant, 0) << c.name;
    EXPECT_FALSE(s.iterations.back().secant) << c.name << ": the stop was decided on a secant slope";
    EXPECT_EQ(s.iterations.back().theta_members.rows(), 2 * c.p) << c.name;
    // A sampled iteration costs 2p runs here, a secant one 1: the saving needs p > 2 (with 2
    // parameters the two cost about the same: 44 and 40 runs).
    if (c.p > 2) EXPECT_LT(s.simulations, sampled.simulations) << c.name;
    expect_objective_never_rises(s, c.name);
  }
}

TEST(UtCalibration, GeodesicAccelerationKeepsTheMapPointAndFollowsACurvedValleyInFewerIterations) {
  // The acceleration changes the path, not the fixed point: the same MAP and Laplace covariance
  // on the two exact cases.
  for (const NonlinearCase& c : nonlinear_cases()) {
    UtOptions opt = exact_map_options();
    opt.geodesic_acceleration = true;
    const auto [s, mean_error, cov_error] = run_against_exact(c, opt);
    ASSERT_EQ(s.termination, UtTermination::kConverged) << c.name << ": " << s.message;
    EXPECT_LT(mean_error, 1e-4) << c.name;
    EXPECT_LT(cov_error, 1e-4) << c.name;
  }
  // Rosenbrock's valley as residuals (z = (10 (t1 - t0^2), t0), y = (0, 1); Transtrum & Sethna
  // 2012, s.5): from (-1.2, 1) damped Gauss-Newton creeps round the parabola t1 = t0^2.
  const Map rosenbrock = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z << 10.0 * (t(1) - t(0) * t(0)), t(0);
    return model::Status::Ok();
  };
  auto run = [&](bool accelerate) {
    UtOptions opt = map_options({SigmaRule::kCanonical});
    opt.sample_scale = 1e-4;
    opt.tolerance = 1e-8;
    opt.geodesic_acceleration = accelerate;
    Prior prior = identity_parameters(Eigen::Vector2d(-1.2, 1.0), Eigen::Vector2d(100.0, 100.0));
    return UtCalibration(FunctionModel(2, 2, rosenbrock), prior,
                         observations(Eigen::Vector2d(0.0, 1.0), Eigen::Matrix2d::Identity()), opt)
        .run();
  };
  const UtSummary plain = run(false), accelerated = run(true);
  std::printf("Rosenbrock: plain %zu iterations, %d runs, %d rejected; accelerated %zu iterations, %d runs, "
              "%d rejected\n",
              plain.iterations.size(), plain.simulations, plain.rejected_steps, accelerated.iterations.size(),
              accelerated.simulations, accelerated.rejected_steps);
  ASSERT_EQ(plain.termination, UtTermination::kConverged) << plain.message;
  ASSERT_EQ(accelerated.termination, UtTermination::kConverged) << accelerated.message;
  // The minimum is (1, 1) up to the weak prior's pull (std 100: ~1e-4).
  EXPECT_LT((accelerated.eta_mean - Eigen::Vector2d(1.0, 1.0)).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT((accelerated.eta_mean - plain.eta_mean).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(accelerated.iterations.size(), plain.iterations.size());
}

TEST(UtCalibration, MapModeRejectsAFailedCandidateAndDampsInsteadOfAborting) {
  // z = exp(t): the undamped first step from 0 overshoots to ~2.2 where the model fails (t > 1.6);
  // the damped step lands short of it and the run goes on to the MAP.
  Map h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(0) > 1.6) return model::Status::Error(model::StatusCode::kDiverged, "Newton failed");
    z(0) = std::exp(t(0));
    return model::Status::Ok();
  };
  const Eigen::VectorXd m0 = Eigen::VectorXd::Zero(1), s0 = Eigen::VectorXd::Constant(1, 2.0);
  const Eigen::VectorXd y = Eigen::VectorXd::Constant(1, 4.0);
  const Eigen::MatrixXd R = Eigen::MatrixXd::Constant(1, 1, 0.01);
  UtOptions opt = map_options({SigmaRule::kCanonical});
  opt.sample_scale = 1e-4;
  const UtSummary s = UtCalibration(FunctionModel(1, 1, h), identity_parameters(m0, s0), observations(y, R), opt).run();
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  EXPECT_GE(s.rejected_steps, 1);
  ASSERT_FALSE(s.actions.empty());
  EXPECT_EQ(s.actions.front().kind, UtAction::Kind::kReject);
  EXPECT_EQ(s.actions.front().failed_members, std::vector<int>{-1});
  EXPECT_GE(s.failures, 1);
  const Exact exact = newton_map(h, [](const Eigen::VectorXd& t) { return Eigen::MatrixXd::Constant(1, 1, std::exp(t(0))); },
                                 1, m0, s0, y, R, Eigen::VectorXd::Constant(1, std::log(4.0)));
  EXPECT_LT(std::abs(s.eta_mean(0) - exact.map(0)), 1e-4);
}

TEST(UtCalibration, MapModeReturnsFromACentreWhoseSigmaPointsFailInsteadOfAborting) {
  // z = (t0^2, t1), data (4, 0): the Gauss-Newton step from t0 = 1 overshoots to 2.5 and lowers
  // Phi, so it is accepted; there every sigma point off the line t1 = 0 fails (t0 > 2.2), also
  // after the shrink retries. The step is rejected (kRevert), the damped steps from t0 = 1 stay
  // short of 2.2 and the run converges to the MAP near 2 without aborting.
  Map h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(0) > 2.2 && t(1) != 0.0) return model::Status::Error(model::StatusCode::kDiverged, "not periodic");
    z(0) = t(0) * t(0);
    z(1) = t(1);
    return model::Status::Ok();
  };
  const Eigen::VectorXd m0 = Eigen::Vector2d(1.0, 0.0), s0 = Eigen::Vector2d(1.0, 1.0);
  const Eigen::VectorXd y = Eigen::Vector2d(4.0, 0.0);
  const Eigen::MatrixXd R = Eigen::Vector2d(0.01, 0.01).asDiagonal();
  UtOptions opt = map_options({SigmaRule::kCanonical});
  opt.sample_scale = 1e-3;
  const UtSummary s = UtCalibration(FunctionModel(2, 2, h), identity_parameters(m0, s0), observations(y, R), opt).run();
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  int reverts = 0;
  for (const UtAction& a : s.actions) {
    EXPECT_NE(a.kind, UtAction::Kind::kAbort);
    if (a.kind != UtAction::Kind::kRevert) continue;
    ++reverts;
    EXPECT_FALSE(a.failed_members.empty());
    EXPECT_LT(a.previous_misfit, s.objective_prior + 1e-12);
    EXPECT_NE(a.describe().find("back to the previous centre"), std::string::npos);
  }
  EXPECT_GE(reverts, 1);
  EXPECT_GE(s.rejected_steps, reverts);
  EXPECT_GE(s.retries, 3 * reverts);  // every revert follows max_retries shrinks
  EXPECT_GT(s.failures, 0);
  const Exact exact = newton_map(
      h, [](const Eigen::VectorXd& t) { return Eigen::Matrix2d(Eigen::Vector2d(2.0 * t(0), 1.0).asDiagonal()); }, 2,
      m0, s0, y, R, Eigen::Vector2d(2.0, 0.0));
  EXPECT_LT((s.eta_mean - exact.map).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LE(s.objective, s.objective_prior);
}

TEST(UtCalibration, MapModeMirrorsAFailedSigmaPointWhoseOppositePointRan) {
  // LinearProblem, but the model fails for t2 below its prior mean 2.0: the "-" star point along
  // t2 fails at every spread, so shrinking cannot help (without mirroring the run aborts at the
  // start). Its output mirrored through the centre is exact for a linear h, so the first
  // linearisation gives the exact linear-Gaussian gain and posterior covariance.
  const LinearProblem lp;
  int calls_below = 0;
  FunctionModel fm(3, 4, [&](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(2) < 2.0 - 1e-12) {
      ++calls_below;
      return model::Status::Error(model::StatusCode::kNotPeriodic, "not periodic after 400 beats");
    }
    z = lp.H * t + lp.c;
    return model::Status::Ok();
  });
  Eigen::VectorXd mean;
  Eigen::MatrixXd P;
  lp.exact(mean, P);
  UtOptions opt = map_options({SigmaRule::kStar});
  opt.max_iterations = 1;
  const UtSummary s = UtCalibration(fm, identity_parameters(lp.m0, lp.s0), observations(lp.y, lp.R), opt).run();
  ASSERT_FALSE(s.iterations.empty()) << s.message;
  EXPECT_NE(s.termination, UtTermination::kAbortedFailures) << s.message;
  EXPECT_EQ(s.retries, 0);  // mirrored before any shrink
  EXPECT_EQ(s.mirrored, 1);
  EXPECT_GE(s.failures, 1);
  ASSERT_FALSE(s.actions.empty());
  EXPECT_EQ(s.actions.front().kind, UtAction::Kind::kMirror);
  EXPECT_EQ(s.actions.front().failed_members.size(), 1u);
  EXPECT_NE(s.brief_report().find("1 sigma points mirrored"), std::string::npos) << s.brief_report();
  const Eigen::MatrixXd P0 = lp.s0.array().square().matrix().asDiagonal();
  const Eigen::MatrixXd K = P0 * lp.H.transpose() * (lp.H * P0 * lp.H.transpose() + lp.R).inverse();
  EXPECT_LT((s.iterations[0].gain - K).cwiseAbs().maxCoeff(), 1e-8 * K.cwiseAbs().maxCoeff());
  EXPECT_LT((s.iterations[0].P - P).cwiseAbs().maxCoeff(), 1e-8 * P.cwiseAbs().maxCoeff());
  EXPECT_GT(calls_below, 0);
}

TEST(UtCalibration, MapModeEndsDivergedWhenNoDampedStepIsAcceptable) {
  // Linear z = t with data at 3, but the model fails for t > 0.1: with one rejection allowed the
  // halved step still fails, so no acceptable step exists and the run says so, after re-linearising
  // the centre three times on a smaller spread (each time two rejected candidates).
  Map h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (t(0) > 0.1) return model::Status::Error(model::StatusCode::kDiverged, "Newton failed");
    z(0) = t(0);
    return model::Status::Ok();
  };
  UtOptions opt = map_options({SigmaRule::kCanonical});
  opt.sample_scale = 1e-3;
  opt.max_rejections = 1;
  const UtSummary s = UtCalibration(FunctionModel(1, 1, h), identity_parameters(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1)),
                                    observations(Eigen::VectorXd::Constant(1, 3.0), Eigen::MatrixXd::Constant(1, 1, 0.01)), opt)
                          .run();
  EXPECT_EQ(s.termination, UtTermination::kDiverged) << s.message;
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.rejected_steps, 2 * (1 + 3));
  int relinearisations = 0;
  for (const auto& a : s.actions) {
    relinearisations += a.kind == UtAction::Kind::kShrinkAndRetry && a.failed_members.empty();
  }
  EXPECT_EQ(relinearisations, 3);
  EXPECT_EQ(s.eta_mean(0), 0.0);  // the prior mean, the last accepted centre
  EXPECT_NE(s.message.find("no step lowers the MAP objective"), std::string::npos);
}

// A creeping valley (issue 45, item 1): z_k = exp(t0 + t1) exp(-0.025 k (t0 - t1)) +
// 0.001 sin(60 (t0 - t1) + k / 2), k = 0..11, against y_k = 1 / (1 + k / 4) (a curve the model
// cannot make: 10 noise std RMS at the MAP, noise 0.01), prior N(0, 1) on each: the data fix the
// sum t0 + t1 and hardly the difference, so the posterior correlation is -0.99, and the small
// ripple (a forward map whose output moves in steps, like a valve event on a time grid) makes the
// sigma points' slope along the valley unreliable. With a tight step tolerance (1e-4) the damped
// steps creep along the valley; the objective stop ends the run where Phi stops falling.
struct ValleyTwin {
  Map h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    for (int k = 0; k < 12; ++k) {
      z(k) = std::exp(t(0) + t(1)) * std::exp(-0.025 * k * (t(0) - t(1))) +
             0.001 * std::sin(60.0 * (t(0) - t(1)) + 0.5 * k);
    }
    return model::Status::Ok();
  };
  UtSummary run(double objective_tolerance, double tolerance = 1e-4) const {
    Eigen::VectorXd y(12);
    for (int k = 0; k < 12; ++k) y(k) = 1.0 / (1.0 + 0.25 * k);
    UtOptions opt = map_options({SigmaRule::kCanonical});
    opt.sample_scale = 0.1;
    opt.tolerance = tolerance;
    opt.objective_tolerance = objective_tolerance;
    opt.max_iterations = 100;
    return UtCalibration(FunctionModel(2, 12, h), identity_parameters(Eigen::Vector2d::Zero(), Eigen::Vector2d::Ones()),
                         observations(y, Eigen::MatrixXd::Identity(12, 12) * 1e-4), opt)
        .run();
  }
};

TEST(UtCalibration, ACreepingValleyTwinConvergesOnTheObjective) {
  const ValleyTwin v;
  const UtSummary before = v.run(0.0);
  const UtSummary after = v.run(0.01);
  const Eigen::MatrixXd& P = after.eta_covariance;
  const double rho = P(0, 1) / std::sqrt(P(0, 0) * P(1, 1));
  std::printf("valley: rho %.4f; step-only stop: %s after %zu iterations, %d runs, Phi %.4f; objective stop: %s "
              "after %zu iterations, %d runs, %d finishing steps, Phi %.4f\n",
              rho, to_string(before.termination), before.iterations.size(), before.simulations, before.objective,
              to_string(after.termination), after.iterations.size(), after.simulations, after.extrapolations,
              after.objective);
  EXPECT_LT(rho, -0.99);
  ASSERT_EQ(after.termination, UtTermination::kConverged) << after.message;
  EXPECT_LE(after.iterations.size(), 20u);
  EXPECT_LE(after.simulations, 120);
  // Where it stopped, Phi is within 0.01 per observation of where the step-only run went on to.
  EXPECT_LT(after.objective - before.objective, 0.01 * 12);
}

TEST(UtCalibration, TheObjectiveStopEndsARunWhoseStepsNeverMeetTheStepTolerance) {
  // tolerance 0: no step is ever below it, so only the objective can say "converged"; it does,
  // in words, once Phi falls by less than 0.01 per observation over two iterations (12 here).
  const ValleyTwin v;
  const UtSummary s = v.run(0.01, 0.0);
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  EXPECT_EQ(s.message.rfind("objective: Phi fell by ", 0), 0u) << s.message;
  const size_t n = s.iterations.size();
  ASSERT_GE(n, 3u);
  EXPECT_LT(s.iterations[n - 3].objective - s.objective, 0.01 * 12);
  // Without it the same run cannot say converged: it goes on at the same Phi (to the damping
  // limit after 80 iterations, "diverged") where the objective stop ended after 13.
  const UtSummary off = v.run(0.0, 0.0);
  EXPECT_NE(off.termination, UtTermination::kConverged) << off.message;
  EXPECT_GT(off.iterations.size(), 3 * n) << off.message;
  EXPECT_LT(std::abs(off.objective - s.objective), 0.01 * 12);
}

// theta in (0, 1) through a logit; z = theta observed at 1.5: the ML point is outside the bounds.
Prior unit_interval_prior(double std_eta) {
  Prior prior;
  prior.parameters.push_back(PriorParameter::gaussian("t0", "1", 0.5, std_eta, SpreadKind::kEta,
                                                      Transform{TransformKind::kLogit, 1.0, 0.0, 1.0}, 0.0, 1.0));
  return prior;
}

TEST(UtCalibration, BoundsHoldForEveryMemberAndEstimateWhenTheMlPointIsOutside) {
  FunctionModel fm(1, 1, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    if (!(t(0) > 0.0 && t(0) < 1.0)) return model::Status::Error(model::StatusCode::kOutOfBounds, "out of [0, 1]");
    z(0) = t(0);
    return model::Status::Ok();
  });
  const auto obs = observations(Eigen::VectorXd::Constant(1, 1.5), Eigen::MatrixXd::Constant(1, 1, 0.05 * 0.05));
  for (const UtMode mode : {UtMode::kMap, UtMode::kOneShot, UtMode::kIterateKeepSpread, UtMode::kIterateInflate}) {
    UtOptions opt = map_options();
    opt.mode = mode;
    opt.max_iterations = 30;
    opt.tolerance = 1e-8;
    const UtSummary s = UtCalibration(fm, unit_interval_prior(1.0), obs, opt).run();
    EXPECT_EQ(s.failures, 0) << to_string(mode);
    for (const auto& it : s.iterations) {
      EXPECT_TRUE((it.theta_members.array() > 0.0).all() && (it.theta_members.array() < 1.0).all());
    }
    EXPECT_GT(s.theta_of_eta_mean(0), 0.5) << to_string(mode);
    EXPECT_LT(s.theta_of_eta_mean(0), 1.0) << to_string(mode);
  }
  // The MAP in eta: (1.5 - s(e)) s(e)(1 - s(e)) / r^2 = e, s the logistic function (bisection).
  auto dphi = [](double e) {
    const double sg = 1.0 / (1.0 + std::exp(-e));
    return -(1.5 - sg) * sg * (1.0 - sg) / 0.0025 + e;
  };
  double lo = 0.0, hi = 20.0;
  for (int i = 0; i < 200; ++i) (dphi(0.5 * (lo + hi)) < 0 ? lo : hi) = 0.5 * (lo + hi);
  UtOptions opt = map_options({SigmaRule::kCanonical});
  opt.sample_scale = 1e-4;
  const UtSummary s = UtCalibration(fm, unit_interval_prior(1.0), obs, opt).run();
  ASSERT_EQ(s.termination, UtTermination::kConverged) << s.message;
  EXPECT_NEAR(s.eta_mean(0), 0.5 * (lo + hi), 1e-4);
  // A vague prior lets the estimate run into the bound: reported, not a success.
  const UtSummary vague = UtCalibration(fm, unit_interval_prior(100.0), obs, opt).run();
  EXPECT_EQ(vague.termination, UtTermination::kAtBound) << vague.message;
  EXPECT_LT(vague.theta_of_eta_mean(0), 1.0);
  EXPECT_NE(vague.message.find("upper bound"), std::string::npos) << vague.message;
}

TEST(UtCalibration, OutcomesSayWhenTheResultIsNotTrustworthy) {
  const auto prior = identity_parameters(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 0.3));
  const Eigen::MatrixXd R = Eigen::MatrixXd::Constant(1, 1, 0.01);
  // One-shot far from the data: NIS ~ 2.9^2 / (0.09 + 0.01) = 84 > chi2_1(0.999) = 10.8.
  FunctionModel linear(1, 1, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z(0) = t(0);
    return model::Status::Ok();
  });
  const UtSummary far = UtCalibration(linear, prior, observations(Eigen::VectorXd::Constant(1, 2.9), R), serial_options()).run();
  EXPECT_EQ(far.termination, UtTermination::kOneShotNotTrusted) << far.message;
  EXPECT_NEAR(far.nis_threshold, 10.828, 1e-3);  // chi2_1 at 0.999 (tables: 10.828)
  const UtSummary near = UtCalibration(linear, prior, observations(Eigen::VectorXd::Constant(1, 0.2), R), serial_options()).run();
  EXPECT_EQ(near.termination, UtTermination::kCompleted) << near.message;
  // The same update where the model returns NaN (with an ok status) at the estimate.
  FunctionModel nan_above(1, 1, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z(0) = t(0) > 1.0 ? std::nan("") : t(0);
    return model::Status::Ok();
  });
  const UtSummary nan = UtCalibration(nan_above, prior, observations(Eigen::VectorXd::Constant(1, 2.9), R), serial_options()).run();
  EXPECT_EQ(nan.termination, UtTermination::kNonFinite) << nan.message;
  // z = exp(2 t): the sigma-point mean overshoots y, the update lands far below: worse than the prior.
  FunctionModel steep(1, 1, [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z(0) = std::exp(2.0 * t(0));
    return model::Status::Ok();
  });
  const UtSummary worse = UtCalibration(steep, identity_parameters(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1)),
                                        observations(Eigen::VectorXd::Constant(1, 1.2), R), serial_options()).run();
  EXPECT_EQ(worse.termination, UtTermination::kWorseThanPrior) << worse.message;
  EXPECT_GT(worse.fit_after->misfit(), worse.fit_before->misfit());
  // The iteration limit is not a success.
  UtOptions opt = map_options();
  opt.max_iterations = 1;
  const UtSummary limit = UtCalibration(steep, prior, observations(Eigen::VectorXd::Constant(1, 1.2), R), opt).run();
  EXPECT_EQ(limit.termination, UtTermination::kMaxIterations) << limit.message;
  EXPECT_FALSE(limit.ok());
}

TEST(UtCalibration, GlobalStartFindsTheDeeperOfTwoMinimaAFarPriorMisses) {
  // z = (t^2, t), y = (4, 2.1): minima near t = -2 (where the prior mean -1.5 leads) and t = +2
  // (deeper: the second observation prefers it).
  Map h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z << t(0) * t(0), t(0);
    return model::Status::Ok();
  };
  Jacobian J = [](const Eigen::VectorXd& t) { return Eigen::MatrixXd((Eigen::MatrixXd(2, 1) << 2.0 * t(0), 1.0).finished()); };
  const Eigen::VectorXd m0 = Eigen::VectorXd::Constant(1, -1.5), s0 = Eigen::VectorXd::Constant(1, 5.0);
  const Eigen::Vector2d y(4.0, 2.1);
  const Eigen::MatrixXd R = Eigen::Vector2d(0.1 * 0.1, 3.0 * 3.0).asDiagonal();
  UtOptions opt = map_options({SigmaRule::kCanonical});
  opt.sample_scale = 1e-4;
  const UtSummary local = UtCalibration(FunctionModel(1, 2, h), identity_parameters(m0, s0), observations(y, R), opt).run();
  ASSERT_EQ(local.termination, UtTermination::kConverged) << local.message;
  EXPECT_LT(local.eta_mean(0), 0.0);
  opt.global_start = {16, 3, 1.0};
  const UtSummary global = UtCalibration(FunctionModel(1, 2, h), identity_parameters(m0, s0), observations(y, R), opt).run();
  ASSERT_EQ(global.termination, UtTermination::kConverged) << global.message;
  ASSERT_EQ(global.starts.size(), 3u);
  const Exact deep = newton_map(h, J, 2, m0, s0, y, R, Eigen::VectorXd::Constant(1, 2.0));
  EXPECT_LT(std::abs(global.eta_mean(0) - deep.map(0)), 1e-4);
  EXPECT_LT(global.objective, local.objective - 0.1);
  for (const auto& st : global.starts) EXPECT_GE(st.objective, global.objective);
  // Probes of 2 iterations from the same 3 starts: the best probe, continued, lands on the same MAP
  // point with fewer runs than three runs to the end.
  opt.global_start.probe_iterations = 2;
  const UtSummary probed = UtCalibration(FunctionModel(1, 2, h), identity_parameters(m0, s0), observations(y, R), opt).run();
  ASSERT_EQ(probed.termination, UtTermination::kConverged) << probed.message;
  ASSERT_EQ(probed.starts.size(), 3u);
  for (const auto& st : probed.starts) EXPECT_LE(st.iterations, 2);
  EXPECT_LT(std::abs(probed.eta_mean(0) - deep.map(0)), 1e-4);
  EXPECT_LT(probed.simulations, global.simulations);
  EXPECT_NE(probed.message.find("probes of 2 iterations continued"), std::string::npos) << probed.message;
}

TEST(UtCalibration, GlobalStartLocalRunsSideBySideGiveTheNumbersOfRunsOneAfterAnother) {
  // The two-minima problem above: three local runs one after another on one thread, then side by
  // side on two and three threads (UtGlobalStart::concurrent), probes too: every number equal.
  Map h = [](const Eigen::VectorXd& t, Eigen::Ref<Eigen::VectorXd> z) {
    z << t(0) * t(0), t(0);
    return model::Status::Ok();
  };
  const Eigen::VectorXd m0 = Eigen::VectorXd::Constant(1, -1.5), s0 = Eigen::VectorXd::Constant(1, 5.0);
  const Eigen::Vector2d y(4.0, 2.1);
  const Eigen::MatrixXd R = Eigen::Vector2d(0.1 * 0.1, 3.0 * 3.0).asDiagonal();
  for (const int probe : {0, 2}) {
    UtOptions opt = map_options({SigmaRule::kCanonical});
    opt.sample_scale = 1e-4;
    opt.global_start = {16, 3, 1.0};
    opt.global_start.probe_iterations = probe;
    opt.ensemble.backend = Backend::kThreads;
    opt.ensemble.threads = 1;
    const UtSummary serial = UtCalibration(FunctionModel(1, 2, h), identity_parameters(m0, s0), observations(y, R), opt).run();
    ASSERT_EQ(serial.termination, UtTermination::kConverged) << serial.message;
    for (const int threads : {2, 3}) {
      opt.ensemble.threads = threads;
      std::vector<UtProgress> reports;
      opt.progress = [&](const UtProgress& pr) {
        if (pr.iteration == -2) reports.push_back(pr);
      };
      const UtSummary side = UtCalibration(FunctionModel(1, 2, h), identity_parameters(m0, s0), observations(y, R), opt).run();
      SCOPED_TRACE("probe " + std::to_string(probe) + ", threads " + std::to_string(threads));
      EXPECT_EQ(side.termination, serial.termination);
      EXPECT_EQ(side.message, serial.message);
      EXPECT_EQ((side.eta_mean - serial.eta_mean).norm(), 0.0);
      EXPECT_EQ((side.eta_covariance - serial.eta_covariance).norm(), 0.0);
      EXPECT_EQ(side.simulations, serial.simulations);
      ASSERT_EQ(side.starts.size(), serial.starts.size());
      for (size_t k = 0; k < side.starts.size(); ++k) {
        EXPECT_EQ(side.starts[k].objective, serial.starts[k].objective);
        EXPECT_EQ(side.starts[k].simulations, serial.starts[k].simulations);
      }
      // One report per finished local run, counting up to the three of them.
      ASSERT_EQ(reports.size(), 3u);
      for (size_t k = 0; k < reports.size(); ++k) {
        EXPECT_EQ(reports[k].done, static_cast<int>(k) + 1);
        EXPECT_EQ(reports[k].total, 3);
      }
    }
  }
}

}  // namespace
}  // namespace sigmaheart::estimation
