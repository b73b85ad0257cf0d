// The models a config can name in `simulator.model:`, as data: a ModelRegistry maps a name to a
// ModelSetup, which turns the model's `numerics:` section into a ModelBuild (the parameter table
// for those numerics and a factory of simulators). Adding a model is one folder with its own
// register_<family>_models(ModelRegistry&) and one line in builtin_models() (registry.cpp); tests
// add stand-ins to a copy of the built-in registry and hand it to the commands (app/cli.h).
//
// model/ knows no file format: a model reads its options through OptionReader, which app/
// implements over its YAML config nodes so that every error names file:line:column.
//
// Parameter and channel tags (Parameter::family, Channel::family; ParameterSpace::find and
// regional) are one vocabulary shared by every model, so estimators find parameters by role:
//
//   family                 unit        what
//   contractility          Pa          maximal active stress sigma0 (per segment: sigma0_XX)
//   activation_time        s           depolarisation time of a segment (Td_XX)
//   stiffness_scale        1           passive stiffness multiplier of a segment (stiff_XX)
//   scar_fraction          1           non-contractile fraction of a segment (scar_XX)
//   activation_rate        1/s         rate of contraction onset (k_ATP)
//   relaxation_rate        1/s         rate of relaxation (k_RS)
//   activation_duration    s           action-potential duration (APD)
//   active_stiffness       Pa          active and series-element stiffness (k0, Es)
//   active_viscosity       Pa s        contractile-element viscosity (mu)
//   crossbridge_kinetics   1           cross-bridge destruction and length dependence (alpha, n0_*)
//   passive_stiffness      Pa or 1     passive law coefficients (c1, c2, c_exp, b_exp, K_patch)
//   passive_viscosity      Pa s        passive wall viscosity (eta)
//   geometry               m           reference radius and wall thickness (R0, d0)
//   wall_density           kg/m^3      wall mass per volume (rho)
//   period                 s           heart period
//   valve_conductance      m^3/(Pa s)  valve and leak conductances (K_at, K_ar, K_p)
//   afterload_resistance   Pa s/m^3    arterial resistances (R_p, R_d)
//   afterload_compliance   m^3/Pa      arterial compliances (C_p, C_d)
//   venous_pressure        Pa          pressure downstream of the periphery (P_sv)
//   preload_pressure       Pa          atrial pressure baseline and kick (P_at0, P_at_kick), or
//                                      the pulmonary-venous pressure of an atrial chamber (P_pv)
//   preload_resistance     Pa s/m^3    pulmonary-venous resistance of an atrial chamber (R_pv)
//   cavity_compliance      m^3/Pa      cavity compliance (C_cav)
//   elastance              Pa/m^3      time-varying elastance models (E_max, E_min, E_at_min, E_at_max)
//   unloaded_volume        m^3         volume at zero pressure (V0, V_at0)
// and for channels: regional_volume (V_segXX, m^3). A regional parameter or channel has segment
// 1..N (AHA segment or patch), a global one segment 0.
#pragma once

#include "model/bcs/active_law.h"
#include "model/simulator.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::model {

// The tag vocabulary above (registry tests check every model against it).
const std::vector<std::string>& parameter_families();
const std::vector<std::string>& channel_families();

// Read access to one options section (a model's `numerics:`). Keys are the section's own keys.
// Every error is reported by throwing from the reader (app/: an InputError with file:line:column
// and, for unknown keys or choices, a did-you-mean); a model never builds messages about where a
// value was written. Absent keys give the fallback.
class OptionReader {
 public:
  virtual ~OptionReader() = default;

  virtual bool defined() const = 0;                  // the section is present
  virtual bool has(const std::string& key) const = 0;
  virtual bool is_map() const = 0;
  // Dotted path of the section, e.g. "simulator.numerics", for messages.
  virtual std::string path() const = 0;
  // Every key present must be one of `allowed` (an absent section passes).
  virtual void check_keys(const std::vector<std::string>& allowed) const = 0;

