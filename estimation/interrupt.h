// Interruption by SIGINT or SIGTERM (docs/architecture.md s.7, "Interruption and resume").
//
// app/cli.cpp installs handlers that only record the signal (async-signal-safe: one atomic store);
// a second signal of the same kind restores the default action, so pressing Ctrl-C twice kills at
// once. Long loops do not poll the flag themselves: Ensemble checks it before each member (a
// member not started is StatusCode::kCancelled) and after each batch, where it saves the finished
// members to the checkpoint and throws Interrupted; the command then exits with 128 + signal
// (130 for SIGINT, 143 for SIGTERM), the shell's convention for "killed by this signal".
#pragma once

namespace sigmaheart::estimation {

// Thrown (by value) when a run stops because of a signal. Deliberately not a std::exception, so
// estimators that turn a member's or a case's std::exception into a failure Status do not swallow
// it; code that catches (...) must rethrow it.
struct Interrupted {
  int signal = 0;  // SIGINT or SIGTERM
};

// The signal received since the last clear, 0 when none.
int interrupt_signal();
// Records a signal (what the handler does; tests call it directly).
void request_interrupt(int signal);
void clear_interrupt();

// Installs the SIGINT/SIGTERM handlers (process-wide; idempotent).
void install_interrupt_handlers();

}  // namespace sigmaheart::estimation
