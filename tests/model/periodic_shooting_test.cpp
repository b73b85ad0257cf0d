// Newton-Krylov shooting (model/periodic_shooting.h) against beat maps with known fixed points.
#include "model/periodic_shooting.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace sigmaheart::model {
namespace {

// The beat map of a linear system x' = A x + b over one period T, exactly: F(x) = E x + c with
// E = exp(A T) (diagonal A here) and c = (E - I) A^{-1} b. Its fixed point is -A^{-1} b.
struct LinearBeat {
  Eigen::VectorXd rate;  // diagonal of A [1/s], all negative
  Eigen::VectorXd b;
  double T = 1.0;
  int recorded = 0;
  BeatOutcome operator()(const Eigen::VectorXd& x, bool record) {
    if (record) ++recorded;
    const Eigen::VectorXd E = (rate * T).array().exp();
    const Eigen::VectorXd xs = -b.cwiseQuotient(rate);  // fixed point
    BeatOutcome o;
    o.end = xs + E.cwiseProduct(x - xs);
    o.peak = x.cwiseAbs().cwiseMax(o.end.cwiseAbs());
    return o;
  }
};

TEST(PeriodicShooting, FindsTheFixedPointOfANearlyNeutralModeInAFewBeats) {
  // Time constants 0.05 s, 0.3 s and 4.5e4 s (a distal Windkessel with R_d C_d ~ 4.5e4 s): plain
  // iteration contracts that mode by 1 - 2.2e-5 per beat and would need ~1e6 beats for 1e-6.
  LinearBeat lin;
  lin.rate = Eigen::Vector3d(-20.0, -1.0 / 0.3, -1.0 / 4.5e4);
  lin.b = Eigen::Vector3d(2e4, 3.0, 1e4 / 4.5e4);  // fixed point (1000, 0.9, 1e4)
  const BeatMap beat = [&](const Eigen::VectorXd& x, bool record) { return lin(x, record); };
  ShootingOptions o;
  const ShootingResult r = find_periodic_state(Eigen::Vector3d(0.0, 0.0, 5e3), beat, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_NEAR(r.start(0), 1000.0, 1e-6 * 1000.0);
  EXPECT_NEAR(r.start(1), 0.9, 1e-6 * 0.9);
  EXPECT_NEAR(r.start(2), 1e4, 1e-6 * 1e4);
  // 3 plain beats, then Newton steps of at most 3 Krylov beats and one trial beat each.
  EXPECT_LE(r.beats, 3 + 3 * (3 + 1) + 1);
  EXPECT_LE(r.correction, o.tolerance);
}

TEST(PeriodicShooting, ConvergesOnANonlinearMapFromFarAway) {
  // A cubic first entry, F_0(x) = x - 0.01 (x^3 - 8), and a slow linear second one; fixed point
  // (2, -1), started where the cubic's slope is a quarter of its slope at the root.
  const BeatMap beat = [](const Eigen::VectorXd& x, bool) {
    BeatOutcome o;
    o.end = Eigen::Vector2d(x(0) - 0.01 * (x(0) * x(0) * x(0) - 8.0), 0.999 * x(1) - 0.001);
    o.peak = x.cwiseAbs().cwiseMax(o.end.cwiseAbs());
    return o;
  };
  ShootingOptions o;
  const ShootingResult r = find_periodic_state(Eigen::Vector2d(1.0, 5.0), beat, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_NEAR(r.start(0), 2.0, 1e-6 * 2.0);
  EXPECT_NEAR(r.start(1), -1.0, 1e-6 * 5.0);
}

TEST(PeriodicShooting, FindsAFixedPointJustPastAKinkOfTheBeatMap) {
  // The arterial side of a ventricle that barely ejects (census point 677 of the lumped sphere:
  // R_d (C_p + C_d) ~ 3.5e4 s). Proximal and distal pressures x = (P_ar, P_d) [Pa]; per beat the
  // ventricle ejects only when P_ar is below its peak pressure P* (the aortic valve opens), which
  // raises P_ar by up to g w (a stroke volume); the arteries drain slowly. F(x) = x + G(x) with
  //   G_ar = g w tanh(max(P* - P_ar, 0) / w) - a (P_ar - P_d),   G_d = c (P_ar - P_d) - b (P_d - P_sv).
  // Above P* the map is nearly the identity (a, b, c ~ 1e-4), just below it steep (g = 0.5), far
  // below flat again: the fixed point sits 0.4 Pa below the kink. The first Newton step from the
  // flat side overshoots by 6e5 Pa; when that beat's peak stayed in the entry scales, the
  // tolerance and the finite-difference steps grew 60-fold, and the solve stopped 0.09 Pa off.
  const double Ps = 1e4, g = 0.5, w = 50.0, a = 1e-4, b = 5e-5, c = 2e-4, Psv = 600.0;
  const BeatMap beat = [&](const Eigen::VectorXd& x, bool) {
    BeatOutcome o;
    const double G_ar = g * w * std::tanh(std::max(Ps - x(0), 0.0) / w) - a * (x(0) - x(1));
    const double G_d = c * (x(0) - x(1)) - b * (x(1) - Psv);
    o.end = x + Eigen::Vector2d(G_ar, G_d);
    o.peak = x.cwiseAbs().cwiseMax(o.end.cwiseAbs());
    return o;
  };
  // The fixed point below the kink solves the linear system (g + a) P_ar - a P_d = g P*,
  // c P_ar - (b + c) P_d = -b P_sv.
  Eigen::Matrix2d A;
  A << g + a, -a, c, -(b + c);
  const Eigen::Vector2d fixed = A.lu().solve(Eigen::Vector2d(g * Ps, -b * Psv));
  ASSERT_LT(fixed(0), Ps);
  ASSERT_GT(fixed(0), Ps - 1.0);
  ShootingOptions o;
  o.max_beats = 400;
  const ShootingResult r = find_periodic_state(Eigen::Vector2d(1.1e4, 9e3), beat, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_NEAR(r.start(0), fixed(0), 1e-6 * Ps);
  EXPECT_NEAR(r.start(1), fixed(1), 1e-6 * Ps);
  EXPECT_LE(r.beats, 100);
}

TEST(PeriodicShooting, ABudgetTooSmallIsNotPeriodicAndAFailedBeatIsPassedOn) {
  LinearBeat lin;
  lin.rate = Eigen::Vector2d(-1.0 / 4.5e4, -1.0);
  lin.b = Eigen::Vector2d(1.0, 1.0);
  const BeatMap beat = [&](const Eigen::VectorXd& x, bool record) { return lin(x, record); };
  ShootingOptions o;
  o.max_beats = 3;  // only the plain beats
  const ShootingResult r = find_periodic_state(Eigen::Vector2d(0.0, 0.0), beat, o);
  EXPECT_EQ(r.status.code, StatusCode::kNotPeriodic);
  EXPECT_NE(r.status.message.find("not periodic after 3 beats"), std::string::npos)
      << r.status.message;

  const BeatMap broken = [](const Eigen::VectorXd& x, bool) {
    BeatOutcome failed;
    failed.status = Status::Error(StatusCode::kDiverged, "Newton did not converge at t = 0.1 s");
    failed.end = x;
    return failed;
  };
  const ShootingResult f = find_periodic_state(Eigen::Vector2d(0.0, 0.0), broken, ShootingOptions{});
  EXPECT_EQ(f.status.code, StatusCode::kDiverged);
  EXPECT_EQ(f.beats, 1);
}


// The cubic family of ConvergesOnANonlinearMapFromFarAway with its root at c^(1/3):
// F(x) = (x_0 - 0.01 (x_0^3 - c), 0.999 x_1 - 0.001), fixed point (c^(1/3), -1).
BeatMap cubic_map(double c) {
  return [c](const Eigen::VectorXd& x, bool) {
    BeatOutcome o;
    o.end = Eigen::Vector2d(x(0) - 0.01 * (x(0) * x(0) * x(0) - c), 0.999 * x(1) - 0.001);
    o.peak = x.cwiseAbs().cwiseMax(o.end.cwiseAbs());
    return o;
  };
}

TEST(PeriodicShooting, TheWarmStartCarriesTheFixedPointAndTheJacobianOfTheBeatMap) {
  ShootingOptions o;
  o.jacobian = true;
  const ShootingResult r = find_periodic_state(Eigen::Vector2d(1.0, 5.0), cubic_map(8.0), o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ASSERT_TRUE(r.warm.has_value());
  EXPECT_EQ(r.warm->start, r.start);
  // I - dF/dx = diag(0.03 x_0^2, 0.001) at (2, -1), in scaled units (diagonal: scale-free);
  // forward differences of 1e-6 scaled units: error ~ F'' h / 2 = 0.12 x 2e-6 / 2 on 0.12.
  EXPECT_NEAR(r.warm->jacobian(0, 0), 0.12, 1e-5 * 0.12);
  EXPECT_NEAR(r.warm->jacobian(1, 1), 0.001, 1e-5 * 0.001);
  EXPECT_NEAR(r.warm->jacobian(0, 1), 0.0, 1e-12);
  EXPECT_NEAR(r.warm->jacobian(1, 0), 0.0, 1e-12);
  // The flat form round-trips exactly; a flat vector of the wrong size, with a NaN or all zero
  // (what a failed run hands on) is no warm start.
  const Eigen::VectorXd flat = r.warm->pack();
  ASSERT_EQ(flat.size(), ShootingWarmStart::packed_size(2));
  const std::optional<ShootingWarmStart> back = ShootingWarmStart::unpack(flat, 2);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->pack(), flat);
  EXPECT_FALSE(ShootingWarmStart::unpack(flat, 3).has_value());
  Eigen::VectorXd nan = flat;
  nan(5) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(ShootingWarmStart::unpack(nan, 2).has_value());
  EXPECT_FALSE(ShootingWarmStart::unpack(Eigen::VectorXd::Zero(flat.size()), 2).has_value());
}

// The warm start of the cubic map with its root at 2.
ShootingWarmStart warm_start_at_root_two() {
  ShootingOptions o;
  o.jacobian = true;
  const ShootingResult r = find_periodic_state(Eigen::Vector2d(1.0, 5.0), cubic_map(8.0), o);
  EXPECT_TRUE(r.warm.has_value());
  return r.warm.value_or(ShootingWarmStart{});
}

TEST(PeriodicShooting, AWarmStartFromANearbyMapReachesTheSameFixedPointInFewerBeats) {
  const ShootingWarmStart near = warm_start_at_root_two();
  const ShootingOptions o;
  const double c = 8.08;  // the root moves by 0.33 %
  const ShootingResult cold = find_periodic_state(Eigen::Vector2d(1.0, 5.0), cubic_map(c), o);
  const ShootingResult warm = find_periodic_state(Eigen::Vector2d(1.0, 5.0), cubic_map(c), o, &near);
  ASSERT_TRUE(cold.status.ok()) << cold.status.message;
  ASSERT_TRUE(warm.status.ok()) << warm.status.message;
  EXPECT_NEAR(warm.start(0), std::cbrt(c), 1e-6 * std::cbrt(c));
  EXPECT_NEAR(warm.start(1), -1.0, 1e-6);
  EXPECT_LE(warm.correction, o.tolerance);
  // Only chord steps: the first beat, then one beat per step, linear rate ~ 0.33 % / 1 (3 steps
  // from a start 6.6e-3 off reach 1e-6 scaled).
  EXPECT_GE(warm.chord_steps, 1);
  EXPECT_EQ(warm.newton_steps, 0);
  EXPECT_LE(warm.beats, 1 + 4);
  EXPECT_LT(warm.beats, cold.beats);
}

TEST(PeriodicShooting, AWarmStartFromAFarMapHandsOverToNewtonAndStillConverges) {
  const ShootingWarmStart far = warm_start_at_root_two();
  // The root at 3 instead of 2: the chord slope 0.12 is a quarter of the true one (0.27) there,
  // so chord steps overshoot and do not halve |G|; Newton-Krylov takes over.
  const ShootingResult r =
      find_periodic_state(Eigen::Vector2d(1.0, 5.0), cubic_map(27.0), ShootingOptions{}, &far);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_NEAR(r.start(0), 3.0, 1e-6 * 3.0);
  EXPECT_NEAR(r.start(1), -1.0, 1e-6);
  EXPECT_GE(r.newton_steps, 1);
}

}  // namespace
}  // namespace sigmaheart::model
