#include "model/circulation/circulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <utility>

namespace sigmaheart::model::circulation {
namespace {

TEST(ValveFlow, IsContinuousAtBothValveThresholds) {
  const CirculationParameters c;
  const double P_at = 1e3, P_ar = 1e4, eps = 1e-6;
  for (double P : {P_at, P_ar}) {
    const ValveFlow below = valve_flow(P - eps, P_ar, P_at, c);
    const ValveFlow above = valve_flow(P + eps, P_ar, P_at, c);
    EXPECT_NE(below.regime, above.regime);
    EXPECT_NEAR(below.q, above.q, 1e-12);
    EXPECT_NEAR(below.q_ar, above.q_ar, 1e-12);
    EXPECT_NEAR(below.q_at, above.q_at, 1e-12);
  }
  // Conservation: ventricular outflow = aortic flow - mitral inflow, in every regime.
  for (double P : {500.0, 5e3, 1.2e4}) {
    const ValveFlow f = valve_flow(P, P_ar, P_at, c);
    EXPECT_NEAR(f.q, f.q_ar - f.q_at, 1e-15);
  }
  EXPECT_NEAR(valve_flow(1.2e4, P_ar, P_at, c).q_ar, c.K_ar * 2e3, 1e-15);
  EXPECT_NEAR(valve_flow(500.0, P_ar, P_at, c).q_at, c.K_at * 500.0, 1e-15);
}

TEST(ValveFlow, DerivativesMatchFiniteDifferencesInEveryRegime) {
  const CirculationParameters c;
  const double P_at = 1e3, P_ar = 1e4, d = 1e-2;
  for (double P : {500.0, 5e3, 1.2e4}) {
    const ValveFlow f = valve_flow(P, P_ar, P_at, c);
    const auto qv = [&](double pv, double par) { return valve_flow(pv, par, P_at, c); };
    EXPECT_NEAR(f.dq_dPv, (qv(P + d, P_ar).q - qv(P - d, P_ar).q) / (2 * d), 1e-15);
    EXPECT_NEAR(f.dq_dPar, (qv(P, P_ar + d).q - qv(P, P_ar - d).q) / (2 * d), 1e-15);
    EXPECT_NEAR(f.dqar_dPv, (qv(P + d, P_ar).q_ar - qv(P - d, P_ar).q_ar) / (2 * d), 1e-15);
    EXPECT_NEAR(f.dqar_dPar, (qv(P, P_ar + d).q_ar - qv(P, P_ar - d).q_ar) / (2 * d), 1e-15);
    const auto qa = [&](double pat) { return valve_flow(P, P_ar, pat, c).q; };
    EXPECT_NEAR(f.dq_dPat, (qa(P_at + d) - qa(P_at - d)) / (2 * d), 1e-15);
  }
}

TEST(Phase, ClosedValvesAreContractionAfterFillingAndRelaxationAfterEjection) {
  EXPECT_EQ(static_cast<int>(phase(ValveRegime::kFilling, ValveRegime::kEjection)), 0);
  EXPECT_EQ(static_cast<int>(phase(ValveRegime::kClosed, ValveRegime::kFilling)), 1);
  EXPECT_EQ(static_cast<int>(phase(ValveRegime::kEjection, ValveRegime::kFilling)), 2);
  EXPECT_EQ(static_cast<int>(phase(ValveRegime::kClosed, ValveRegime::kEjection)), 3);
}

TEST(AtrialPressure, KicksOnceABeatJustBeforeDepolarisation) {
  const AtrialPressure a{.P_at0 = 1e3, .P_at_kick = 500.0, .kick_duration = 0.1, .period = 0.8};
  EXPECT_DOUBLE_EQ(a(0.3), 1e3);
  EXPECT_NEAR(a(0.75), 1.5e3, 1e-9);            // middle of [0.7, 0.8)
  EXPECT_NEAR(a(0.75 + 3 * 0.8), 1.5e3, 1e-6);  // periodic
  EXPECT_NEAR(a(0.8), 1e3, 1e-9);               // continuous at the beat start
  EXPECT_NEAR(a(0.7999999), 1e3, 1e-6 * 500.0 + 1e-3);
}

// The atrial chamber's backward-Euler step is solved exactly in every valve regime: the residual
// of its volume balance vanishes at the returned P_at (to rounding), V_at = V0 + P_at / E, and the
// derivatives in (P_v, P_ar) match central differences (the kinks lie 10+ Pa away).
TEST(AtrialChamber, TheStepSolvesTheVolumeBalanceExactlyInEveryRegime) {
  CirculationParameters c;
  c.K_p = 5e-10;  // a visible leak, so that the closed regimes depend on P_at
  const AtrialChamber a{.E_min = 2e7, .E_max = 5e7, .V0 = 4e-6, .P_pv = 1100.0, .R_pv = 8e5,
                        .kick_duration = 0.12, .period = 0.8};
  const double h = 1e-3, V_old = 6e-5;
  int regimes_seen[3] = {0, 0, 0};
  for (double t1 : {0.3, 0.74}) {  // passive, and at the kick
    // (P_v, P_ar): filling; closed below the arteries; ejection (aortic open, atrium below P_ar)
    for (auto [Pv, Par] : {std::pair{400.0, 1e4}, {5e3, 1e4}, {1.2e4, 1e4}}) {
      const AtrialStep s = atrial_step(a, a.elastance(t1), Pv, Par, V_old, h, c);
      const double E = a.elastance(t1);
      const ValveFlow f = valve_flow(Pv, Par, s.P_at, c);
      ++regimes_seen[static_cast<int>(f.regime)];
      const double r = (s.V_at - V_old) / h - (a.P_pv - s.P_at) / a.R_pv + f.q_at;
      EXPECT_LT(std::abs(r), 1e-12 * std::abs(a.P_pv / a.R_pv)) << "t1 " << t1 << " P_v " << Pv;
      EXPECT_NEAR(s.V_at, a.V0 + s.P_at / E, 1e-18);
      const double d = 1e-3;
      auto P = [&](double pv, double par) {
        return atrial_step(a, a.elastance(t1), pv, par, V_old, h, c).P_at;
      };
      EXPECT_NEAR(s.dPat_dPv, (P(Pv + d, Par) - P(Pv - d, Par)) / (2 * d), 1e-7);
      EXPECT_NEAR(s.dPat_dPar, (P(Pv, Par + d) - P(Pv, Par - d)) / (2 * d), 1e-7);
    }
  }
  EXPECT_GT(regimes_seen[0], 0);
  EXPECT_GT(regimes_seen[1], 0);
  EXPECT_GT(regimes_seen[2], 0);
  // The kick raises the elastance from E_min to E_max at its middle, and is periodic.
  EXPECT_DOUBLE_EQ(a.elastance(0.3), 2e7);
  EXPECT_NEAR(a.elastance(0.74), 5e7, 1e-3);
  EXPECT_NEAR(a.elastance(0.74 + 2 * 0.8), 5e7, 1e-3);
}

// With the atrium at the venous pressure and the ventricle far below it, the step is the
// closed-form solution of the linear balance with the mitral valve open.
TEST(AtrialChamber, TheFillingStepMatchesItsClosedForm) {
  const CirculationParameters c;
  const AtrialChamber a{.E_min = 2e7, .E_max = 2e7, .V0 = 4e-6, .P_pv = 1e3, .R_pv = 8e5,
                        .kick_duration = 0.12, .period = 0.8};
  const double h = 1e-3, V_old = 5e-5, Pv = 200.0, Par = 1e4;
  const AtrialStep s = atrial_step(a, a.elastance(0.3), Pv, Par, V_old, h, c);
  // (V0 + P/E - V_old)/h = (P_pv - P)/R_pv - K_at (P - P_v)
  const double P = ((V_old - a.V0) / h + a.P_pv / a.R_pv + c.K_at * Pv) /
                   (1.0 / (a.E_min * h) + 1.0 / a.R_pv + c.K_at);
  EXPECT_NEAR(s.P_at, P, 1e-9 * P);
  EXPECT_NEAR(s.dPat_dPv, c.K_at / (1.0 / (a.E_min * h) + 1.0 / a.R_pv + c.K_at), 1e-15);
  EXPECT_EQ(s.dPat_dPar, 0.0);
}

// Backward Euler on a constant inflow converges to the steady state
// P_d = P_sv + q R_d, P_ar = P_d + q R_p (two resistances in series).
TEST(Windkessel, SettlesAtTheResistiveSteadyStateForConstantFlow) {
  const CirculationParameters c;
  const double q = 1e-4, h = 1e-2;
  double P_ar = 0.0, P_d = 0.0;
  for (int n = 0; n < 5000; ++n) {
    // The two residuals are linear: one 2x2 solve per step.
    const WindkesselResidual r0 = windkessel_residual(P_ar, P_d, P_ar, P_d, q, h, c);
    const double det = r0.dar_dPar * r0.dd_dPd - r0.dar_dPd * r0.dd_dPar;
    const double dPar = (-r0.r_ar * r0.dd_dPd + r0.dar_dPd * r0.r_d) / det;
    const double dPd = (-r0.dar_dPar * r0.r_d + r0.dd_dPar * r0.r_ar) / det;
    P_ar += dPar;
    P_d += dPd;
  }
  EXPECT_NEAR(P_d, c.P_sv + q * c.R_d, 1e-6 * P_d);
  EXPECT_NEAR(P_ar, c.P_sv + q * (c.R_d + c.R_p), 1e-6 * P_ar);
}

TEST(CirculationParameters, ValidateNamesTheBadField) {
  CirculationParameters c;
  EXPECT_EQ(c.validate(), "");
  c.C_p = 0.0;
  EXPECT_NE(c.validate().find("C_p"), std::string::npos);
}

}  // namespace
}  // namespace sigmaheart::model::circulation
