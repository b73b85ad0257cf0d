#include "estimation/interrupt.h"

#include <atomic>
#include <csignal>

namespace sigmaheart::estimation {

namespace {
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler needs a lock-free store");

extern "C" void on_signal(int signal) {
  if (g_signal.load() == signal) {
    // The second Ctrl-C: give up waiting for running members.
    std::signal(signal, SIG_DFL);
    std::raise(signal);
    return;
  }
  g_signal.store(signal);
}
}  // namespace

int interrupt_signal() { return g_signal.load(); }
void request_interrupt(int signal) { g_signal.store(signal); }
void clear_interrupt() { g_signal.store(0); }

void install_interrupt_handlers() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace sigmaheart::estimation
