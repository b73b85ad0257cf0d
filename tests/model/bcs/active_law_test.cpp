#include "model/bcs/active_law.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iterator>

namespace sigmaheart::model::bcs {
namespace {

TEST(ActiveFraction, CountsTheExactOverlapOfAStepWithTheActivationWindow) {
  // Window [0.1, 0.4) every 1 s.
  EXPECT_NEAR(active_fraction(0.09, 0.11, 0.1, 0.3, 1.0), 0.5, 1e-12);
  EXPECT_NEAR(active_fraction(0.2, 0.3, 0.1, 0.3, 1.0), 1.0, 1e-12);
  EXPECT_NEAR(active_fraction(0.395, 0.405, 0.1, 0.3, 1.0), 0.5, 1e-9);
  EXPECT_NEAR(active_fraction(0.5, 0.6, 0.1, 0.3, 1.0), 0.0, 1e-12);
  // Next beat, and a window that wraps over the beat end (T_d = 0.9, APD = 0.3).
  EXPECT_NEAR(active_fraction(1.09, 1.11, 0.1, 0.3, 1.0), 0.5, 1e-9);
  EXPECT_NEAR(active_fraction(0.95, 1.15, 0.9, 0.3, 1.0), 1.0, 1e-9);
  EXPECT_NEAR(active_fraction(1.1, 1.3, 0.9, 0.3, 1.0), 0.5, 1e-9);
  // A step longer than a period sees APD/period of it.
  EXPECT_NEAR(active_fraction(0.0, 2.0, 0.1, 0.3, 1.0), 0.3, 1e-12);
}

TEST(ActiveLaw, StepJacobianMatchesCentralFiniteDifferences) {
  ActiveParameters p;
  p.n0_slope = 2.0;  // on the ramp of the length dependence, so its derivative is exercised
  p.n0_e_max = 0.1;
  const ActiveState old{0.05, 3e4, 4e4};
  const ActiveState trial{0.04, 3.5e4, 4.5e4};
  const double e = 0.07, h = 1e-3;
  const StepActivation act = step_activation(0.0, h, 0.0, 1.0, p);
  const ActiveStep s = step_residual(p, old, trial, e, act, h);

  const double steps[3] = {1e-7, 1e-1, 1e-1};
  for (int j = 0; j < 3; ++j) {
    ActiveState plus = trial, minus = trial;
    double* pp = j == 0 ? &plus.e_c : (j == 1 ? &plus.k_c : &plus.tau_c);
    double* pm = j == 0 ? &minus.e_c : (j == 1 ? &minus.k_c : &minus.tau_c);
    *pp += steps[j];
    *pm -= steps[j];
    const Eigen::Vector3d fd = (step_residual(p, old, plus, e, act, h).residual -
                                step_residual(p, old, minus, e, act, h).residual) /
                               (2.0 * steps[j]);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(s.d_state(i, j), fd(i), 1e-6 * (1.0 + std::abs(fd(i)))) << i << "," << j;
    }
    if (j == 0) {
      const double fds = (step_residual(p, old, plus, e, act, h).stress -
                          step_residual(p, old, minus, e, act, h).stress) / (2.0 * steps[j]);
      EXPECT_NEAR(s.dstress_dstate(0), fds, 1e-6 * std::abs(fds));
    }
  }
  const double de = 1e-7;
  const Eigen::Vector3d fd = (step_residual(p, old, trial, e + de, act, h).residual -
                              step_residual(p, old, trial, e - de, act, h).residual) / (2 * de);
  EXPECT_NEAR(s.d_strain(0), fd(0), 1e-6 * std::abs(fd(0)));
  const double fds = (step_residual(p, old, trial, e + de, act, h).stress -
                      step_residual(p, old, trial, e - de, act, h).stress) / (2 * de);
  EXPECT_NEAR(s.dstress_dstrain, fds, 1e-6 * std::abs(fds));
}

// reduced_step eliminates k_c and tau_c exactly: the full residual vanishes in its rows 2-3 and its
// first row and total derivative match; checked with the length-dependent n0 switched on.
TEST(ActiveLaw, ReducedStepSolvesTheRateEquationsExactly) {
  ActiveParameters p;
  p.n0_slope = 2.0;
  p.n0_e_max = 0.1;
  const ActiveState old{0.05, 3e4, 4e4};
  const double e = 0.07, h = 1e-3;
  const StepActivation act = step_activation(0.0, h, 0.0, 1.0, p);
  const double ec = 0.045;
  const ReducedStep r = reduced_step(p, old, ec, e, act, h);
  const ActiveStep full = step_residual(p, old, r.state, e, act, h);
  EXPECT_NEAR(full.residual(1), 0.0, 1e-6);
  EXPECT_NEAR(full.residual(2), 0.0, 1e-6);
  EXPECT_NEAR(full.residual(0), r.residual, 1e-9 * std::abs(r.residual));
  EXPECT_NEAR(length_factor(ec, p), 0.89, 1e-12);  // 1 - 2 (0.1 - 0.045)

  const double d = 1e-8;
  const ReducedStep rp = reduced_step(p, old, ec + d, e, act, h);
  const ReducedStep rm = reduced_step(p, old, ec - d, e, act, h);
  EXPECT_NEAR(r.dres_dec, (rp.residual - rm.residual) / (2 * d), 1e-6 * std::abs(r.dres_dec));
  EXPECT_NEAR(r.dk_dec, (rp.state.k_c - rm.state.k_c) / (2 * d), 1e-6 * std::abs(r.dk_dec));
  EXPECT_NEAR(r.dtau_dec, (rp.state.tau_c - rm.state.tau_c) / (2 * d),
              1e-6 * std::abs(r.dtau_dec));
  EXPECT_NEAR(r.dstress_dec, (rp.stress - rm.stress) / (2 * d), 1e-6 * std::abs(r.dstress_dec));
  const ReducedStep ep = reduced_step(p, old, ec, e + d, act, h);
  const ReducedStep em = reduced_step(p, old, ec, e - d, act, h);
  EXPECT_NEAR(r.dres_de, (ep.residual - em.residual) / (2 * d), 1e-6 * std::abs(r.dres_de));
}

TEST(ActiveLaw, CondensedTangentIsTheDerivativeOfTheCondensedStress) {
  ActiveParameters p;
  const ActiveState old{0.02, 5e4, 6e4};
  const double h = 1e-3, e = 0.03;
  const StepActivation act = step_activation(0.1, 0.1 + h, 0.0, 1.0, p);
  CondensedStep c, cp, cm;
  ASSERT_TRUE(condense_step(p, old, e, act, h, c));
  const double de = 1e-7;
  ASSERT_TRUE(condense_step(p, old, e + de, act, h, cp));
  ASSERT_TRUE(condense_step(p, old, e - de, act, h, cm));
  const double fd = (cp.stress - cm.stress) / (2 * de);
  EXPECT_NEAR(c.tangent, fd, 1e-5 * std::abs(fd));
  EXPECT_LE(c.iterations, 10);
}

// Held at a fixed strain with u = +k_ATP for long, the law settles at tau_c = sigma0, k_c = k0
// (docs/models.md s.1 with de_c/dt = 0), and the series element carries
// sigma_1D = tau_c (1 + 2 e_c)/(1 + 2 e).
TEST(ActiveLaw, IsometricContractionSettlesAtSigma0AndK0) {
  ActiveParameters p;
  p.APD = 5.0;
  const double e = 0.1, h = 1e-3, period = 10.0;
  ActiveState s{e, 0.0, 0.0};
  CondensedStep c;
  for (int n = 0; n < 2000; ++n) {
    const double t0 = n * h;
    ASSERT_TRUE(condense_step(p, s, e, step_activation(t0, t0 + h, 0.0, period, p), h, c));
    s = c.state;
  }
  EXPECT_NEAR(s.tau_c, p.sigma0, 1e-6 * p.sigma0);
  EXPECT_NEAR(s.k_c, p.k0, 1e-6 * p.k0);
  EXPECT_NEAR(c.stress, s.tau_c * (1 + 2 * s.e_c) / (1 + 2 * e), 1e-6 * p.sigma0);
  EXPECT_LT(s.e_c, e);  // the contractile element shortened against the series element
}

// After repolarisation (u = -k_RS) an isometric fibre relaxes as exp(-k_RS t). With alpha = 0 and
// k0 = 0 the tau_c equation decouples from e_c: backward Euler gives tau^n = tau^0/(1 + h k_RS)^n.
TEST(ActiveLaw, IsometricRelaxationDecaysAtRateKRS) {
  ActiveParameters p;
  p.APD = 0.0;
  p.alpha = 0.0;
  p.k0 = 0.0;
  const double e = 0.1, h = 1e-4, period = 10.0;
  const double tau0 = p.sigma0;
  ActiveState s{e - 0.03, 0.0, tau0};
  CondensedStep c;
  for (int n = 0; n < 1000; ++n) {  // 0.1 s
    const double t0 = 1.0 + n * h;
    ASSERT_TRUE(condense_step(p, s, e, step_activation(t0, t0 + h, 0.0, period, p), h, c));
    s = c.state;
  }
  EXPECT_NEAR(s.tau_c, tau0 / std::pow(1.0 + h * p.k_RS, 1000), 1e-9 * tau0);
  const double exact = tau0 * std::exp(-p.k_RS * 0.1);
  EXPECT_NEAR(s.tau_c, exact, 0.005 * exact);
  // The stress follows tau_c through the series element: sigma_1D (1 + 2e)/(1 + 2e_c) = tau_c
  // up to the small viscous term mu de_c/dt.
  EXPECT_NEAR(c.stress * (1 + 2 * e) / (1 + 2 * s.e_c), s.tau_c, 0.01 * s.tau_c);
}

TEST(ActiveParameters, ValidateNamesTheBadField) {
  ActiveParameters p;
  EXPECT_EQ(p.validate(), "");
  p.mu = -1.0;
  EXPECT_NE(p.validate().find("mu"), std::string::npos);
  p.mu = 70.0;
  p.Es = 0.0;
  EXPECT_NE(p.validate().find("Es"), std::string::npos);
}

}  // namespace
// --- The ramped activation input (Caruel et al. 2014) ---------------------------------------

