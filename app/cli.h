// The `sigmaheart` command line as a function, so tests can run commands in-process with their
// own output streams. main() is run_cli(argc, argv, std::cout, std::cerr).
#pragma once

#include "model/registry.h"

#include <ostream>
#include <string>
#include <vector>

namespace sigmaheart::app {

// Parses the arguments, runs the chosen command and returns the exit code (errors.h: 0 ok,
// 1 runtime failure, 2 bad input). Never throws. Configs may name the models of `models`; tests
// pass the built-in registry plus test-only models to run the real commands on them.
int run_cli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
            const model::ModelRegistry& models = model::builtin_models());
// The same with the arguments after the program name, e.g. {"validate", "configs/healthy.yaml"}.
int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
            const model::ModelRegistry& models = model::builtin_models());

}  // namespace sigmaheart::app
