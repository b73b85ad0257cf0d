#include "app/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

namespace sigmaheart::app {

namespace {
std::string format_seconds(double s) {
  std::ostringstream o;
  if (s < 10) {
    o << std::fixed << std::setprecision(1) << s << " s";
  } else if (s < 60) {
    o << static_cast<int>(std::ceil(s)) << " s";
  } else {
    o << static_cast<int>(s / 60) << " min " << static_cast<int>(std::fmod(s, 60.0)) << " s";
  }
  return o.str();
}
}  // namespace

ProgressLine::ProgressLine(std::ostream& out, std::string label, bool enabled)
    : out_(out), label_(std::move(label)), enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0) {}

ProgressLine::~ProgressLine() {
  // A stage still open here ended early (an error or a signal unwound the command): the line
  // keeps the count reached, not the total.
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_) return;
  draw(done_, true);
  open_ = false;
}

void ProgressLine::start(const std::string& stage, int total) {
  std::lock_guard<std::mutex> lock(mutex_);
  stage_ = stage;
  total_ = total;
  done_ = 0;
  start_ = last_draw_ = std::chrono::steady_clock::now();
  open_ = true;
  draw(0, false);
}

void ProgressLine::update(int done) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_) return;
  done_ = done;
  draw(done, false);
}

void ProgressLine::finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_) return;
  draw(total_, true);
  open_ = false;
}

void ProgressLine::draw(int done, bool final) {
  if (!enabled_ || total_ <= 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (tty_) {
    if (!final && done > 0 && done < total_ && now - last_draw_ < std::chrono::milliseconds(200)) return;
  } else {
    // Logs: one line per stage when it ends, and a line every 10 s while a long stage runs.
    if (!final && now - last_draw_ < std::chrono::seconds(10)) return;
  }
  last_draw_ = now;
  std::ostringstream line;
  line << label_ << ": " << stage_ << ", " << done << "/" << total_ << " runs";
  if (final || done >= total_) {
    line << ", " << format_seconds(elapsed);
  } else if (done > 0) {
    line << ", ETA " << format_seconds(elapsed / done * (total_ - done));
  }
  if (tty_) {
    out_ << "\r\033[K" << line.str() << (final ? "\n" : "") << std::flush;
  } else {
    out_ << line.str() << "\n" << std::flush;
  }
}

}  // namespace sigmaheart::app
