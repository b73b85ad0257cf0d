// The physiology the literature reports for acute pacing (issue 47, item 5), on lv-3d: the
// lbbb-heart-failure preset on the coarse mesh with linear tetrahedra (the numerics of the cohort's
// truths, experiments/therapy/run) at 10 ms steps, its LBBB activation against a synchronous one,
// biventricular pacing at the lateral wall and at the septum, anterior and posterolateral scars.
// About 42 periodic 3D runs (slow tier).
//  - LBBB lowers dP/dt max, SV and EF against synchronous activation, EDV about unchanged (acute,
//    same preload): Strik et al. 2012 (J Cardiovasc Transl Res 5:117), the canine LBBB model.
//  - BiV pacing raises dP/dt max in LBBB and not in a synchronous heart (Auricchio et al. 1999,
//    Circulation 99:2993: the LV-pacing site and dP/dt; Kass et al. 1999, Circulation 99:1567).
//  - A lead over scar does worse than the latest activated site outside it (Khan et al. 2012, J Am
//    Coll Cardiol 59:1509, the TARGET trial's guide to lead placement); a posterolateral scar leaves
//    no responder (Bleeker et al. 2006, Circulation 113:969).
#include "app/blackbox/register.h"
#include "app/config.h"
#include "estimation/therapy/therapy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace sigmaheart::estimation::therapy {
namespace {

namespace act = model::activation;

app::Config heart(const std::string& activation, const std::string& scar_parameters = "") {
  return app::parse_config(
      "name: physiology\nsimulator:\n  model: lv-3d\n  preset: lbbb-heart-failure\n"
      "  numerics: {mesh: coarse, dt: 10 ms, max_beats: 8, element_order: 1, bulk_modulus: 10 MPa, "
      "quadrature_degree: 1, activation: " + activation + "}\n" +
          (scar_parameters.empty() ? "" : "  parameters: {" + scar_parameters + "}\n"),
      "physiology.yaml", {}, app::blackbox::cli_models());
}

TherapyOptions at(std::vector<int> sites, std::vector<int> scar = {}) {
  TherapyOptions o;
  for (int s : sites) o.lv_sites.push_back({s, act::Surface::kEpicardium, std::nullopt});
  o.scar = std::move(scar);
  o.ensemble.threads = 2;
  return o;
}

double ahr(const TherapySummary& s, int k) { return s.map[static_cast<size_t>(k)].change_moments.mean(0); }

TEST(TherapyPhysiologySlow, LbbbLowersDpdtSvAndEfAndBivPacingRestoresDpdtOnlyInLbbb) {
  const app::Config lbbb = heart("lbbb"), sync = heart("synchronous");
  const auto ml = lbbb.simulator.make(), ms = sync.simulator.make();
  // LV sites: basal inferolateral (5, latest in LBBB), mid anterior (7), mid inferoseptal (9).
  const TherapySummary l = run_therapy_study(*ml, lbbb.simulator.parameters.nominal(), {}, std::nullopt, at({5, 7, 9}));
  const TherapySummary s = run_therapy_study(*ms, sync.simulator.parameters.nominal(), {}, std::nullopt, at({5}));
  ASSERT_TRUE(l.ok()) << l.message;
  ASSERT_TRUE(s.ok()) << s.message;
  const Eigen::VectorXd& b = l.baseline.raw_moments.mean;  // dPdt_max, SV, EF, EDV, ESV, SW, TAT
  const Eigen::VectorXd& n = s.baseline.raw_moments.mean;
  EXPECT_LT(b(0), 0.9 * n(0));                    // dP/dt max
  EXPECT_LT(b(1), n(1));                          // SV
  EXPECT_LT(b(2), n(2));                          // EF
  EXPECT_NEAR(b(3) / n(3), 1.0, 0.05);            // EDV about unchanged
  EXPECT_GT(ahr(l, 0), 5.0);                      // BiV at the late lateral wall: a response
  EXPECT_LE(ahr(s, 0), 0.0);                      // and none in the synchronous heart
  EXPECT_EQ(l.best, 0);                           // of the three, the late lateral wall is the best
  EXPECT_GT(ahr(l, 0), ahr(l, 2));                // septal LV pacing does little
}

// The LBBB heart with a dense scar (15 % of the contractility) in `scar_segments`, the LV lead at each
// of the 17 segments.
TherapySummary scar_map(const std::vector<int>& scar_segments) {
  std::string scar;
  for (int k : scar_segments)
    scar += std::string(scar.empty() ? "" : ", ") + "sigma0_" + (k < 10 ? "0" : "") + std::to_string(k) + ": 12750";
  const app::Config c = heart("lbbb", scar);
  const auto m = c.simulator.make();
  std::vector<int> all(act::kSegments);
  for (int k = 0; k < act::kSegments; ++k) all[static_cast<size_t>(k)] = k + 1;
  return run_therapy_study(*m, c.simulator.parameters.nominal(), {}, std::nullopt, at(all, scar_segments));
}

bool in(const std::vector<int>& segments, int segment) {
  return std::find(segments.begin(), segments.end(), segment) != segments.end();
}

TEST(TherapyPhysiologySlow, PacingInAnAnteriorScarDoesWorseThanAtTheLatestActivatedSiteOutsideIt) {
  // An LAD scar: a lead in it does not capture (RV pacing alone), and the latest activated segment
  // outside it (Khan et al. 2012: the target of lead placement) does better than every lead in it.
  const std::vector<int> scar{1, 2, 7, 8, 13, 14, 17};
  const TherapySummary s = scar_map(scar);
  ASSERT_TRUE(s.ok()) << s.message;
  int latest = 0;  // the latest activated segment outside scar at baseline
  for (int k = 1; k <= act::kSegments; ++k)
    if (!in(scar, k) && (latest == 0 || s.baseline.segment_times[static_cast<size_t>(k - 1)] >
                                            s.baseline.segment_times[static_cast<size_t>(latest - 1)]))
      latest = k;
  double best_lead_in_scar = -1e9;
  for (int k : scar) {
    EXPECT_EQ(s.map[static_cast<size_t>(k - 1)].captured, (std::vector<bool>{true, false})) << "segment " << k;
    best_lead_in_scar = std::max(best_lead_in_scar, ahr(s, k - 1));
  }
  EXPECT_GT(ahr(s, latest - 1), best_lead_in_scar + 5.0) << "latest activated outside scar: segment " << latest;
  EXPECT_FALSE(in(scar, s.best + 1));
}

TEST(TherapyPhysiologySlow, APosterolateralScarLeavesNoSiteAResponder) {
  // An LCx scar takes the late-activated wall that resynchronisation would recruit: no LV site
  // reaches the responder threshold (Bleeker et al. 2006, Circulation 113:969: posterolateral scar
  // predicts non-response to CRT).
  const TherapySummary s = scar_map({5, 6, 11, 12, 16});
  ASSERT_TRUE(s.ok()) << s.message;
  for (int k = 0; k < act::kSegments; ++k) EXPECT_LT(ahr(s, k), 10.0) << "segment " << k + 1;
}

}  // namespace
}  // namespace sigmaheart::estimation::therapy
