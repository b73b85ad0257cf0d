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
// model/registry.h. Channel units must be known to model/units.h and are stored as their SI unit
// (outputs are converted on reading).
#pragma once

#include "model/registry.h"

#include <string>
#include <vector>

namespace sigmaheart::app::blackbox {

// True when `unit` is known to model/units.h or is a product of SI symbols with powers.
bool known_unit(const std::string& unit);

// The `parameters:` list (at least one item).
model::ParameterSpace read_parameter_table(const model::OptionReader& numerics,
                                           const std::string& key = "parameters");
// The `channels:` list (at least one item); units as their SI equivalent.
std::vector<model::Channel> read_channel_table(const model::OptionReader& numerics,
                                               const std::string& key = "channels");

}  // namespace sigmaheart::app::blackbox
