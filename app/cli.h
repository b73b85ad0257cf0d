// The `sigmaheart` command line as a function, so tests can run commands in-process with their
// own output streams. main() is run_cli(argc, argv, std::cout, std::cerr, world communicator).
#pragma once

#include "model/registry.h"

#include <ostream>
#include <string>
#include <vector>

namespace sigmaheart::estimation::parallel {
class Communicator;
}

namespace sigmaheart::app {

// Parses the arguments, runs the chosen command and returns the exit code (errors.h: 0 ok,
// 1 runtime failure, 2 bad input), on one rank. Never throws. Configs may name the models of
// `models`; tests pass the built-in registry plus test-only models to run the real commands on
// them.
int run_cli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
            const model::ModelRegistry& models = model::builtin_models());
// The same on every rank of `comm` (main() passes the MPI world; collective). Only rank 0 prints
// (out, err, logs) and writes files; the others run the same command silently. Every rank returns
// the largest exit code of all ranks, also when a command failed on one rank only (e.g. an output
// file that rank 0 could not write); a rank that failed alone, while rank 0 succeeded, prints
// its error prefixed with "rank N: ".
int run_cli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
            estimation::parallel::Communicator& comm,
            const model::ModelRegistry& models = model::builtin_models());
// The same with the arguments after the program name, e.g. {"validate", "configs/healthy.yaml"}.
int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
            const model::ModelRegistry& models = model::builtin_models());

}  // namespace sigmaheart::app
