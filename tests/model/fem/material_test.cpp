// Stresses and tangents of the hyperelastic laws against finite differences of the energy.
#include "model/fem/material.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

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

// S against dW/dE and D against dS/dE, by central differences on symmetric perturbations.
void check_law(const Material& m) {
  const Frame R = test_frame();
  const Eigen::Matrix3d E = test_strain();
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
          EXPECT_NEAR(dSa[3 * K + L], dS(K, L), 1e-6 * D.norm()) << m.name() << " D(" << K << L << "," << I << J << ")";
    }
  // Major and minor symmetry of D (the element kernel contracts D with F^T dF, not symmetric).
  EXPECT_LT((D - D.transpose()).norm(), 1e-10 * D.norm());
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J)
      for (int c = 0; c < 9; ++c) EXPECT_NEAR(D(3 * I + J, c), D(3 * J + I, c), 1e-10 * D.norm()) << m.name();
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
