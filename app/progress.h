// A progress line on the terminal for long runs: "calibrate: iteration 2, 7/11 runs, ETA 4 s".
// On a terminal the line is redrawn in place (at most 5 times a second); otherwise (CI logs,
// files) one line is printed when a stage ends, and every 10 s during a long stage. Thread-safe: update() may be called from
// worker threads.
#pragma once

#include <chrono>
#include <mutex>
#include <ostream>
#include <string>

namespace sigmaheart::app {

class ProgressLine {
 public:
  ProgressLine(std::ostream& out, std::string label, bool enabled = true);
  ~ProgressLine();

  // Starts a new stage (e.g. one iteration) of `total` units of work.
  void start(const std::string& stage, int total);
  void update(int done);
  // Ends the current line (prints the stage's elapsed time).
  void finish();

 private:
  void draw(int done, bool final);

  std::ostream& out_;
  std::string label_;
  std::string stage_;
  bool enabled_ = true;
  bool tty_ = false;
  bool open_ = false;
  int total_ = 0;
  int done_ = 0;  // the last count drawn (what the line shows when a stage ends early)
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::mutex mutex_;
};

}  // namespace sigmaheart::app