ActiveParameters caruel_rates() {
  ActiveParameters p;
  p.input.shape = ActivationShape::kRamped;
  p.k_ATP = 35.0;
  p.k_RS = 12.0;
  p.APD = 0.24;
  return p;
}

TEST(RampedActivation, ReproducesTheCaruelTableOfSvZeroDSolverAtItsKnots) {
  // chamber_sphere_straindependent_Caruel.json: u = -3.2, 35, 35, 0, -12, -12, -3.2 1/s at
  // t = 0.10, 0.27, 0.32, 0.34, 0.46, 0.59, 0.60 s of an 0.8 s cycle (depolarisation at 0.1 s).
  const ActiveParameters p = caruel_rates();
  const double period = 0.8, Td = 0.1;
  const double t[] = {0.10, 0.27, 0.32, 0.34, 0.46, 0.59, 0.60, 0.75, 0.05, 0.185, 0.40};
  const double u[] = {-3.2, 35.0, 35.0, 0.0, -12.0, -12.0, -3.2, -3.2, -3.2, 15.9, -6.0};
  for (size_t i = 0; i < std::size(t); ++i)
    EXPECT_NEAR(activation(t[i], Td, period, p), u[i], 1e-9) << "t = " << t[i];
  // The next beat repeats it.
  EXPECT_NEAR(activation(0.27 + period, Td, period, p), 35.0, 1e-9);
}

