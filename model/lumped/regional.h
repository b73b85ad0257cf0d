// The regional lumped ventricle: N wall patches on one sphere (MultiPatch principle, Walmsley et
// al. 2015, "Fast simulation of mechanical heterogeneity in the electrically asynchronous heart
// using the MultiPatch module", PLoS Comput Biol 11:e1004284; docs/models.md section 3).
//
// All patches share one membrane tension and one curvature. Patch p has a reference area share
// w_p = A0_p / A0 (sum 1), its own areal stretch C_p, BCS active state (e_c, k_c, tau_c),
// contractility sigma0_p, activation time T_d,p, passive stiffness scale k_p and non-contractile
// (scar) fraction f_p. With s = R / R0:
//   C_p = s^2 c_p,  sum_p w_p c_p = 1        (compatibility sum A0_p C_p = 4 pi R^2)
//   Sigma_p = k_p Sigma_pas(C_p) + eta dC_p/dt (1 + 2 C_p^-6) + (1 - f_p) sigma_1D,p
//             + K_patch (c_p - 1)
//   Sigma_p = Sigma_q for all p, q           (equal tension T = d0 Sigma / 2)
//   rho d0 y'' + (d0/R0) s Sigma_bar = P_v s^2, Sigma_bar = sum_p w_p Sigma_p  (Laplace + inertia)
// c_p is the patch's share of the current area relative to its reference share, so the regional
// cavity volume (the cone from the centre, Marchesseau et al. 2013 Med Image Anal 17:816) is
// V_p = V A_p / A = V w_p c_p. With one patch c_1 = 1 and the equations reduce to LumpedSphere's.
//
// K_patch (c_p - 1) is a mean-field tethering term, our addition to MultiPatch: its area-weighted
// mean is K_patch (sum w_p c_p - 1) = 0, so it never loads the cavity, but it resists a patch's
// area departing from its share. K_patch = 0 is the pure MultiPatch of Walmsley et al.
//
// Dyssynchrony (docs/models.md s.3.2): acute LBBB must lower EF, stroke volume and dP/dt max at
// about the same EDV, as the 3D model lv-3d does (EF 64.4 -> 62.8 %, EDV -3.5 %). With a stiff
// tether (1e5 Pa) and the classical n0 = 1 it did the opposite (EF 61.0 -> 69.5 %, ESV 56 -> 36
// mL, EDV 144 -> 117 mL): the tether kept every patch within +-20 % of its share, so the late
// patches' tension added to the early ones' into one long systole instead of stretching them, and
// a shortened patch lost no force. Two changes, measured against lv-3d's LBBB beat:
//  - the patches' length-dependent activation n0(e_c) (bcs/active_law.h) from the tension-length
//    relation of human myocytes, h(lambda) = 1 + beta0 (lambda - 1), beta0 = 2.3, lambda <= 1.2
//    (Land et al. 2017, J Mol Cell Cardiol 106:68), on the sphere's fibre stretch lambda =
//    sqrt(1 + 2 e_c) from its unloaded radius, normalised at the cap and linearised in e_c:
//    n0_slope = 1.43, n0_e_max = 0.22 (n0 = 0.69 at lambda = 1);
//  - K_patch 1e4 Pa, at which the septal flash and rebound stretch and the lateral pre-stretch of
//    the lumped 140 ms LBBB (mid-septal share 0.57 -> 1.99 of its end-diastolic value, basal
//    lateral 1.40) come nearest those of the 3D heart (0.45 -> 1.69, lateral 1.81); 1e5 suppresses
//    them (0.88 -> 1.17, 1.17), 0 overshoots the rebound (2.64).
// The shortening-dependent loss of force needs a higher contractility for the same EF: the
// segments' sigma0 is 60 kPa (the sphere's 53).
//
// Time discretisation: the sphere's (sphere.cpp; grid, step cutting and run loop shared in
// shell.h): backward Euler on every equation, y, P_d and each
// patch's (k_c, tau_c) eliminated exactly, Newton on (v, P_v, P_ar, c_1..c_{N-1}, e_c,1..N), the
// same row scaling and stopping test, on the sphere's beat-local time grid, with
// dC_p/dt = 2 s (dy/dt / R0) c_p + s^2 (c_p - c_p^n)/h. One patch agrees with LumpedSphere to
// about 1e-11 relative over a periodic run (the Newton tolerance, not bitwise: the test allows 1e-9).
// Limits: no real tethering between patches (docs/models.md s.3); the geometry of the segments (area
// shares, activation delays) comes from a truncated ellipsoid, the mechanics from the sphere.
#pragma once

#include "model/lumped/sphere.h"
#include "model/simulator.h"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::model::lumped {

// The regional model's own defaults (docs/models.md s.3.2; the sphere keeps n0 = 1 and 53 kPa).
inline constexpr double kRegionalN0Slope = 1.43;  // [1] Land et al. 2017, beta0 2.3, linearised
inline constexpr double kRegionalN0EMax = 0.22;   // [1] e_c at stretch 1.2
inline constexpr double kRegionalKPatch = 1e4;    // [Pa] mean-field tether
inline constexpr double kRegionalSigma0 = 6.0e4;  // [Pa] every segment's contractility

// How activation times T_d,p (the nominal values of Td_XX) are set.
enum class ActivationPattern {
  kSynchronous,  // every patch at 0
  kLbbb,         // left bundle branch block: septal breakthrough, latest basal lateral wall
  kPacing,       // a pacing site at one segment, delays = wall path length / conduction velocity
  kExplicit,     // RegionalOptions::activation_times
};
const char* to_string(ActivationPattern pattern);
std::optional<ActivationPattern> parse_activation_pattern(const std::string& text);
// "synchronous", "lbbb", "pacing", "explicit"

