// The lumped (0D) BCS ventricle: a thin spherical shell (Caruel et al. 2014, Biomech Model
// Mechanobiol 13:897) coupled to valves and a two-stage Windkessel. MODELS.md sections 1-2.
#pragma once

#include "model/simulator.h"

#include <string>

namespace sigmaheart::model::lumped {

// Numerics of a lumped run (not estimated; set in the config's `numerics:` section).
struct SphereOptions {
  double dt = 1e-3;                  // time step [s]
  int min_beats = 3;                 // beats always integrated before testing periodicity
  int max_beats = 40;                // give up (kNotPeriodic) after this many beats
  double periodic_tolerance = 1e-3;  // max relative beat-to-beat change of V, P at beat start [-]
  int output_every = 1;              // keep every k-th step in the returned trajectory
  double newton_tolerance = 1e-10;   // relative residual tolerance of the per-step Newton solve
  int newton_max_iterations = 25;
  // Empty when valid, else a message naming the field and the expected range.
  std::string validate() const;
};

class LumpedSphere final : public SteppableSimulator {
 public:
  explicit LumpedSphere(SphereOptions options = {});
  LumpedSphere(SphereOptions options, ParameterSpace parameters);

  // The parameters with their healthy-preset nominal values, SI units, bounds and sources.
  static ParameterSpace default_parameters();

  std::string name() const override { return "lumped-sphere"; }
  const ParameterSpace& parameters() const override { return parameters_; }
  ParameterSpace& mutable_parameters() { return parameters_; }
  const SphereOptions& options() const { return options_; }
  std::vector<Channel> channels() const override;
  RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::unique_ptr<Simulator> clone() const override;

  std::vector<Channel> state_layout() const override;
  State initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  Status advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                 double t_end) override;
  Eigen::VectorXd sample(const State& state,
                         const Eigen::Ref<const Eigen::VectorXd>& theta) const override;

 private:
  SphereOptions options_;
  ParameterSpace parameters_;
};

}  // namespace sigmaheart::model::lumped
