// The registry of simulators a config can name in `simulator.model:`. Each entry knows its
// parameters and parses its own `numerics:` section into its typed options, so adding a model
// (regional lumped, 3D, external) is one register_simulator() call in simulators.cpp.
#pragma once

#include "app/config_node.h"
#include "model/simulator.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app {

// Builds a simulator with the given parameter space (nominal values = the config's values).
using SimulatorBuilder =
    std::function<std::unique_ptr<model::Simulator>(const model::ParameterSpace& parameters)>;

struct SimulatorEntry {
  std::string name;  // as written in configs, e.g. "lumped-sphere"
  std::string doc;   // one line for --help and `params`
  // The model's parameters with their default nominal values, SI units and bounds.
  std::function<model::ParameterSpace()> default_parameters;
  // Parses and validates the `numerics:` section (an undefined node gives the defaults) and
  // returns the builder; throws InputError for bad numerics.
  std::function<SimulatorBuilder(const ConfigNode& numerics)> parse_numerics;
};

// Adds an entry, replacing one of the same name (tests register stand-ins this way).
void register_simulator(SimulatorEntry entry);
// nullptr when no simulator has that name.
const SimulatorEntry* find_simulator(const std::string& name);
std::vector<std::string> simulator_names();

}  // namespace sigmaheart::app
