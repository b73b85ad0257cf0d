// Runs one external program to completion or to its time limit, without a shell (posix_spawn).
// Used by the external simulator (external_model.h) for every ensemble member; safe to call from
// several threads at once (nothing shared; every call waits only for its own child).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace sigmaheart::app::blackbox {

struct ProcessOptions {
  std::string executable;           // absolute path (resolve_executable); argv[0] is argv.front()
  std::vector<std::string> argv;    // the whole argument vector, argv[0] included
  std::filesystem::path workdir;    // the child's working directory (must exist)
  std::filesystem::path stdout_file;  // created or truncated; the child's stdout
  std::filesystem::path stderr_file;  // created or truncated; the child's stderr
  double timeout = 0.0;             // [s]; <= 0: no limit
  double kill_grace = 1.0;          // [s] between SIGTERM and SIGKILL after the time limit
};

struct ProcessResult {
  bool started = false;      // false: posix_spawn failed (error says why)
  bool timed_out = false;    // killed after the time limit (SIGTERM, then SIGKILL)
  bool exited = false;       // exited normally with exit_code
  int exit_code = -1;
  int signal = 0;            // the signal that ended it (when !exited)
  double elapsed = 0.0;      // [s] wall time from spawn to reaping
  std::string error;         // set when !started

  bool ok() const { return started && exited && exit_code == 0 && !timed_out; }
  // "exit code 3", "killed by signal 9 (Killed)", "timed out after 30 s", ...
  std::string describe(double timeout) const;
};

// Spawns the program in a new process group (stdin from /dev/null) and waits. After the time
// limit the whole group gets SIGTERM, then SIGKILL after kill_grace; once the program has ended,
// whatever it left running in its group is killed too, so no member leaves processes behind.
ProcessResult run_process(const ProcessOptions& options);

// The last `lines` lines of a text file (at most `max_bytes` from its end), "" when unreadable.
std::string tail_lines(const std::filesystem::path& file, int lines = 10, size_t max_bytes = 4096);

}  // namespace sigmaheart::app::blackbox
