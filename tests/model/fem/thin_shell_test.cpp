// lv-3d against the lumped sphere on a truncated spherical shell (thin_shell_comparison.h says how
// the two are matched): the tangent-isotropic active stress does not depend on the helix angle,
// and on a wall 0.4 of the radius (coarse mesh, dt 20 ms, one beat) the distance between the PV
// loops is the one of the slow study; ~19 s of CPU together. The study over d/R = 0.4, 0.2, 0.1
// and its mesh checks: thin_shell_slow_test.cpp; the numbers: docs/models.md s.4.8,
// "Consistency with the lumped sphere".
#include "tests/model/fem/thin_shell_comparison.h"

#include <gtest/gtest.h>

#include <cstdio>

namespace sigmaheart::model::fem {
namespace {

using testing::compare_thin_shell;
using testing::kMmHg;
using testing::ThinShellCase;
using testing::ThinShellComparison;

// Fibres spread evenly in the tangent plane: the average (f0 (x) f0 + s0 (x) s0)/2 is the same for
// every helix angle, so two fibre fields give the same beat to rounding; the single-fibre stress
// does not.
TEST(ThinShell, TangentIsotropicActiveStressIgnoresTheHelixAngle) {
  auto volume_after = [](ActiveStress a, double endo_deg, double epi_deg) {
    LeftVentricle3DOptions o;
    o.geometry = testing::thin_sphere_geometry(0.4, 0.9);
    o.active_stress = a;
    o.fibre_endo_deg = endo_deg;
    o.fibre_epi_deg = epi_deg;
    o.dt = 0.02;
    LeftVentricle3D lv(o);
    const Eigen::VectorXd theta = lv.parameters().nominal();
    model::State s = lv.initial_state(theta);
    EXPECT_TRUE(s.x.allFinite());
    const Status st = lv.advance(s, theta, 0.1);  // isovolumic contraction into ejection
    EXPECT_TRUE(st.ok()) << st.message;
    const Eigen::VectorXd y = lv.sample(s, theta);
    return Eigen::Vector2d(y(0), y(1));  // V_lv [m^3], P_lv [Pa]
  };
  const Eigen::Vector2d a = volume_after(ActiveStress::kTangentIsotropic, 60.0, -60.0);
  const Eigen::Vector2d b = volume_after(ActiveStress::kTangentIsotropic, 0.0, 30.0);
  const Eigen::Vector2d c = volume_after(ActiveStress::kFibre, 60.0, -60.0);
  EXPECT_NEAR(a(0), b(0), 1e-9 * a(0));
  EXPECT_NEAR(a(1), b(1), 1e-9 * a(1));
  EXPECT_GT(std::abs(a(1) - c(1)), 1e-3 * a(1));  // the single fibre direction is another law
}

// d/R = 0.4: the 3D loop lies where the slow study puts it (dt 10 ms, 9 x 24 mesh: max |dV|/SV
// 1.55, max |dP|/peak P 0.311, EDV 0.50, peak P 0.311); the thinner walls of the study approach
// the lumped loop.
TEST(ThinShell, ThickShellBeatIsAtTheStudysDistanceFromTheLumpedSphere) {
  ThinShellCase c;
  c.thickness_ratio = 0.4;
  c.dt = 0.02;
  const ThinShellComparison r = compare_thin_shell(c);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  std::printf("d/R 0.4 coarse dt 20 ms: EDV %.2f/%.2f mL ESV %.2f/%.2f mL peak P %.2f/%.2f mmHg | "
              "max|dV|/SV %.4f max|dP|/Ppk %.4f\n",
              r.edv3 * 1e6, r.edvl * 1e6, r.esv3 * 1e6, r.esvl * 1e6, r.pmax3 / kMmHg, r.pmaxl / kMmHg,
              r.max_dV_rel_sv, r.max_dP_rel_pk);
  // The lumped loop does not depend on the thickness (kappa scaling): the healthy sphere's.
  EXPECT_NEAR(r.edvl * 1e6, 174.3, 1.0);
  EXPECT_NEAR(r.esvl * 1e6, 92.0, 1.5);
  // Measured 1.545, 0.3105, 0.484, 0.3105.
  EXPECT_NEAR(r.max_dV_rel_sv, 1.55, 0.1);
  EXPECT_NEAR(r.max_dP_rel_pk, 0.31, 0.03);
  EXPECT_NEAR(r.edv_rel(), 0.48, 0.05);
  // The 3D wall is the more compliant and the weaker (thick-wall strain gradient).
  EXPECT_GT(r.edv3, r.edvl);
  EXPECT_GT(r.esv3, r.esvl);
  EXPECT_LT(r.pmax3, r.pmaxl);
}

}  // namespace
}  // namespace sigmaheart::model::fem
