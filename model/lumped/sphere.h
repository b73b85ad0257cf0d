// The lumped (0D) BCS ventricle: a thin spherical shell (Caruel et al. 2014, Biomech Model
// Mechanobiol 13:897) coupled to valves and a two-stage Windkessel. docs/models.md sections 1-2.
#pragma once

#include "model/bcs/active_law.h"
#include "model/simulator.h"

#include <string>
#include <vector>

namespace sigmaheart::model::lumped {

// Numerics of a lumped run (not estimated; set in the config's `numerics:` section).
struct SphereOptions {
  // Limits validate() enforces. kMaxBeats bounds the run time and keeps t = beats * period small
  // enough for the time grid's rounding margins; periodicity is measured on states solved to
  // newton_tolerance, and the beat-to-beat change of the healthy beat stalls near 2e-14, so a
  // periodic_tolerance below kMinPeriodicTolerance would only spend max_beats; kMinDt bounds the
  // samples kept per beat. Checked with the period (check_theta): dt <= period / kMinStepsPerBeat.
  static constexpr int kMaxBeats = 10000;
  static constexpr double kMinPeriodicTolerance = 1e-12;
  static constexpr double kMinDt = 1e-5;  // [s]
  static constexpr int kMinStepsPerBeat = 20;

  double dt = 1e-3;                  // time step [s]
  // The periodic beat is found by Newton-Krylov shooting (model/periodic_shooting.h).
  int min_beats = 3;                 // plain beats before the first Newton step
  int max_beats = 400;               // beats of every kind before giving up (kNotPeriodic)
  double periodic_tolerance = 1e-6;  // last Newton correction of the beat-start state, relative
                                     // to each entry's peak over the beat [-]
  int output_every = 1;              // keep every k-th step in the returned trajectory
  double newton_tolerance = 1e-10;   // relative residual tolerance of the per-step Newton solve
  int newton_max_iterations = 25;
  // Shape of the activation input u(t) (`activation_shape:`; docs/models.md s.1): square by default,
  // or the ramped u(t) of Caruel et al. 2014. The regional model does not read it yet.
  bcs::ActivationInput activation_input;
  // Empty when valid, else a message naming the field and the expected range.
  std::string validate() const;
};

// Backward Euler (first order) on (y, y', P_v, P_ar, P_d, e_c, k_c, tau_c), one small Newton solve
// per step (sphere.cpp). run() finds the periodic beat from a relaxed state by shooting (Newton on
// the beat map, model/periodic_shooting.h) and returns it on t in [0, period]. Channels (SI):
// V_lv, P_lv, P_ar, P_at, q_ar, q_at, phase (0 filling, 1 isovolumic contraction, 2 ejection,
// 3 isovolumic relaxation), P_d, e_fibre, e_c, k_c, tau_c, sigma_act, viscous_power.
// The state is the eight unknowns plus last_open_valve (state_layout()); t = 0 of every beat is
// the ventricular depolarisation, the atrial kick fills the last 0.12 s of the beat.
//
// Atrium::kChamber ("lumped-sphere-atrium"): the prescribed atrial pressure is replaced by an
// atrial chamber (circulation::AtrialChamber; parameters E_at_min, E_at_max, V_at0, P_pv, R_pv
// instead of P_at0, P_at_kick), and the state gains the atrial volume V_at before last_open_valve.
class LumpedSphere final : public SteppableSimulator {
 public:
  enum class Atrium { kPrescribed, kChamber };
  explicit LumpedSphere(SphereOptions options = {});
  LumpedSphere(SphereOptions options, ParameterSpace parameters,
               Atrium atrium = Atrium::kPrescribed);

  // The parameters with their healthy-preset nominal values, SI units, bounds and sources.
  static ParameterSpace default_parameters(Atrium atrium = Atrium::kPrescribed);  // ranges set

  std::string name() const override {
    return atrium_ == Atrium::kChamber ? "lumped-sphere-atrium" : "lumped-sphere";
  }
  Atrium atrium() const { return atrium_; }
  const ParameterSpace& parameters() const override { return parameters_; }
  ParameterSpace& mutable_parameters() { return parameters_; }
  const SphereOptions& options() const { return options_; }
  std::vector<Channel> channels() const override;
  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<Simulator> clone() const override;
  // The periodic state of the eight unknowns with the beat map's Jacobian (docs/models.md s.2.1).
  int warm_start_size() const override;
  RunResult run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta, const Eigen::VectorXd& from,
                     Eigen::VectorXd* produce) override;

  std::vector<Channel> state_layout() const override;
  SIGMAHEART_STEPPING_OVERRIDES;

 private:
  // Size, bounds and option checks shared by run() and advance().
  Status check_theta(const Eigen::Ref<const Eigen::VectorXd>& theta) const;
  // Backward-Euler steps on the beat-local grid up to t_end (see sphere.cpp), with step cutting.
  Status step_to(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end,
                 int* newton_iterations, int* step_cuts) const;

  int unknowns() const;  // 8, or 9 with the atrial chamber

  SphereOptions options_;
  ParameterSpace parameters_;
  Atrium atrium_ = Atrium::kPrescribed;
  std::vector<int> index_;  // position in parameters_ of each model parameter (by name)
  std::vector<int> atrium_index_;  // of shell::atrium_names() (atrial chamber only)
};

// Sets Parameter::range_* (physiological ranges with their sources, docs/models.md s.8.1) of the
// lumped sphere's parameters found in p by name; the regional ventricle's globals reuse it.
void set_physiological_ranges(std::vector<Parameter>& p);

}  // namespace sigmaheart::model::lumped
