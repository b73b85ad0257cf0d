// The contract between estimators and simulators (docs/architecture.md, "The contract").
//
// A simulator is a black box: a full parameter vector theta (physical units, SI, in the order of
// parameters()) goes in; a Trajectory of named channels with units comes out, together with a
// Status. Estimators never see simulator internals, only these types.
//
// Thread safety: a Simulator object is used by one thread at a time. Parallel ensembles give each
// thread (or MPI rank) its own clone(); clones share nothing mutable.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <iosfwd>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::model {

// ---------------------------------------------------------------------------------------------
// Status: a forward run that fails is a value, never an exception or a crash.
enum class StatusCode {
  kOk = 0,
  kDiverged,         // Newton did not converge, even after the step was cut
  kNonFinite,        // NaN or Inf in the state
  kOutOfBounds,      // theta outside the parameter bounds
  kNotPeriodic,      // the beat did not settle within the allowed number of beats
  kProcessFailed,    // external simulator: non-zero exit
  kTimeout,          // external simulator: killed after its time limit
  kBadOutput,        // external simulator: output missing or unreadable
  kInvalidArgument,  // wrong sizes or options: a programming or configuration error
  kCancelled,        // not run: the run was interrupted (SIGINT/SIGTERM) before this member
};

const char* to_string(StatusCode code);

struct Status {
  StatusCode code = StatusCode::kOk;
  std::string message;  // human-readable, names the quantity and time where it went wrong

  bool ok() const { return code == StatusCode::kOk; }
  static Status Ok() { return {}; }
  static Status Error(StatusCode c, std::string msg) { return {c, std::move(msg)}; }
};

// ---------------------------------------------------------------------------------------------
// Parameters: names, units (SI), nominal values, bounds, a one-line doc; lookup by name.
struct Parameter {
  std::string name;   // e.g. "sigma0"
  std::string unit;   // SI unit string, e.g. "Pa", "1/s", "m^3/(Pa s)"
  double nominal = 0.0;
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  std::string doc;    // one line: what it is and where the default comes from
  // Structure as data: estimators find parameters by tags, never by name patterns or casts.
  // family names what the parameter is, shared by its regional copies ("contractility",
  // "activation_time", "afterload_resistance", ...; the vocabulary is in model/registry.h);
  // segment is the AHA segment or patch (1-based) of a regional parameter, 0 for a global one.
  std::string family;
  int segment = 0;
  // Physiological range (SI; docs/models.md s.8): where a value still describes a human heart,
  // healthy or diseased, with its source. Narrower than [lower, upper], which only keep runs
  // physical. NaN: no range stated. Calibrations report whether an estimate left it.
  double range_lower = std::numeric_limits<double>::quiet_NaN();
  double range_upper = std::numeric_limits<double>::quiet_NaN();
  std::string range_source;
  bool regional() const { return segment > 0; }
  bool has_range() const { return range_lower == range_lower && range_upper == range_upper; }
};

class ParameterSpace {
 public:
  ParameterSpace() = default;
  explicit ParameterSpace(std::vector<Parameter> params);

  int size() const { return static_cast<int>(params_.size()); }
  const Parameter& operator[](int i) const { return params_.at(static_cast<size_t>(i)); }
  const std::vector<Parameter>& all() const { return params_; }
  std::vector<std::string> names() const;

  std::optional<int> index(const std::string& name) const;
  int index_or_throw(const std::string& name) const;  // std::invalid_argument with a did-you-mean

  Eigen::VectorXd nominal() const;
  // Replace a nominal value (presets and --set do this). Throws std::invalid_argument when the
  // name is unknown or the value lies outside the bounds.
  void set_nominal(const std::string& name, double value);

  // Empty string when theta has the right size, is finite and lies inside the bounds; otherwise a
  // message naming the first offending parameter, its value, unit and bounds.
  std::string check(const Eigen::Ref<const Eigen::VectorXd>& theta) const;

