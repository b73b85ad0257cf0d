// Regional volumes measured as the data measure them: the regional_volume channels of a model
// re-weighted by per-segment cavity-volume shares (docs/models.md s.3.3, "Volume shares").
//
// A lumped segment's volume is the cone share V w_p c_p of the cavity (w_p its wall-area share,
// c_p its current area relative to that share, docs/models.md s.3.1). A real or 3D ventricle's
// segment holds another share of the cavity than of the wall: by the long-axis definition of
// docs/models.md s.5 the basal ring of the lv-3d ellipsoid holds 7.7 % of the cavity per segment
// at end-diastole, the apical ring 3.6 % and the apical cap nothing, against wall-area shares of
// 6.2, 5.5 and 5.7 %. Fitted with the wall shares, the estimator bends contractility from base to
// apex to make up the sizes (experiments/3d-twin/README.md). This wrapper keeps the mechanics of
// the inner model (its area shares, tensions and pressure) and changes only what it reports:
//
//   V'_p = V omega_p r_p / sum_q omega_q r_q,   r_p = (V_p / V) / s_p,   V = sum_q V_q
//
// with s_p the inner model's reference share (its regional volume fraction in the state
// initial_state(theta), where every lumped patch has c_p = 1, so r_p = c_p) and omega_p >= 0 the
// volume shares (sum 1). The regional volumes still sum to V; with omega = s nothing changes (to
// rounding); a segment with omega_p = 0 reports no volume. Every other channel, the state and the
// time stepping are the inner model's.
//
// Shares over the beat (17 AHA segments only, `level_exponents`): a real ventricle's segments do
// not keep their share as it empties. In the 3D ellipsoid with healthy activation the apical
// segments' share falls to about half at end-systole and the basal ones' rises by a third (wall
// thickening narrows the apex; docs/models.md s.3.5). The share law
//   omega_p(V) = omega_p (V / V_ref)^b_l,   l = the AHA level of p (basal 1-6, mid 7-12, apical 13-17)
// with one exponent per level, appended to the parameters as vshare_basal, vshare_mid,
// vshare_apical (unit 1, family geometry, nominal 0: the shares of V_ref) with vshare_gamma (below),
// lets an estimator take
// the levels' emptying from the data; V_ref is the cavity volume at which omega holds (the data's
// end-diastolic volume). A whole ring moves together, so a local infarct stays the segments'.
// With them comes vshare_gamma (nominal 1): the share follows r_p^gamma. A lumped patch's cavity
// share is its area share (a cone from the centre); a segment of a real ventricle that bulges
// outward at a fixed height gains volume as the square of its distance from the long axis but area
// only linearly (docs/models.md s.5: V_z = 1/2 int (x - c)_perp . n_perp), so its volume share moves
// up to twice as much as its area share (gamma 2; 1.5 for the sphere as a whole).
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <memory>
#include <vector>

namespace sigmaheart::model {

class RegionalVolumeShares final : public SteppableSimulator {
 public:
  // shares and reference: one entry per regional_volume channel of inner, in segment order;
  // shares >= 0 summing to 1 (to 1e-9), reference > 0. reference_volume > 0 [m^3]: V_ref of the
  // share law, which level_exponents (17 regional channels only) adds. Throws
  // std::invalid_argument otherwise, or when inner has no regional_volume channel.
  RegionalVolumeShares(std::unique_ptr<SteppableSimulator> inner, Eigen::VectorXd shares,
                       Eigen::VectorXd reference, double reference_volume = 0.0, bool level_exponents = false);

  // The inner model's regional volume fractions V_p / V in initial_state(theta): its reference
  // shares s_p. Throws std::invalid_argument when the model has no regional_volume channel or the
  // fractions are not positive and finite.
  static Eigen::VectorXd reference_shares(SteppableSimulator& inner,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta);
  // The parameters of a wrapper around a model with `inner` parameters: inner's, then with
  // level_exponents vshare_basal, vshare_mid, vshare_apical, vshare_gamma. Throws
  // std::invalid_argument when a name is taken.
  static ParameterSpace shares_space(const ParameterSpace& inner, bool level_exponents);
  // Positions of the regional_volume channels in channels(), in segment order.
  static std::vector<int> regional_channels(const std::vector<Channel>& channels);

  const Eigen::VectorXd& shares() const { return shares_; }

  std::string name() const override { return inner_->name(); }
  const ParameterSpace& parameters() const override { return space_; }
  std::vector<Channel> channels() const override;
  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<Simulator> clone() const override;

  std::vector<Channel> state_layout() const override { return inner_->state_layout(); }
  State initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) override {
    return inner_->initial_state(inner_theta(theta));
  }
  Status advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end) override {
    return inner_->advance(state, inner_theta(theta), t_end);
  }
  Eigen::VectorXd sample(const State& state, const Eigen::Ref<const Eigen::VectorXd>& theta) const override;
  std::unique_ptr<SteppableSimulator> with_time_step_factor(double factor) const override;

 private:
  // The inner model's parameters: theta without the appended exponents (a theta of another size
  // is passed on for the inner model to refuse).
  Eigen::VectorXd inner_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const;
  // Re-weights the regional entries of one row of channel values in place.
  void reweight(Eigen::Ref<Eigen::VectorXd> values, const Eigen::Ref<const Eigen::VectorXd>& theta) const;

  std::unique_ptr<SteppableSimulator> inner_;
  Eigen::VectorXd shares_, reference_;
  double reference_volume_ = 0.0;
  bool level_exponents_ = false;
  ParameterSpace space_;
  std::vector<int> regional_;  // positions of the regional_volume channels
};

}  // namespace sigmaheart::model
