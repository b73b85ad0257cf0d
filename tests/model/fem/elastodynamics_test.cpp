// Elastodynamics (model/fem/elastodynamics.h): the effective Newton tangent (mass, Robin
// spring-dashpots, viscous stress, material, follower pressure) against finite differences of the
// residual, and the whole time stepper in the small-amplitude limit against Newmark's
// average-acceleration recursion on the linearised system M a + C v + K u = f, whose solution is
// known exactly (the discrete recursion is solved with dense linear algebra).
#include "model/fem/elastodynamics.h"

#include "model/fem/fibres.h"
#include "model/fem/material.h"
#include "model/fem/mesh.h"
#include "tests/model/fem/perturbed_state.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <memory>

namespace sigmaheart::model::fem {
namespace {

// A 2 x 1 x 1 cm box (P2), HO law in displacement-only form, fibres along (1, 1, 0)/sqrt 2; full
// Robin on x = 0 (1e5 Pa/m, 5e3 Pa s/m), normal-only Robin (1e3 Pa/m, 5e3 Pa s/m) and the
// pressure on z = 0.
struct Box {
  Mesh mesh;
  std::unique_ptr<Mechanics> mech;
  std::unique_ptr<Elastodynamics> dyn;
  explicit Box(double eta = 100.0, double h = 1e-3, bool displacement_only = true) {
    mesh = box_mesh(0.02, 0.01, 0.01, 2, 1, 1, 2);
    const Eigen::Vector3d f = Eigen::Vector3d(1, 1, 0).normalized();
    const Eigen::Vector3d s = Eigen::Vector3d(-1, 1, 0).normalized();
    MechanicsOptions mo;
    mo.pressure_surfaces = {kBottom};
    mo.displacement_only = displacement_only;
    mo.bulk_modulus = displacement_only ? 0.0 : 1e6;
    HolzapfelOgdenParameters hp;
    hp.kappa = displacement_only ? 1e6 : 0.0;
    mech = std::make_unique<Mechanics>(mesh, uniform_fibres(mesh, f, s), std::make_unique<HolzapfelOgden>(hp), mo);
    ElastodynamicsOptions eo;
    eo.viscosity = eta;
    eo.time_step = h;
    eo.robin = {RobinCondition{kClamped, 1e5, 5e3, false}, RobinCondition{kBottom, 1e3, 5e3, true}};
    dyn = std::make_unique<Elastodynamics>(*mech, eo);
  }
};

TEST(Elastodynamics, EffectiveTangentMatchesFiniteDifferences) {
  for (const bool disp_only : {true, false}) {
    Box b(100.0, 1e-3, disp_only);
    const Load load{2000.0, 3e4};
    DynamicState xn = b.dyn->initial_state(Load{});
    // A non-trivial previous level: displacement, velocity, acceleration and strain history.
    Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(xn.s.u.size(), 0.0, 1.0).array().sin();
    xn.s.u = 2e-4 * r;
    xn.v = 1e-2 * r.reverse();
    xn.a = 0.3 * r;
    for (size_t i = 0; i < xn.E.size(); ++i) {
      xn.E[i] = 1e-3 * Eigen::Matrix3d::Identity() * std::sin(static_cast<double>(i));
      xn.Edot[i] = 0.1 * Eigen::Matrix3d::Identity() * std::cos(static_cast<double>(i));
    }
    State trial = xn.s;
    trial.u += 1e-4 * r.array().cos().matrix();
    if (!disp_only) trial.p.setConstant(150.0);
    Eigen::VectorXd G;
    SparseMatrix K;
    ASSERT_TRUE(b.dyn->residual(xn, trial, load, &G, &K));
    const Eigen::MatrixXd Kd = K;
    const int n = static_cast<int>(G.size()), nu = static_cast<int>(trial.u.size());
    double worst = 0.0;
    for (int j = 0; j < n; j += 7) {
      if (b.mech->is_fixed(j)) continue;
      const double h = j < nu ? 1e-8 : 1e-3;
      const auto [sp, sm] = perturbed(trial, j, h);
      Eigen::VectorXd Gp, Gm;
      ASSERT_TRUE(b.dyn->residual(xn, sp, load, &Gp, nullptr));
      ASSERT_TRUE(b.dyn->residual(xn, sm, load, &Gm, nullptr));
      const Eigen::VectorXd fd = (Gp - Gm) / (2 * h);
      worst = std::max(worst, (fd - Kd.col(j)).norm() / std::max(Kd.col(j).norm(), 1e-30));
    }
    EXPECT_LT(worst, 1e-6) << (disp_only ? "displacement-only" : "mixed u-p");
  }
}

// With loads of 1e-4 Pa the strains are ~1e-7: geometric and material nonlinearity enter at that
// relative size (and round-off of E = (F^T F - I)/2 at 1e-16 / 1e-7), so the nonlinear stepper
// must reproduce the linear Newmark recursion to ~1e-6; an inconsistent term (a factor in the
// damping, the strain-rate rule, the predictor) gives O(1) differences. M, K, C are taken from the code (the tangent at u = 0 with and
// without the viscous term), so this checks the time stepping: the Newmark update, the
// trapezoidal strain rate (which must equal eta sym grad v in the linear limit), the
// dashpot velocity and the initial acceleration.
TEST(Elastodynamics, SmallAmplitudeMatchesLinearNewmarkRecursion) {
  const double h = 2e-3, eta = 100.0;
  Box b(eta, h);
  Box b_no_visc(0.0, h);
  const Load load{1e-4, 2e-4};  // pressure [Pa], active tension [Pa]: a step at t = 0
  DynamicState x = b.dyn->initial_state(load);
  const int nu = static_cast<int>(x.s.u.size());
  // Linear operators at u = 0, v = 0 (rest; strain history zero).
  DynamicState rest = b.dyn->initial_state(Load{});
  Eigen::VectorXd G0;
  SparseMatrix Kv, K0;
  ASSERT_TRUE(b.dyn->residual(rest, rest.s, Load{}, &G0, &Kv));
  ASSERT_TRUE(b_no_visc.dyn->residual(rest, rest.s, Load{}, &G0, &K0));
  // K_eff = K + 4/h^2 M + K_r + 2/h (C_r + C_visc): split it.
  const Eigen::MatrixXd M = Eigen::MatrixXd(b.dyn->mass()).topLeftCorner(nu, nu);
  const Eigen::MatrixXd Cr = Eigen::MatrixXd(b.dyn->robin_damping()).topLeftCorner(nu, nu);
  const Eigen::MatrixXd Cvisc = (Eigen::MatrixXd(Kv) - Eigen::MatrixXd(K0)).topLeftCorner(nu, nu) * (h / 2.0);
  const Eigen::MatrixXd K = Eigen::MatrixXd(K0).topLeftCorner(nu, nu) - 4.0 / (h * h) * M - 2.0 / h * Cr;  // static + Robin
  const Eigen::MatrixXd C = Cr + Cvisc;
  Eigen::VectorXd f;
  ASSERT_TRUE(b.mech->assemble(rest.s, load, &f, nullptr));
  f = -f.head(nu);
  // Newmark average acceleration on the linear system.
  Eigen::VectorXd u = Eigen::VectorXd::Zero(nu), v = u, a = M.ldlt().solve(f);
  EXPECT_LT((a - x.a).norm(), 1e-9 * a.norm());
  const Eigen::MatrixXd Keff = K + 4.0 / (h * h) * M + 2.0 / h * C;
  const auto lu = Keff.partialPivLu();
  double max_u = 0.0;
  for (int n = 0; n < 40; ++n) {
    const Eigen::VectorXd rhs = f + M * (4.0 / (h * h) * u + 4.0 / h * v + a) + C * (2.0 / h * u + v);
    const Eigen::VectorXd un = lu.solve(rhs);
    const Eigen::VectorXd an = 4.0 / (h * h) * (un - u) - 4.0 / h * v - a;
    v = v + 0.5 * h * (a + an);
    a = an;
    u = un;
    const StepRecord rec = b.dyn->step(x, load);
    ASSERT_TRUE(rec.converged) << rec.failure;
    max_u = std::max(max_u, u.lpNorm<Eigen::Infinity>());
    ASSERT_LT((x.s.u - u).lpNorm<Eigen::Infinity>(), 1e-5 * max_u) << "step " << n;
    ASSERT_LT((x.v - v).lpNorm<Eigen::Infinity>(), 1e-5 * v.lpNorm<Eigen::Infinity>()) << "step " << n;
  }
  EXPECT_NEAR(x.time, 40 * h, 1e-12);
  EXPECT_GT(max_u, 0.0);
}

// Undamped free vibration (no viscosity, no dashpots, springs only): the average-acceleration
// rule conserves the discrete energy of a linear system exactly; here the energy
// 1/2 v.M v + 1/2 u.(K + K_r) u of the small-amplitude problem stays at its initial value.
TEST(Elastodynamics, UndampedSmallVibrationConservesEnergy) {
  Mesh mesh = box_mesh(0.02, 0.01, 0.01, 2, 1, 1, 2);
  MechanicsOptions mo;
  mo.pressure_surfaces = {kBottom};
  mo.displacement_only = true;
  Mechanics mech(mesh, uniform_fibres(mesh, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()),
                 std::make_unique<HolzapfelOgden>(HolzapfelOgdenParameters{}), mo);
  ElastodynamicsOptions eo;
  eo.viscosity = 0.0;
  eo.time_step = 1e-3;
  eo.robin = {RobinCondition{kClamped, 1e5, 0.0, false}};
  Elastodynamics dyn(mech, eo);
  // Pushed by a small pressure (strains ~1e-8) for 5 steps, then free vibration about u = 0. The
  // step that removes the load does the work (f_n + f_{n+1})/2 . du; energy is conserved after it.
  DynamicState x = dyn.initial_state(Load{1e-5, 0.0});
  const int nu = static_cast<int>(x.s.u.size());
  for (int n = 0; n < 5; ++n) ASSERT_TRUE(dyn.step(x, Load{1e-5, 0.0}).converged);
  ASSERT_TRUE(dyn.step(x, Load{}).converged);
  SparseMatrix Keff;
  Eigen::VectorXd G;
  DynamicState rest = dyn.initial_state(Load{});
  ASSERT_TRUE(dyn.residual(rest, rest.s, Load{}, &G, &Keff));
  const Eigen::MatrixXd M = Eigen::MatrixXd(dyn.mass()).topLeftCorner(nu, nu);
  const Eigen::MatrixXd K = Eigen::MatrixXd(Keff).topLeftCorner(nu, nu) - 4.0 / (eo.time_step * eo.time_step) * M;
  auto energy = [&](const DynamicState& s) { return 0.5 * s.v.dot(M * s.v) + 0.5 * s.s.u.dot(K * s.s.u); };
  const double e0 = energy(x);
  ASSERT_GT(e0, 0.0);
  EXPECT_NEAR(dyn.kinetic_energy(x), 0.5 * x.v.dot(M * x.v), 1e-12 * e0);
  for (int n = 0; n < 50; ++n) {
    ASSERT_TRUE(dyn.step(x, Load{}).converged);
    EXPECT_NEAR(energy(x), e0, 1e-6 * e0) << "step " << n;
  }
}

TEST(Elastodynamics, RejectsBadInput) {
  Mesh mesh = box_mesh(0.02, 0.01, 0.01, 1, 1, 1, 1);
  MechanicsOptions mo;
  mo.displacement_only = true;
  Mechanics mech(mesh, uniform_fibres(mesh, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()),
                 std::make_unique<HolzapfelOgden>(HolzapfelOgdenParameters{}), mo);
  ElastodynamicsOptions eo;
  eo.time_step = 0.0;
  EXPECT_THROW(Elastodynamics(mech, eo), std::invalid_argument);
  eo = {};
  eo.robin = {RobinCondition{kEpicardium, 1.0, 1.0, true}};  // no such face on a box
  EXPECT_THROW(Elastodynamics(mech, eo), std::invalid_argument);
  eo = {};
  mech.fix_surface(kClamped);
  EXPECT_THROW(Elastodynamics(mech, eo), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model::fem