struct RegionalOptions {
  SphereOptions numerics;  // dt, beats, periodicity, Newton: the sphere's numerics
  // Reference area shares of the patches (positive, summing to 1). Empty: the 17 AHA segments
  // (aha17_area_shares()). Activation patterns other than synchronous/explicit need the 17.
  std::vector<double> area_shares;
  ActivationPattern activation = ActivationPattern::kSynchronous;
  double lbbb_duration = 0.14;          // [s] latest minus earliest activation (QRS >= 130 ms)
  int pacing_segment = 17;              // 1-based AHA segment of the pacing lead (17: apex)
  double conduction_velocity = 0.6;     // [m/s] myocardial conduction for kPacing
  std::vector<double> activation_times; // [s] one per patch, kExplicit
  // Empty when valid, else a message naming the field.
  std::string validate() const;
  int patches() const;
};

// AHA 17-segment names (Cerqueira et al. 2002, Circulation 105:539), index 0 = segment 1.
const std::vector<std::string>& aha17_segment_names();

// Endocardial area shares of the 17 segments on the human-sized truncated prolate ellipsoid of
// docs/models.md s.4 (endocardium r_s 25 mm, r_l 45 mm, base plane z = 13.2 mm): the cavity length L
// from apex to base is cut into basal, mid and apical thirds (Cerqueira 2002), the apical third
// losing a cap of height L/12 to segment 17; rings split 6 x 60 deg (basal, mid) and 4 x 90 deg
// (apical). Result: basal 0.0615 each, mid 0.0589, apical 0.0550, apex 0.0573 (basal 37 %, mid
// 35 %, apical + apex 28 %, near Cerqueira's 35/35/30 % mass split). Sums to 1.
std::vector<double> aha17_area_shares();

// Activation times [s] of the 17 segments for a pattern (kSynchronous, kLbbb, kPacing).
//  kLbbb: a simplified septal-to-lateral sequence (docs/models.md s.3): the wave starts at a septal
//    breakthrough (mid septum, between segments 8 and 9, after right-to-left transseptal
//    conduction) and spreads along the wall; T_d = lbbb_duration (path - shortest) / (longest -
//    shortest), so the mid septum is first (0) and the basal (infero)lateral wall last,
//    lbbb_duration later (docs/models.md s.7: total LV activation >= 130-150 ms with LBBB).
//  kPacing: T_d = path from the paced segment's centre / conduction_velocity.
// Path lengths on the ellipsoid above: meridian arc between the two ring heights combined with the
// circumferential arc at the mean ring radius, sqrt(ds_meridian^2 + (r_mean dphi)^2).
std::vector<double> aha17_activation_times(const RegionalOptions& options);

class RegionalVentricle final : public SteppableSimulator {
 public:
  explicit RegionalVentricle(RegionalOptions options = {});
  RegionalVentricle(RegionalOptions options, ParameterSpace parameters);

  // The sphere's parameters except sigma0 (n0_slope, n0_e_max at the regional defaults above),
  // K_patch [Pa] (1e4), then per patch XX = 01..N:
  //   sigma0_XX [Pa] (60 kPa), Td_XX [s] (from the activation pattern),
  //   stiff_XX [1] (passive stiffness scale, 1), scar_XX [1] (non-contractile fraction, 0).
  static ParameterSpace default_parameters(const RegionalOptions& options = {});

  std::string name() const override { return "lumped-regional"; }
  const ParameterSpace& parameters() const override { return parameters_; }
  ParameterSpace& mutable_parameters() { return parameters_; }
  const RegionalOptions& options() const { return options_; }
  int patches() const { return n_; }
  // A copy with another time step (the ROUKF's refine hook halves it on a failed member).
  std::unique_ptr<RegionalVentricle> with_time_step(double dt) const;
  std::unique_ptr<SteppableSimulator> with_time_step_factor(double factor) const override {
    return with_time_step(options_.numerics.dt * factor);
  }

  // V_lv, P_lv, P_ar, P_at, q_ar, q_at, phase (as the sphere), P_d, then V_seg01..V_segN [m^3].
  std::vector<Channel> channels() const override;
  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<Simulator> clone() const override;
  // The sphere's warm starts (docs/models.md s.2.1): the periodic state of the 4N + 4 unknowns
  // (72 with 17 patches) with the beat map's Jacobian, 2n + n^2 entries.
  int warm_start_size() const override;
  RunResult run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta, const Eigen::VectorXd& from,
                     Eigen::VectorXd* produce) override;

  // y, dy_dt, P_v, P_ar, P_d, c_01..c_(N-1), (e_c, k_c, tau_c) per patch, last_open_valve.
  std::vector<Channel> state_layout() const override;
  SIGMAHEART_STEPPING_OVERRIDES;

 private:
  // Backward-Euler steps up to t_end with step cutting, and the checks of run() and advance().
  Status step_to(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end,
                 int* newton_iterations, int* step_cuts) const;
  Status check_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const;

  RegionalOptions options_;
  ParameterSpace parameters_;
  int n_ = 1;                     // patches
  std::vector<double> shares_;    // w_p
  std::vector<int> global_;       // positions of the global parameters (sphere order, no sigma0)
  std::vector<int> sigma0_, td_, stiff_, scar_;  // positions of the per-patch parameters
};

}  // namespace sigmaheart::model::lumped
