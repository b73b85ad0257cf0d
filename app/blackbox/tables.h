// The parameter and channel tables a black-box model declares in its `numerics:` (the program
// cannot tell us): shared by `model: external` and `model: umbridge`.
//
//   parameters:                    # one map per parameter, in the order of theta
//     - {name: E_max, unit: Pa/m^3, nominal: 2.0e8, lower: 5e7, upper: 1e9, family: elastance,
//        doc: "end-systolic elastance"}
//   channels:                      # what the output holds
//     - {name: V_lv, unit: m^3}
//
// Checked on reading, each error located in the config: names unique identifiers; units either
// known to model/units.h or an SI product of the symbols m, s, kg, Pa, N, J, W, K, mol, A with
// powers (Pa/m^3, Pa s/m^3, m^3/(Pa s)); nominal, lower and upper finite with
// lower < upper and lower <= nominal <= upper; a family from the tag vocabulary of
// model/registry.h. Channel units must be known to model/units.h.
//
// Every value crosses the adapter in its declared unit and lives inside sigmaheart in SI: a
// parameter declared in mL is held in m^3 (ParameterSpace, bounds and nominal in SI) and handed
// to the program as theta_i / factor_i in mL; a channel declared in mmHg is multiplied by its
// factor on reading. A unit that is missing or unknown is refused at the config (exit 2).
#pragma once

#include "model/registry.h"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app::blackbox {

// True when `unit` is known to model/units.h or is a product of SI symbols with powers.
bool known_unit(const std::string& unit);

// value_SI = factor * value in `unit`: how one declared quantity crosses the adapter.
struct DeclaredUnit {
  std::string unit;     // as written in the table ("mL", "Pa/m^3", "1")
  double factor = 1.0;  // to SI (1 for an SI product such as Pa s/m^3)
};

// The `parameters:` list (at least one item), in SI. With input_vectors, an item may name the
// UM-Bridge input vector it belongs to (`input: 1`; default 0).
model::ParameterSpace read_parameter_table(const model::OptionReader& numerics,
                                           const std::string& key = "parameters",
                                           bool input_vectors = false);
// The `input:` of every item of that table (0 when absent).
std::vector<int> input_vectors(const model::OptionReader& numerics, const std::string& key = "parameters");
// The `channels:` list (at least one item); units as their SI equivalent.
std::vector<model::Channel> read_channel_table(const model::OptionReader& numerics,
                                               const std::string& key = "channels");
// The declared unit of every item of a table read above (same order); the table must have been
// read (checked) first.
std::vector<DeclaredUnit> declared_units(const model::OptionReader& numerics, const std::string& key);
// The factors of declared_units, as a vector (value_SI = factors .* value_declared).
Eigen::VectorXd unit_factors(const std::vector<DeclaredUnit>& declared);

// Where the period of a returned curve comes from (the time axis is the model's own):
//   period: 0.8 s      fixed;
//   period: period     the parameter of that name (unit s), read from theta at every run, so a
//                      study of the period moves the time axis with it.
// A fixed period while the table has a parameter of family "period" is refused (a study of it
// would sample the curves on a time axis the model did not use).
struct PeriodSource {
  double fixed = 0.0;  // [s]; 0: none
  int parameter = -1;  // index in theta; -1: none
  bool defined() const { return fixed > 0.0 || parameter >= 0; }
  // [s]; 0 when not defined.
  double of(const Eigen::Ref<const Eigen::VectorXd>& theta) const {
    return parameter >= 0 ? theta(parameter) : fixed;
  }
};
// `required`: a missing key fails; otherwise it gives the period parameter when the table has
// one (family "period"), else none.
PeriodSource read_period(const model::OptionReader& numerics, const model::ParameterSpace& parameters,
                         bool required);

// How a black-box simulator refuses a theta outside its declared table: the run result with status
// kOutOfBounds and the reason, or nullopt when theta is inside the bounds.
std::optional<model::RunResult> refuse_out_of_bounds(const model::ParameterSpace& parameters,
                                                     const Eigen::Ref<const Eigen::VectorXd>& theta);

}  // namespace sigmaheart::app::blackbox
