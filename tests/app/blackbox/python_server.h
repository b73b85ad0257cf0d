// A python3 program serving UM-Bridge on a free loopback port for one test: started with
// `--port 0`, its first stdout line "listening on http://127.0.0.1:PORT" gives the address;
// SIGTERM (by its pid) when the test ends.
#pragma once

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

namespace sigmaheart::testing {

class PythonServer {
 public:
  // `script` and its arguments (python3 is Debian's, /usr/bin/python3, when present).
  explicit PythonServer(const std::string& script, const std::vector<std::string>& args) {
    std::string cmd = "exec /usr/bin/python3 -u '" + script + "'";
    for (const auto& a : args) cmd += " '" + a + "'";
    int out[2];
    if (::pipe(out) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], 1);
      ::close(out[0]);
      ::close(out[1]);
      ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(out[1]);
    FILE* f = ::fdopen(out[0], "r");
    char line[256] = {};
    if (f != nullptr && std::fgets(line, sizeof line, f) != nullptr) {
      const std::string text(line);
      const auto at = text.find("http://");
      if (at != std::string::npos) url_ = text.substr(at, text.find_first_of("\r\n", at) - at);
    }
    stdout_ = f;  // kept open so the server never writes into a closed pipe
  }
  ~PythonServer() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
    if (stdout_ != nullptr) std::fclose(stdout_);
  }
  PythonServer(const PythonServer&) = delete;
  PythonServer& operator=(const PythonServer&) = delete;

  // "http://127.0.0.1:PORT"; empty when the program did not start.
  const std::string& url() const { return url_; }

 private:
  int pid_ = -1;
  FILE* stdout_ = nullptr;
  std::string url_;
};

// The UM-Bridge benchmark server of this folder (umbridge_models.py) for `model`.
inline std::string benchmark_script() {
  return std::string(SIGMAHEART_SOURCE_DIR) + "/tests/app/blackbox/umbridge_models.py";
}

}  // namespace sigmaheart::testing