TEST(RampedActivation, StepAveragesAreTheExactIntegralsOfTheProfile) {
  const ActiveParameters p = caruel_rates();
  const double period = 0.8;
  // Steps across knots, across the zero of the fall, across the wrap of the period, longer than a
  // period; T_d inside and past the period.
  const double steps[][3] = {{0.26, 0.28, 0.1}, {0.335, 0.345, 0.1}, {0.05, 0.15, 0.1}, {0.79, 0.93, 0.1},
                             {0.0, 2.0, 0.1},   {0.3, 0.31, 0.75},   {1.2, 1.25, 1.7}, {0.1, 0.1001, 0.1}};
  for (const auto& s : steps) {
    const double t0 = s[0], t1 = s[1], Td = s[2];
    const StepActivation a = step_activation(t0, t1, Td, period, p);
    // Midpoint rule on 200 000 panels: the profile is piecewise linear, so the error is that of
    // the few panels holding a kink, below 1e-6 1/s here.
    const int n = 200000;
    double abs_sum = 0.0, plus_sum = 0.0;
    for (int k = 0; k < n; ++k) {
      const double u = activation(t0 + (k + 0.5) * (t1 - t0) / n, Td, period, p);
      abs_sum += std::abs(u);
      plus_sum += std::max(u, 0.0);
    }
    EXPECT_NEAR(a.u_abs, abs_sum / n, 1e-6) << "[" << t0 << ", " << t1 << "], T_d " << Td;
    EXPECT_NEAR(a.u_plus, plus_sum / n, 1e-6) << "[" << t0 << ", " << t1 << "], T_d " << Td;
  }
}

TEST(RampedActivation, KnotsPastThePeriodAreCutWhereTheNextBeatStarts) {
  ActiveParameters p = caruel_rates();
  p.APD = 0.3;  // relaxation knots at 0.42, 0.55, 0.56 s: past a 0.5 s period
  const double period = 0.5;
  // Just before the next depolarisation: on the ramp from 0 (at 0.3 s) to -12 (at 0.42 s).
  EXPECT_NEAR(activation(period - 1e-12, 0.0, period, p), -12.0, 1e-6);
  EXPECT_NEAR(activation(0.36, 0.0, period, p), -6.0, 1e-9);
  // And the profile restarts at the rest rate.
  EXPECT_NEAR(activation(period, 0.0, period, p), -3.2, 1e-9);
}

TEST(RampedActivation, TheSquareWaveStaysTheDefault) {
  const ActiveParameters p;
  EXPECT_EQ(p.input.shape, ActivationShape::kSquare);
  EXPECT_EQ(activation(0.1, 0.0, 1.0, p), p.k_ATP);
  EXPECT_EQ(activation(0.5, 0.0, 1.0, p), -p.k_RS);
}

TEST(RampedActivation, InvalidShapesAreRefusedWithTheField) {
  ActiveParameters p = caruel_rates();
  p.input.ramp.rise = 0.95;  // rise + fall > 1
  EXPECT_NE(p.validate().find("rise + fall"), std::string::npos) << p.validate();
  p.input.ramp.rise = 0.5;
  p.input.ramp.rest = 2.0;
  EXPECT_EQ(p.validate().rfind("rest = ", 0), 0u) << p.validate();
  p.input.ramp.rest = 0.2;
  p.input.ramp.relax_ramp = -0.1;
  EXPECT_EQ(p.validate().rfind("relax_ramp", 0), 0u) << p.validate();
}

}  // namespace sigmaheart::model::bcs
