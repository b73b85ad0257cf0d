// The error types of the command line and their exit codes (docs/architecture.md, "Errors, in three
// tiers"). Bad input is an InputError that names the place (file:line:column) and what was
// expected; a forward run that fails is a RunFailure. main() maps them to distinct exit codes.
#pragma once

#include <stdexcept>
#include <string>

namespace sigmaheart::app {

// Exit codes of `sigmaheart`, documented in the --help footer.
enum ExitCode : int {
  kExitOk = 0,
  kExitRuntimeFailure = 1,  // the input was fine but the work failed (simulation diverged ...)
  kExitBadInput = 2,        // config, data file, unknown key, value out of bounds, bad option
  // Stopped by a signal: 128 + its number (130 SIGINT, 143 SIGTERM), the shell's convention. The
  // finished members are in the checkpoint; --resume continues (docs/architecture.md s.7).
  kExitInterruptedBase = 128,
};

// Where a piece of input came from. line and column are 1-based; 0 means unknown (a command-line
// override, a file that could not be opened).
struct Location {
  std::string file;  // a path, or an origin such as "--set sigma0=1"
  int line = 0;
  int column = 0;

  // "file:line:column", "file:line" or "file", whichever is known.
  std::string str() const;
};

// Bad input, reported before any work starts. what() is "file:line:column: message".
class InputError : public std::runtime_error {
 public:
  InputError(Location where, const std::string& message);
  InputError(const std::string& file, int line, int column, const std::string& message)
      : InputError(Location{file, line, column}, message) {}

  const Location& where() const { return where_; }
  const std::string& file() const { return where_.file; }
  int line() const { return where_.line; }
  int column() const { return where_.column; }
  const std::string& message() const { return message_; }

 private:
  Location where_;
  std::string message_;
};

// A failure of the work itself (a forward run that did not converge, a file that could not be
// written); exit code 1.
class RunFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace sigmaheart::app