  // Index of the parameter tagged (family, segment); nullopt when there is none.
  std::optional<int> find(const std::string& family, int segment = 0) const;
  // Indices of the regional parameters of a family (segment > 0), in increasing segment order.
  std::vector<int> regional(const std::string& family) const;

 private:
  std::vector<Parameter> params_;
};

// ---------------------------------------------------------------------------------------------
// Trajectory: sample times [s] and named channels with units. values(k, c) is channel c at
// times(k). Channels are SI unless their unit says otherwise (e.g. "1" for dimensionless).
struct Channel {
  std::string name;  // e.g. "V_lv", "P_lv", "V_seg07", "phase"
  std::string unit;  // e.g. "m^3", "Pa", "m^3/s", "1"
  std::string doc;
  // Tags as on Parameter: family ("regional_volume", ...) and the 1-based segment (0: global).
  std::string family;
  int segment = 0;
};

struct Trajectory {
  Eigen::VectorXd times;            // [s], strictly increasing
  std::vector<Channel> channels;
  Eigen::MatrixXd values;           // samples x channels

  int samples() const { return static_cast<int>(times.size()); }
  std::optional<int> channel_index(const std::string& name) const;
  // The column of a channel; throws std::invalid_argument naming the missing channel.
  Eigen::VectorXd channel(const std::string& name) const;
  bool has_channel(const std::string& name) const { return channel_index(name).has_value(); }
};

// Beat-level facts a simulator may report beside its curves (lumped and 3D models do).
struct RunInfo {
  int beats = 0;                    // beats integrated in total
  double periodicity_change = 0.0;  // last correction of the periodic start state, scaled [-]
  double period = 0.0;              // [s]
  int newton_iterations = 0;        // total over the run
  int step_cuts = 0;                // how often the time step was halved to recover
  int factorizations = 0;           // of a Newton tangent, total over the run (0: not counted)
  long long linear_iterations = 0;  // of an iterative linear solver, total over the run (0: none)
};

struct RunResult {
  Trajectory trajectory;  // for a periodic model: the last (periodic) beat, t in [0, period]
  Status status;
  RunInfo info;
};

// ---------------------------------------------------------------------------------------------
// Capabilities beyond run(): a simulator answers each query with an interface, or nullptr when it
// has no such capability. Commands and estimators ask, never cast to a concrete model:
//   steppable()  the state can be stopped, saved, edited and resumed (the ROUKF needs it);
//   fields()     the state has spatial fields (`simulate --vtu` writes them for any model);
//   pacing()     the activation sequence can be set from pacing leads (model/activation/pacing.h;
//                models without it may still be paced through their per-segment activation times);
//   regional channels are tagged (Channel::family "regional_volume", segment 1..N).
struct State;
class SteppableSimulator;
class FieldOutput;
namespace activation {
class Pacing;
}

class Simulator {
 public:
  virtual ~Simulator() = default;

  virtual std::string name() const = 0;                 // e.g. "lumped-sphere"
  virtual const ParameterSpace& parameters() const = 0;
  virtual std::vector<Channel> channels() const = 0;

  // Runs the model for the full parameter vector theta (size parameters().size(), physical
  // units). Never throws for a numerical failure: returns a non-ok Status (trajectory may then be
  // partial or empty). Deterministic: the same theta gives the same bits.
  virtual RunResult run(const Eigen::Ref<const Eigen::VectorXd>& theta) = 0;

  // An independent copy with the same configuration; used for one thread or rank each.
  virtual std::unique_ptr<Simulator> clone() const = 0;

  // Warm starts (docs/models.md s.2.1, "Warm starts"): a model that finds a periodic state can hand
  // what it found on to a run at nearby parameters. warm_start_size() entries, opaque to the
  // estimators; 0 (the default): the model takes none and run_warm() is run().
  virtual int warm_start_size() const { return 0; }
  // run() starting from `from`, the warm start of an earlier run of this model (empty, all zero or
  // of the wrong size: from rest as run()), and, when `produce` is not null, writing this run's own
  // warm start there (warm_start_size() entries, all zero when it has none, e.g. a failed run).
  // Deterministic in (theta, from); the returned beat equals run()'s to within the model's
  // periodic tolerance.
  virtual RunResult run_warm(const Eigen::Ref<const Eigen::VectorXd>& theta,
                             const Eigen::VectorXd& from, Eigen::VectorXd* produce);

