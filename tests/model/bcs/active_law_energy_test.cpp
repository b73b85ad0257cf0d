// Energy balance of the Bestel-Clement-Sorine active law in the lumped sphere over one periodic
// beat (model/bcs/active_law.h, docs/models.md s.1-2): the work done on the cavity equals the work
// of the wall stresses, active + passive + viscous, plus the change of kinetic energy.
//
// Derivation (principle of virtual power for the thin sphere, Caruel et al. 2014, Biomech Model
// Mechanobiol 13:897, s.2.2; Chapelle et al. 2012, Int J Multiscale Comput Eng 10:189). The wall
// balance of docs/models.md s.2.1, with s = R/R0 = 1 + y/R0 and Sigma = Sigma_pas + Sigma_act +
// Sigma_vis,
//   rho d0 y'' + (d0/R0) s Sigma = P s^2,
// multiplied by the wall area 4 pi R0^2 times the velocity y':
//   M y' y'' + 4 pi R0 d0 s y' Sigma = P 4 pi R0^2 s^2 y' = P dV/dt,     M = 4 pi R0^2 rho d0,
// since V = 4/3 pi R0^3 s^3. With e = (s^2 - 1)/2, de/dt = s y'/R0, so 4 pi R0 d0 s y' = V_w de/dt
// with the reference wall volume V_w = 4 pi R0^2 d0:
//   P dV/dt = d/dt (M y'^2 / 2) + V_w (Sigma_pas + Sigma_act + Sigma_vis) de/dt.
// Sigma_pas = 2 dW/dC = dW/de makes the passive power the rate of the stored energy V_w dW/dt, and
// Sigma_vis de/dt = Sigma_vis (dC/dt)/2 is the channel viscous_power. Over the beat [0, T]:
//   int P dV = V_w int sigma_act de + V_w int viscous_power dt + V_w [W]_0^T + [M y'^2/2]_0^T,
// where the last two terms vanish for an exactly periodic beat (they are kept: the returned beat is
// periodic to periodic_tolerance only).
//
// Discretisation: the channels come from backward Euler (first order), the integrals are trapezoidal
// sums on the output times. The imbalance is the numerical dissipation of the scheme plus the
// quadrature error; both are first order in dt, so relative to the cavity work it is bounded by
// a number of order dt/T: asserted below dt/T (1.2e-3 at dt = 1 ms, T = 0.85 s), and required to
// fall when dt is halved.
#include "model/lumped/sphere.h"

#include "model/registry.h"
#include "tests/support/thin_sphere.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sigmaheart::model::lumped {
namespace {

struct EnergyBalance {
  double cavity = 0;   // int P dV [J] (negative: the ventricle does work on the blood)
  double active = 0;   // V_w int sigma_act de [J]
  double viscous = 0;  // V_w int viscous_power dt [J]
  double passive = 0;  // V_w int Sigma_pas de [J], by quadrature
  double stored = 0;   // V_w [W]_0^T [J], exact
  double kinetic = 0;  // [M y'^2/2]_0^T [J]
  double imbalance() const { return cavity - active - viscous - stored - kinetic; }
};

// The healthy preset (model/lumped/register.cpp) run at time step dt.
EnergyBalance energy_balance(double dt) {
  ParameterSpace space = LumpedSphere::default_parameters();
  for (const auto& [name, value] : builtin_models().find("lumped-sphere")->find_preset("healthy")->values) {
    space.set_nominal(name, value);
  }
  SphereOptions o;
  o.dt = dt;
  LumpedSphere sim(o, space);
  const RunResult r = sim.run(space.nominal());
  EXPECT_TRUE(r.status.ok()) << r.status.message;
  const auto w = sigmaheart::testing::ThinSphere::from(space, space.nominal());
  const Trajectory& tr = r.trajectory;
  const Eigen::VectorXd V = tr.channel("V_lv"), P = tr.channel("P_lv"), e = tr.channel("e_fibre");
  const Eigen::VectorXd sigma_act = tr.channel("sigma_act"), power = tr.channel("viscous_power");
  const double Vw = w.wall_volume();
  EnergyBalance b;
  for (Eigen::Index k = 1; k < tr.samples(); ++k) {
    const double h = tr.times(k) - tr.times(k - 1), de = e(k) - e(k - 1);
    b.cavity += 0.5 * (P(k) + P(k - 1)) * (V(k) - V(k - 1));
    b.active += Vw * 0.5 * (sigma_act(k) + sigma_act(k - 1)) * de;
    b.viscous += Vw * 0.5 * (power(k) + power(k - 1)) * h;
    b.passive += Vw * 0.5 * (w.passive_stress(1.0 + 2.0 * e(k)) + w.passive_stress(1.0 + 2.0 * e(k - 1))) * de;
  }
  const Eigen::Index n = tr.samples() - 1;
  b.stored = Vw * (w.strain_energy(1.0 + 2.0 * e(n)) - w.strain_energy(1.0 + 2.0 * e(0)));
  // Wall velocity y' = dR/dt from the last and first steps (backward, forward differences).
  auto y = [&](Eigen::Index k) { return w.radius(e(k)); };
  const double v_end = (y(n) - y(n - 1)) / (tr.times(n) - tr.times(n - 1));
  const double v_start = (y(1) - y(0)) / (tr.times(1) - tr.times(0));
  const double M = w.rho * Vw;
  b.kinetic = 0.5 * M * (v_end * v_end - v_start * v_start);
  return b;
}

TEST(ActiveLawEnergy, CavityWorkEqualsTheWorkOfTheWallStressesOverABeat) {
  const double T = 0.85, dt = 1e-3;
  const EnergyBalance b = energy_balance(dt);
  // Stroke work of a normal adult beat is of the order of 1 J (SV ~100 mL at ~100 mmHg).
  EXPECT_LT(b.cavity, -0.5);
  // The active element supplies the stroke work and what the viscous wall dissipates.
  EXPECT_LT(b.active, b.cavity);
  EXPECT_GT(b.viscous, 0.0);
  const double relative = std::abs(b.imbalance()) / std::abs(b.cavity);
  EXPECT_LT(relative, dt / T) << "int P dV " << b.cavity << " J, active " << b.active
                              << " J, viscous " << b.viscous << " J, stored " << b.stored
                              << " J, kinetic " << b.kinetic << " J";
  // The passive law is conservative: its work over the beat is the change of stored energy, up to
  // the error of the trapezoidal rule on a total differential (second order: (dt/T)^2 of the work).
  EXPECT_NEAR(b.passive, b.stored, (dt / T) * (dt / T) * std::abs(b.active));
}

TEST(ActiveLawEnergy, ImbalanceFallsWithTheTimeStep) {
  const EnergyBalance coarse = energy_balance(1e-3), fine = energy_balance(0.5e-3);
  EXPECT_LT(std::abs(fine.imbalance()), std::abs(coarse.imbalance()))
      << coarse.imbalance() << " J at 1 ms, " << fine.imbalance() << " J at 0.5 ms";
}

}  // namespace
}  // namespace sigmaheart::model::lumped
