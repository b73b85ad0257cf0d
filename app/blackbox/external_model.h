// `model: external`: a simulator that is a program (docs/architecture.md s.9). Every run() writes
// the parameter vector to a file in a fresh member directory, runs the configured command there
// (no shell; command_template.h), enforces the time limit and reads the program's output CSV
// (`name [unit]` headers, app/io/observation_file.h) or HDF5 file (/time and /<channel> datasets
// with `units` attributes) back into a Trajectory in SI.
//
//   simulator:
//     model: external
//     numerics:
//       command: "./model.py --params {params} --out {output}"
//       workdir: runs/             # member directories are created below it
//       parameter_format: json     # or yaml
//       output: curves.csv         # the file the program writes in {dir} (.csv or .h5)
//       timeout: 30 s
//       period: 0.8 s              # optional: RunInfo::period
//       keep_workdirs: false       # true: keep every member directory, not only failed ones
//       parameters: [...]          # tables.h
//       channels: [...]
//
// With `steppable: true` the program is driven step by step instead (the ROUKF needs it):
//
//       steppable: true
//       step_command: "./model.py --params {params} --in {state_in} --out {state_out} --to {t_end}"
//       state: [{name: V, unit: m^3}, {name: P_c, unit: Pa}]   # the state vector's layout
//       period: 0.8 s              # required: run() samples one beat at `frames` times
//       frames: 41
//
// The program reads the state file {state_in}, integrates from its time to {t_end} (equal: no
// integration) and writes {state_out}. Both are CSV with a `name [unit]` header and one row:
// `time [s]`, then the state entries in the order of `state:`; {state_out} continues with the
// channels at t_end in the order of `channels:`. A {state_in} with the header but no row means
// "start from your own initial state at t = 0". initial_state() is such a call with t_end = 0,
// advance() one call, sample() one call with t_end equal to the state's time (so a state the
// filter edited is sampled by the program itself), run() one initial call and `frames` - 1
// advances with a sample each. A failed sample() gives NaN channels (the ensemble turns them into
// a failed member).
//
// Failures are Statuses (never exceptions out of run()): kOutOfBounds (theta outside the
// table's bounds), kProcessFailed (could not start, non-zero exit, killed by a signal),
// kTimeout (killed after `timeout`), kBadOutput (no output file, unreadable or non-finite
// values, a declared channel missing or in the wrong unit). Their messages name the member
// directory, which is kept, and end with the last lines of the program's stderr.
#pragma once

#include "app/blackbox/command_template.h"
#include "app/blackbox/tables.h"
#include "model/registry.h"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app::blackbox {

enum class ParameterFormat { kJson, kYaml };

struct ExternalOptions {
  CommandTemplate command;            // parsed template
  std::string executable;             // the program word resolved (absolute path)
  std::filesystem::path workdir;      // absolute; member directories go below it
  ParameterFormat parameter_format = ParameterFormat::kJson;
  std::string output = "curves.csv";  // file name inside the member directory
  double timeout = 60.0;              // [s]
  PeriodSource period;                // fixed, a parameter, or none (the output's time span)
  bool keep_workdirs = false;
  std::vector<model::Channel> channels;
  std::vector<DeclaredUnit> parameter_units;  // per parameter: the unit the program reads
  std::vector<DeclaredUnit> channel_units;    // per channel: the default unit of an HDF5 dataset
  // The steppable protocol (steppable: true).
  bool steppable = false;
  CommandTemplate step_command;
  std::string step_executable;
  std::vector<model::Channel> state;  // layout of State::x (SI units)
  int frames = 41;                    // samples of run()
};

// What the one-shot and the steppable external simulators share (Contract: model::Simulator or
// model::SteppableSimulator; Derived: the simulator itself): the options, the declared parameter
// table, a clone id unique in this process (member directories carry it), and the name,
// parameters, channels and clone() of the contract.
template <class Derived, class Contract>
class ExternalBase : public Contract {
 public:
  std::string name() const override { return "external"; }
  const model::ParameterSpace& parameters() const override { return parameters_; }
  std::vector<model::Channel> channels() const override { return options_->channels; }
  std::unique_ptr<model::Simulator> clone() const override {
    return std::make_unique<Derived>(options_, parameters_);
  }

 protected:
  ExternalBase(std::shared_ptr<const ExternalOptions> options, model::ParameterSpace parameters, int clone_id)
      : options_(std::move(options)), parameters_(std::move(parameters)), clone_id_(clone_id) {}

  std::shared_ptr<const ExternalOptions> options_;
  model::ParameterSpace parameters_;
  int clone_id_;
};

class ExternalSimulator final : public ExternalBase<ExternalSimulator, model::Simulator> {
 public:
  ExternalSimulator(std::shared_ptr<const ExternalOptions> options, model::ParameterSpace parameters);

  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;

 private:
  long counter_ = 0;  // runs of this clone
};

// The same program driven step by step (the steppable protocol above).
class ExternalSteppableSimulator final : public ExternalBase<ExternalSteppableSimulator, model::SteppableSimulator> {
 public:
  ExternalSteppableSimulator(std::shared_ptr<const ExternalOptions> options, model::ParameterSpace parameters);

  model::RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) override;
  std::vector<model::Channel> state_layout() const override { return options_->state; }
  // Throws std::runtime_error when the program fails (the contract has no Status here).
  SIGMAHEART_STEPPING_OVERRIDES;

 private:
  // One program call from `in` (nullptr: the initial state) to t_end; fills out_state and
  // out_channels.
  model::Status step(const model::State* in, const Eigen::Ref<const Eigen::VectorXd>& theta, double t_end,
                     model::State& out_state, Eigen::VectorXd& out_channels) const;

  mutable long counter_ = 0;  // program calls of this clone
};

// The `numerics:` of `model: external`, checked before any work: every error goes through the
// reader (file:line:column). The program must exist and be executable now.
model::ModelBuild configure_external(const model::OptionReader& numerics);

// The parameter file of one run: names, values (shortest round-trip text) and units, each value
// in its declared unit (theta_i / factor_i; `declared` empty: SI, as in the ParameterSpace).
std::string parameter_file_text(const model::ParameterSpace& parameters,
                                const Eigen::Ref<const Eigen::VectorXd>& theta, ParameterFormat format,
                                const std::vector<DeclaredUnit>& declared = {});

}  // namespace sigmaheart::app::blackbox