  // Capability queries (above); the interfaces live as long as this simulator.
  virtual SteppableSimulator* steppable() { return nullptr; }
  virtual FieldOutput* fields() { return nullptr; }
  virtual activation::Pacing* pacing() { return nullptr; }
};

// A simulator whose state can be stopped, saved, edited and resumed: what the ROUKF needs.
// The state is a flat vector (positions, velocities, active variables, circulation pressures) plus
// its time; advance() is a pure function of (state, theta, t_end).
struct State {
  double time = 0.0;  // [s]
  Eigen::VectorXd x;
};

class SteppableSimulator : public Simulator {
 public:
  // Names (and units) of the entries of State::x, for logs and results.
  virtual std::vector<Channel> state_layout() const = 0;

  virtual State initial_state(const Eigen::Ref<const Eigen::VectorXd>& theta) = 0;

  // Integrates from state.time to t_end (>= state.time) with the simulator's own time step,
  // landing exactly on t_end. On failure the state is left at the last good time.
  virtual Status advance(State& state, const Eigen::Ref<const Eigen::VectorXd>& theta,
                         double t_end) = 0;

  // The channel values (in the order of channels()) at the given state.
  virtual Eigen::VectorXd sample(const State& state,
                                 const Eigen::Ref<const Eigen::VectorXd>& theta) const = 0;

  // A copy whose time step is this one's times `factor` (the ROUKF retries a failed member with
  // factor 2^-level); nullptr when the simulator has no such control.
  virtual std::unique_ptr<SteppableSimulator> with_time_step_factor(double factor) const {
    (void)factor;
    return nullptr;
  }

  SteppableSimulator* steppable() final { return this; }
};

// Declares, in the class body of a SteppableSimulator, the three members it implements out of line:
// initial_state, advance and sample (state_layout and with_time_step_factor stay the model's).
#define SIGMAHEART_STEPPING_OVERRIDES                                                              \
  ::sigmaheart::model::State initial_state(const ::Eigen::Ref<const ::Eigen::VectorXd>& theta) override; \
  ::sigmaheart::model::Status advance(::sigmaheart::model::State& state,                           \
                                      const ::Eigen::Ref<const ::Eigen::VectorXd>& theta, double t_end) override; \
  ::Eigen::VectorXd sample(const ::sigmaheart::model::State& state,                                \
                           const ::Eigen::Ref<const ::Eigen::VectorXd>& theta) const override

// The simulator as a SteppableSimulator when it is one (ownership passes), else nullptr and the
// simulator is destroyed.
std::unique_ptr<SteppableSimulator> into_steppable(std::unique_ptr<Simulator> simulator);

// Spatial fields of a model's state (3D models): observed at every output step of run(), written
// as one VTK XML UnstructuredGrid document per state.
class FieldOutput {
 public:
  virtual ~FieldOutput() = default;

  // Called during run() at t = 0 of every beat and after every kept output step (the rows of the
  // returned trajectory) with the beat (from 1), the time in that beat [s] and the state; an empty
  // function removes the observer. Clones do not inherit it.
  using StepObserver = std::function<void(int beat, double t_in_beat, const State& state)>;
  virtual void observe_steps(StepObserver observer) = 0;

  // Writes the fields of `state` (layout of the model's state) as one binary VTU document.
  // Throws std::invalid_argument when the state does not belong to this model.
  virtual void write_fields(const State& state, std::ostream& os) = 0;
};

// Closest candidate by edit distance, for "did you mean" messages; empty if none is close.
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace sigmaheart::model