  // A number in `unit`, written plainly or as "<number> <unit>" in any compatible unit.
  virtual double quantity(const std::string& key, const std::string& unit, double fallback) const = 0;
  virtual double number(const std::string& key, double fallback) const = 0;  // dimensionless
  virtual int integer(const std::string& key, int fallback) const = 0;
  // A required string that must be one of `allowed`.
  virtual std::string choice(const std::string& key, const std::vector<std::string>& allowed) const = 0;
  // A list of quantities in `unit` (the key must be present and hold a list).
  virtual std::vector<double> quantities(const std::string& key, const std::string& unit) const = 0;
  // The sub-section at `key` (absent: an undefined reader whose errors point at this section).
  virtual std::unique_ptr<OptionReader> child(const std::string& key) const = 0;

  // Text, lists of maps and file locations (the black-box models of app/blackbox/ need them).
  // The defaults serve readers that hold no such values: an absent key gives the fallback (or an
  // empty list), a present one is reported through fail().
  // A string (a command template, a path); absent: fallback.
  virtual std::string text(const std::string& key, const std::string& fallback) const;
  // true/false; absent: fallback.
  virtual bool boolean(const std::string& key, bool fallback) const;
  // The number of items of the list at `key`: 0 when absent; fail() when it is not a list.
  virtual int list_size(const std::string& key) const;
  // Item i (0-based, < list_size(key)) of the list at `key`, as a section of its own.
  virtual std::unique_ptr<OptionReader> item(const std::string& key, int i) const;
  // The value at `key` as JSON text, passed through to a model that reads it itself (a UM-Bridge
  // request's "config"); absent: "{}". Numbers stay numbers, true/false booleans, null null.
  virtual std::string json_text(const std::string& key) const;
  // The directory relative paths written in this section are relative to (the config file's);
  // empty: the working directory.
  virtual std::string base_directory() const { return {}; }

  // Reports `message` at `key` (at the section itself when key is empty or absent).
  [[noreturn]] virtual void fail(const std::string& key, const std::string& message) const = 0;
};

// The time-stepping keys every beat-by-beat model shares (`numerics:` of the lumped models and of
// lv-3d; docs/models.md): dt [s], min_beats, max_beats, periodic_tolerance, output_every,
// newton_tolerance, newton_max_iterations, read into the fields of the same names of `o`.
template <class Options>
void read_beat_numerics(const OptionReader& node, Options& o) {
  o.dt = node.quantity("dt", "s", o.dt);
  o.min_beats = node.integer("min_beats", o.min_beats);
  o.max_beats = node.integer("max_beats", o.max_beats);
  o.periodic_tolerance = node.number("periodic_tolerance", o.periodic_tolerance);
  o.output_every = node.integer("output_every", o.output_every);
  o.newton_tolerance = node.number("newton_tolerance", o.newton_tolerance);
  o.newton_max_iterations = node.integer("newton_max_iterations", o.newton_max_iterations);
}

// The key `activation_shape` of a BCS model's numerics (docs/models.md s.1, "Activation input"):
// `square` (the default) or `ramped`, or a map {shape: ramped, rise, fall, relax_ramp, relax_hold,
// rest_ramp, rest} whose keys left out keep Caruel et al. 2014's values (bcs::RampedActivation).
// Errors are reported at the key through the reader.
void read_activation_input(const OptionReader& node, bcs::ActivationInput& input);

// An absent section: every value is its fallback, fail() throws std::invalid_argument. What a
// model is built with when nothing is configured (tests, `builtin_models()` defaults).
class NoOptions final : public OptionReader {
 public:
  bool defined() const override { return false; }
  bool has(const std::string&) const override { return false; }
  bool is_map() const override { return false; }
  std::string path() const override { return "numerics"; }
  void check_keys(const std::vector<std::string>&) const override {}
  double quantity(const std::string&, const std::string&, double fallback) const override { return fallback; }
  double number(const std::string&, double fallback) const override { return fallback; }
  int integer(const std::string&, int fallback) const override { return fallback; }
  std::string choice(const std::string& key, const std::vector<std::string>&) const override;
  std::vector<double> quantities(const std::string& key, const std::string&) const override;
  std::unique_ptr<OptionReader> child(const std::string&) const override;
  [[noreturn]] void fail(const std::string& key, const std::string& message) const override;
};

