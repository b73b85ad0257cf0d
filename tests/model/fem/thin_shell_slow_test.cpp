// The thin-shell study of docs/models.md s.4.8 ("Consistency with the lumped sphere"): lv-3d on
// truncated spherical shells with d/R = 0.4, 0.2, 0.1 (9 x 24 mesh) and 0.05 (12 x 36), dt 10 ms,
// one beat, against the lumped sphere (thin_shell_comparison.h), and three other meshes, so that
// the trend is not discretisation error. Slow tier: about 8 min of CPU (7.5 min, 2026-11-27).
#include "tests/model/fem/thin_shell_comparison.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

namespace sigmaheart::model::fem {
namespace {

using testing::compare_thin_shell;
using testing::kMmHg;
using testing::ThinShellCase;
using testing::ThinShellComparison;

// UMFPACK: SparseLU (the default, for the same bits on any thread count) factorises these meshes
// far more slowly (its fill grows as unknowns^2.7 on the 3D tangents,
// experiments/lv3d-solver/NOTES.md).
ThinShellCase study_case(double ratio, int longitudinal = 9, int circumferential = 24,
                         LinearSolver solver = LinearSolver::kUmfPack) {
  ThinShellCase c;
  c.linear_solver = solver;
  c.thickness_ratio = ratio;
  c.n_longitudinal = longitudinal;
  c.n_circumferential = circumferential;
  c.dt = 0.01;
  return c;
}

ThinShellComparison run_case(const ThinShellCase& c) {
  const ThinShellComparison r = compare_thin_shell(c);
  EXPECT_TRUE(r.status.ok()) << r.status.message;
  std::printf("d/R %.2f mesh %dx%d: R0 %.3f mm d0 %.3f mm kappa %.2f | EDV %.2f/%.2f mL ESV %.2f/%.2f mL "
              "peak P %.2f/%.2f mmHg | max|dV|/SV %.4f max|dP|/Ppk %.4f | EDV %.4f ESV %.4f SV %.4f Ppk %.4f\n",
              c.thickness_ratio, c.n_longitudinal, c.n_circumferential, r.R0 * 1e3, r.d0 * 1e3, r.kappa,
              r.edv3 * 1e6, r.edvl * 1e6, r.esv3 * 1e6, r.esvl * 1e6, r.pmax3 / kMmHg, r.pmaxl / kMmHg,
              r.max_dV_rel_sv, r.max_dP_rel_pk, r.edv_rel(), r.esv_rel(), r.sv_rel(), r.pmax_rel());
  std::fflush(stdout);
  return r;
}

// The PV-loop distance falls as the wall thins (each halving of d/R removes more than a quarter of
// it; measured: 38 %, then 35 % from 0.1 to 0.05), and at d/R = 0.1 and 0.05 it is below the
// stated tolerances. Thin walls need fine in-plane meshes (curved quadratic tetrahedra invert when
// the chord sag nears the thickness: d/R = 0.05 needs 12 x 36, about 3 min of CPU; d/R = 0.025 on
// 18 x 54 fails its passive inflation, so 0.05 is the thinnest run).
TEST(ThinShellSlow, DistanceToTheLumpedLoopFallsAsTheWallThins) {
  std::vector<ThinShellComparison> r;
  for (double ratio : {0.4, 0.2, 0.1}) {
    r.push_back(run_case(study_case(ratio)));
    ASSERT_TRUE(r.back().status.ok());
  }
  r.push_back(run_case(study_case(0.05, 12, 36)));
  ASSERT_TRUE(r.back().status.ok());
  for (size_t k = 1; k < r.size(); ++k) {
    EXPECT_LT(r[k].max_dV_rel_sv, 0.75 * r[k - 1].max_dV_rel_sv) << k;
    EXPECT_LT(r[k].max_dP_rel_pk, 0.75 * r[k - 1].max_dP_rel_pk) << k;
    EXPECT_LT(r[k].edv_rel(), 0.75 * r[k - 1].edv_rel()) << k;
  }
  // The tolerances at d/R = 0.1 (measured 0.595, 0.117, 0.177, 0.117) and 0.05 (measured 0.385,
  // 0.0745, 0.116, 0.0745).
  const ThinShellComparison& thin = r[2];
  EXPECT_LE(thin.max_dV_rel_sv, 0.65);
  EXPECT_LE(thin.max_dP_rel_pk, 0.13);
  EXPECT_LE(thin.edv_rel(), 0.20);
  EXPECT_LE(thin.pmax_rel(), 0.13);
  const ThinShellComparison& thinner = r[3];
  EXPECT_LE(thinner.max_dV_rel_sv, 0.42);
  EXPECT_LE(thinner.max_dP_rel_pk, 0.082);
  EXPECT_LE(thinner.edv_rel(), 0.13);
  EXPECT_LE(thinner.pmax_rel(), 0.082);

  // Mesh: longitudinal refinement at d/R = 0.1 and 0.05, circumferential coarsening at d/R = 0.2;
  // the distances move by far less than the thickness changes them (measured: 0.0012 and 0.0003
  // at 0.1, 0.0001 and 0.0002 at 0.05, 0.0025 and 0.0002 at 0.2).
  const ThinShellComparison fine = run_case(study_case(0.1, 12, 24));
  const ThinShellComparison finer = run_case(study_case(0.05, 16, 36));
  const ThinShellComparison coarse = run_case(study_case(0.2, 9, 18));
  ASSERT_TRUE(fine.status.ok());
  ASSERT_TRUE(finer.status.ok());
  ASSERT_TRUE(coarse.status.ok());
  EXPECT_NEAR(fine.max_dV_rel_sv, r[2].max_dV_rel_sv, 0.01);
  EXPECT_NEAR(fine.max_dP_rel_pk, r[2].max_dP_rel_pk, 0.002);
  EXPECT_NEAR(finer.max_dV_rel_sv, r[3].max_dV_rel_sv, 0.01);
  EXPECT_NEAR(finer.max_dP_rel_pk, r[3].max_dP_rel_pk, 0.002);
  EXPECT_NEAR(coarse.max_dV_rel_sv, r[1].max_dV_rel_sv, 0.01);
  EXPECT_NEAR(coarse.max_dP_rel_pk, r[1].max_dP_rel_pk, 0.002);
}

}  // namespace
}  // namespace sigmaheart::model::fem
