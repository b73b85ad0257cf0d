// Stresses and tangents of the hyperelastic laws against finite differences of the energy.
#include "model/fem/material.h"

#include "model/fem/electromechanics.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace sigmaheart::model::fem {
namespace {

Frame test_frame() {
  const Eigen::Vector3d f = Eigen::Vector3d(1, 0.3, 0.2).normalized();
  const Eigen::Vector3d s = (Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(f) * f).normalized();
  Frame R;
  R << f, s, f.cross(s);
  return R;
}

Eigen::Matrix3d test_strain() {
  Eigen::Matrix3d E;
  E << 0.05, 0.02, -0.01, 0.02, -0.03, 0.015, -0.01, 0.015, 0.04;
  return E;
}

// S against dW/dE and D against dS/dE, by central differences on symmetric perturbations at strain
// E in frame R; D to within d_tolerance of its norm.
void check_law(const Material& m, const Eigen::Matrix3d& E = test_strain(), const Frame& R = test_frame(),
               double d_tolerance = 1e-6) {
  Eigen::Matrix3d S;
  Matrix9d D;
  m.stress(E, R, S, D);
  const double h = 1e-6;
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J) {
      Eigen::Matrix3d dE = Eigen::Matrix3d::Zero();
      dE(I, J) += 0.5 * h;
      dE(J, I) += 0.5 * h;
      const double dW = (m.energy(E + dE, R) - m.energy(E - dE, R)) / (2 * h);
      EXPECT_NEAR(S(I, J), dW, 1e-6 * S.norm()) << m.name() << " S(" << I << "," << J << ")";
      Eigen::Matrix3d Sp, Sm;
      Matrix9d Dp;
      m.stress(E + dE, R, Sp, Dp);
      m.stress(E - dE, R, Sm, Dp);
      const Eigen::Matrix3d dS = (Sp - Sm) / (2 * h);
      Eigen::Matrix<double, 9, 1> sym = Eigen::Matrix<double, 9, 1>::Zero();
      sym[3 * I + J] += 0.5;
      sym[3 * J + I] += 0.5;
      const Eigen::Matrix<double, 9, 1> dSa = D * sym;
      for (int K = 0; K < 3; ++K)
        for (int L = 0; L < 3; ++L)
          EXPECT_NEAR(dSa[3 * K + L], dS(K, L), d_tolerance * D.norm()) << m.name() << " D(" << K << L << "," << I << J << ")";
    }
  // Major and minor symmetry of D (the element kernel contracts D with F^T dF, not symmetric).
  EXPECT_LT((D - D.transpose()).norm(), 1e-10 * D.norm());
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J)
      for (int c = 0; c < 9; ++c) EXPECT_NEAR(D(3 * I + J, c), D(3 * J + I, c), 1e-10 * D.norm()) << m.name();
}

// The BCS passive law (docs/models.md s.4.8) at a random strain about 0.2 I, in the identity frame;
// its exponential makes the differences of S less accurate: D within 1e-5 of its norm.
TEST(Material, BcsPassiveStressAndTangentMatchFiniteDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-0.15, 0.15);
  Eigen::Matrix3d E;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) E(i, j) = E(j, i) = U(rng);
  E += 0.2 * Eigen::Matrix3d::Identity();
  check_law(BcsPassive({200.0, 300.0, 200.0, 1.5}), E, Frame::Identity(), 1e-5);
}

// The modified Holzapfel-Ogden law of Arostica et al. 2025 with its Simo-Taylor penalty: S and D
// against finite differences at a stretched state (I4f > 1) and at the test strain, and with the
// fibre in compression (I4f < 1, where the switch chi is small but not zero).
TEST(Material, HolzapfelOgdenStressAndTangentMatchFiniteDifferences) {
  check_law(HolzapfelOgden(HolzapfelOgdenParameters{}));
  HolzapfelOgdenParameters no_penalty;
  no_penalty.kappa = 0.0;
  check_law(HolzapfelOgden(no_penalty));
  // Softer exponentials so the switch's own derivatives dominate near I4 = 1.
  HolzapfelOgdenParameters p;
  p.b_f = 1.0;
  p.b_s = 1.0;
  p.k = 20.0;
  check_law(HolzapfelOgden(p));
}