// A model configured by its numerics: the parameter table (units, nominal values, bounds, doc
// and tags; nominal values may depend on the numerics, e.g. the regional activation pattern sets
// Td_XX) and a factory of simulators with those numerics. Copyable; the options live in the
// factory, nowhere else.
class ModelBuild {
 public:
  using Factory = std::function<std::unique_ptr<Simulator>(const ParameterSpace& parameters)>;

  ModelBuild() = default;
  ModelBuild(ParameterSpace parameters, Factory factory)
      : parameters_(std::move(parameters)), factory_(std::move(factory)) {}

  const ParameterSpace& parameters() const { return parameters_; }
  // A new simulator whose parameter space is `parameters` (the nominal values to run; same names
  // and order as parameters()). std::invalid_argument when the build is empty.
  std::unique_ptr<Simulator> make(const ParameterSpace& parameters) const;
  std::unique_ptr<Simulator> make() const { return make(parameters_); }

 private:
  ParameterSpace parameters_;
  Factory factory_;
};

// One simulator family as a config names it.
// A named set of parameter values (SI, by parameter name) applied over a build's defaults, before
// the config's own `parameters:` (`simulator: {model: lumped-sphere, preset: heart-failure}`).
// A preset may also need numerics (lv-3d's `lbbb-heart-failure`: the LBBB activation and a dilated
// geometry): `numerics` holds their values as text in SI units, keyed by their dotted path inside
// `numerics:` ("activation", "geometry.r_short_endo"); the config's own numerics override them key
// by key (with_defaults below).
struct Preset {
  std::string name;  // e.g. "heart-failure"
  std::string doc;   // one line: what it represents and where its values come from
  std::vector<std::pair<std::string, double>> values;
  std::vector<std::pair<std::string, std::string>> numerics;
};

// `section` read over `defaults` (dotted keys, values as text in SI units, as Preset::numerics): a
// key present in `section` gives its value; an absent key with a default gives the default; other
// keys give the fallback. Sub-sections (child) carry the defaults under their prefix. Errors are
// reported by `section` (a default that the model refuses is reported at the section). `section`
// must outlive the reader. std::logic_error when a default is not a number where one is read or
// not one of a choice's values (a preset defined wrongly, not bad input).
std::unique_ptr<OptionReader> with_defaults(const OptionReader& section,
                                            std::vector<std::pair<std::string, std::string>> defaults);

struct ModelSetup {
  std::string name;  // as written in configs, e.g. "lumped-sphere"
  std::string doc;   // one line for `params` and error messages
  // Parses and validates the `numerics:` section; errors go through the reader.
  std::function<ModelBuild(const OptionReader& numerics)> configure;
  std::vector<Preset> presets;  // may be empty

  ModelBuild configure_defaults() const { return configure(NoOptions{}); }
  const Preset* find_preset(const std::string& preset) const;  // nullptr when unknown
  std::vector<std::string> preset_names() const;
};

// The models known to a run. A value: copy the built-in one and add to it.
class ModelRegistry {
 public:
  // Adds a model; std::invalid_argument when the name is taken or the setup has no configure.
  void add(ModelSetup setup);
  // nullptr when no model has that name.
  const ModelSetup* find(const std::string& name) const;
  std::vector<std::string> names() const;  // in the order added
  const std::vector<ModelSetup>& all() const { return setups_; }

 private:
  std::vector<ModelSetup> setups_;
};

// The models of this library (lumped-sphere, lumped-regional), built once.
const ModelRegistry& builtin_models();

}  // namespace sigmaheart::model
