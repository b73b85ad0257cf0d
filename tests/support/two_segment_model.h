// A test-only model registered from tests/: a two-segment time-varying-elastance ventricle, cheap
// (two ODEs, RK4) and deterministic, with the tags the estimators look for. It shows that a model
// is one registration away from every command (tests/app/registry_commands_test.cpp), and that
// the simulator contract runs on it unchanged.
//
// Two wall segments p = 1, 2 share the cavity pressure P_lv; segment p has the elastance
//   E_p(t) = E_min + kappa sigma0_p e(t),  e(t) = sin^2(pi tau / T_s) for tau = t mod T < T_s, else 0
// (T: the parameter `period`)
// (Suga-Sagawa time-varying elastance, Suga et al. 1973 Circ Res 32:314), so its volume is
// V_seg,p = V0 + P_lv / E_p and P_lv = (V_lv - 2 V0) / (1/E_1 + 1/E_2). Diode valves and a
// two-element Windkessel close the loop:
//   dV_lv/dt = q_in - q_out,  q_in = max(P_ven - P_lv, 0) / R_mv,  q_out = max(P_lv - P_ar, 0) / R_ao
//   C_ar dP_ar/dt = q_out - P_ar / R_d
// Constants: T_s = 0.3 s, kappa = 2e4 1/m^3, V0 = 10 mL, R_mv = 1.33e6 Pa s/m^3,
// R_ao = 2.67e6 Pa s/m^3, C_ar = 1.125e-8 m^3/Pa. Defaults give EDV ~ 120 mL, EF ~ 0.55.
#pragma once

#include "model/registry.h"
#include "model/simulator.h"

namespace sigmaheart::testing {

struct TwoSegmentOptions {
  double dt = 1e-3;                  // RK4 step [s]
  int output_every = 5;              // keep every k-th step of the returned beat
  int max_beats = 80;                // kNotPeriodic after this many
  double periodic_tolerance = 1e-7;  // relative change of (V_lv, P_ar) over one beat
};

class TwoSegmentModel final : public model::SteppableSimulator {
 public:
  TwoSegmentModel(TwoSegmentOptions options, model::ParameterSpace parameters)
      : options_(options), parameters_(std::move(parameters)) {}

  // sigma0_01, sigma0_02 [Pa] (contractility, segments 1 and 2), E_min [Pa/m^3] (elastance),
  // R_d [Pa s/m^3] (afterload_resistance), P_ven [Pa] (preload_pressure), period [s] (period).
  static model::ParameterSpace default_parameters();

  std::string name() const override { return "test-two-segment"; }
  const model::ParameterSpace& parameters() const override { return parameters_; }
  // V_lv [m^3], P_lv [Pa], P_ar [Pa], V_seg01, V_seg02 [m^3] (regional_volume, segments 1, 2).
  std::vector<model::Channel> channels() const override;
  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<model::Simulator> clone() const override {
    return std::make_unique<TwoSegmentModel>(*this);
  }

  // V_lv [m^3], P_ar [Pa].
  std::vector<model::Channel> state_layout() const override;
  SIGMAHEART_STEPPING_OVERRIDES;

 private:
  model::Status check(const Eigen::Ref<const Eigen::VectorXd>& theta) const;

  TwoSegmentOptions options_;
  model::ParameterSpace parameters_;
};

// Adds "test-two-segment" (numerics: {dt: <= 2 ms, output_every: >= 1}).
void register_two_segment_model(model::ModelRegistry& registry);

}  // namespace sigmaheart::testing