TEST(Material, HolzapfelOgdenIsStressFreeInTheReferenceAndRejectsBadParameters) {
  const HolzapfelOgden m(HolzapfelOgdenParameters{});
  Eigen::Matrix3d S;
  Matrix9d D;
  m.stress(Eigen::Matrix3d::Zero(), test_frame(), S, D);
  // chi(1) = 1/2 but (exp(0) - 1) = 0 and its derivative vanish at I4 = 1: no residual stress.
  EXPECT_LT(S.norm(), 1e-9);
  EXPECT_NEAR(m.energy(Eigen::Matrix3d::Zero(), test_frame()), 0.0, 1e-12);
  // Small-strain bulk response of the ST91 penalty alone (the isochoric term does not see a
  // dilatation; the anisotropic terms are switched off): tr(S)/3 = kappa (J - 1) (1 + O(e)).
  HolzapfelOgdenParameters iso;
  iso.a_f = iso.a_s = iso.a_fs = 0.0;
  const double e = 1e-6;
  HolzapfelOgden(iso).stress(e * Eigen::Matrix3d::Identity(), test_frame(), S, D);
  EXPECT_NEAR(S.trace() / 3.0 / (3.0 * e), 1.0e6, 1.0e6 * 1e-5);
  HolzapfelOgdenParameters bad;
  bad.a = -1;
  EXPECT_THROW(HolzapfelOgden{bad}, std::invalid_argument);
  bad = {};
  bad.kappa = std::numeric_limits<double>::infinity();
  EXPECT_THROW(HolzapfelOgden{bad}, std::invalid_argument);
}

TEST(Material, GuccioneStressAndTangentMatchFiniteDifferences) {
  check_law(Guccione({2e3, 8, 2, 4, false}));
  check_law(Guccione({2e3, 8, 2, 4, true}));
}

TEST(Material, IsochoricGuccioneEqualsTheFullLawAtUnitJacobian) {
  // A volume-preserving strain: C = diag(l^2, 1/l, 1/l).
  const double l = 1.2;
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  E.diagonal() << 0.5 * (l * l - 1), 0.5 * (1 / l - 1), 0.5 * (1 / l - 1);
  const Guccione full({2e3, 8, 2, 4, false}), iso({2e3, 8, 2, 4, true});
  EXPECT_NEAR(full.energy(E, test_frame()), iso.energy(E, test_frame()), 1e-9);
}

TEST(Material, MooneyRivlinStressAndTangentMatchFiniteDifferences) { check_law(MooneyRivlin({1e3, 3e2})); }

TEST(Material, GuccioneWithEqualWeightsIsIsotropic) {
  // bf = bt = bfs: Q = b E:E, independent of the frame.
  const Guccione g({1e4, 1, 1, 1});
  const Eigen::Matrix3d E = test_strain();
  EXPECT_NEAR(g.energy(E, test_frame()), g.energy(E, Frame::Identity()), 1e-9);
  const Guccione gf({1e4, 1, 1, 1, false});
  EXPECT_NEAR(gf.energy(E, Frame::Identity()), 0.5e4 * (std::exp(E.squaredNorm()) - 1.0), 1e-9);
}

TEST(Material, MooneyRivlinIsochoricEnergyIgnoresDilatation) {
  const MooneyRivlin m({1e3, 3e2});
  const Eigen::Matrix3d C = 1.2 * Eigen::Matrix3d::Identity();
  EXPECT_NEAR(m.energy(0.5 * (C - Eigen::Matrix3d::Identity()), Frame::Identity()), 0.0, 1e-9);
}

TEST(Material, ValidationRejectsNegativeStiffness) {
  EXPECT_FALSE(GuccioneParameters({-1, 1, 1, 1, true}).validate().empty());
  EXPECT_FALSE(MooneyRivlinParameters({0, 1}).validate().empty());
  EXPECT_THROW(Guccione({-1, 1, 1, 1, true}), std::invalid_argument);
}

}  // namespace
}  // namespace sigmaheart::model::fem
